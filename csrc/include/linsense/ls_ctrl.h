/* linsense firmware library: controllers.
 *
 * ls_pi       PI with output limits and anti-windup by conditional integration (no
 *             integration while the output is limited in the direction the error pushes, and the
 *             integrator kept within the output range): leaves the limit as soon as the error
 *             reverses.
 * ls_current  d/q current PI with decoupling (-omega L_q i_q, omega (L_d i_d + psi_pm)) and a
 *             voltage vector limited to a circle of radius v_max (from the DC bus), with the
 *             same conditional-integration anti-windup per axis.
 * ls_posctrl  position P (-> speed PI -> force) or PD (-> force), with speed and acceleration
 *             feed-forward.
 */
#ifndef LINSENSE_LS_CTRL_H
#define LINSENSE_LS_CTRL_H

#include "linsense/ls_types.h"

/* ------------------------------------------------------------------------------- PI */
typedef struct {
    LS_REAL kp;      /* output unit per input unit, > 0 */
    LS_REAL ki;      /* output unit per input unit and second, >= 0 */
    LS_REAL out_min; /* lower output limit, < out_max */
    LS_REAL out_max; /* upper output limit */
    LS_REAL fs;      /* Hz, sampling rate, > 0 */
} ls_pi_cfg;

typedef struct {
    ls_pi_cfg cfg;   /* copy of the configuration */
    LS_REAL integ;   /* integrator state, output unit */
    LS_REAL ts;      /* s, sampling period */
    bool saturated;  /* output was limited at the last step */
    LS_REAL ki_ts;   /* output unit per input unit, ki ts */
} ls_pi;

ls_status ls_pi_init(ls_pi *pi, const ls_pi_cfg *cfg);
void ls_pi_reset(ls_pi *pi);
/* The step functions are inline (called every PWM period). Each ls_<x>_step guards its inputs
 * against NaN and Inf; ls_<x>_step_finite is the same step without that guard, for a caller whose
 * inputs are finite by construction (the drive, after its own checks). */

/* ls_pi_step for finite err and ff. */
static inline LS_REAL ls_pi_step_finite(ls_pi *pi, LS_REAL err, LS_REAL ff)
{
    LS_REAL integ, u, u_lim;
    integ = pi->integ + pi->ki_ts * err;
    /* = kp err + integ + ff, with err entering late through a single product */
    u = (pi->cfg.kp + pi->ki_ts) * err + (pi->integ + ff);
    u_lim = ls_clamp(u, pi->cfg.out_min, pi->cfg.out_max);
    pi->saturated = u_lim != u;
    /* conditional integration: no integration that would push further into the limit */
    if (!(pi->saturated && (u > pi->cfg.out_max) == (err > LS_R(0.0)))) {
        pi->integ = ls_clamp(integ, pi->cfg.out_min, pi->cfg.out_max);
    }
    return u_lim;
}

/* u = kp e + integ + ff, limited; see the anti-windup rule above. A non-finite err or ff counts
 * as 0. */
static inline LS_REAL ls_pi_step(ls_pi *pi, LS_REAL err, LS_REAL ff)
{
    if (!LS_ISFINITE2(err, ff)) {
        if (!LS_ISFINITE(err)) {
            err = LS_R(0.0);
        }
        if (!LS_ISFINITE(ff)) {
            ff = LS_R(0.0);
        }
    }
    return ls_pi_step_finite(pi, err, ff);
}

/* ------------------------------------------------------------------------------- current */
/* Bounds ls_current_init enforces: far beyond any drive (a 1 H motor at 100 kHz of bandwidth
 * needs kp = 6e5 V/A), and with them and the drive's bounds on currents (1e5 A), speed
 * (omega_max Ts <= pi at fs <= 1 MHz) and bus (1e5 V) the voltage vector stays below 1e18 V, so
 * its square cannot overflow a float (the limit is overflow-proof anyway, see below). */
#define LS_CURRENT_KP_MAX LS_R(1.0e6)  /* V/A, largest kp, and largest ki Ts */
#define LS_CURRENT_L_MAX LS_R(100.0)   /* H, largest l_d, l_q */
#define LS_CURRENT_PSI_MAX LS_R(100.0) /* Wb, largest psi_pm */

typedef struct {
    LS_REAL kp;       /* V/A, proportional gain (both axes), > 0, <= LS_CURRENT_KP_MAX */
    LS_REAL ki;       /* V/(A s), integral gain (both axes), >= 0, ki Ts <= LS_CURRENT_KP_MAX */
    LS_REAL l_d;      /* H, d-axis inductance for decoupling, [0, LS_CURRENT_L_MAX] */
    LS_REAL l_q;      /* H, q-axis inductance for decoupling, [0, LS_CURRENT_L_MAX] */
    LS_REAL psi_pm;   /* Wb, PM flux linkage for back-EMF feed-forward, [0, LS_CURRENT_PSI_MAX] */
    bool decouple;    /* add the decoupling and back-EMF terms */
    LS_REAL fs;       /* Hz, sampling rate, > 0 */
} ls_current_cfg;

typedef struct {
    ls_current_cfg cfg; /* copy of the configuration */
    LS_REAL integ_d;    /* V, d integrator */
    LS_REAL integ_q;    /* V, q integrator */
    LS_REAL ts;         /* s, sampling period */
    bool saturated;     /* voltage limited at the last step */
    LS_REAL ki_ts;      /* V/A, ki ts */
} ls_current;

ls_status ls_current_init(ls_current *c, const ls_current_cfg *cfg);
void ls_current_reset(ls_current *c);
/* (v_d, v_q) scaled onto the circle of radius v_max > 0 without squaring them (no overflow; an
 * infinite component gives its direction, NaN stays NaN); out of line: the current step's slow
 * path when |v|^2 overflowed. */
void ls_current_limit_wide(LS_REAL v_max, LS_REAL *v_d, LS_REAL *v_q);
/* ls_current_step for finite currents, references, omega and v_max. */
static inline void ls_current_step_finite(ls_current *c, LS_REAL i_d, LS_REAL i_q, LS_REAL i_d_ref,
                                          LS_REAL i_q_ref, LS_REAL omega, LS_REAL v_max, LS_REAL *v_d,
                                          LS_REAL *v_q)
{
    const ls_current_cfg *k = &c->cfg;
    const LS_REAL e_d = i_d_ref - i_d;
    const LS_REAL e_q = i_q_ref - i_q;
    LS_REAL ff_d = LS_R(0.0), ff_q = LS_R(0.0);
    LS_REAL ud, uq, mag2, vmax2, id_step, iq_step, kpi;
    if (!(v_max > LS_R(0.0))) {
        *v_d = LS_R(0.0);
        *v_q = LS_R(0.0);
        return;
    }
    if (k->decouple) {
        ff_d = -omega * k->l_q * i_q;
        ff_q = omega * (k->l_d * i_d + k->psi_pm);
    }
    id_step = c->ki_ts * e_d;
    iq_step = c->ki_ts * e_q;
    /* = kp e + integ + ki ts e + ff, with e entering late through a single product */
    kpi = k->kp + c->ki_ts;
    ud = kpi * e_d + (c->integ_d + ff_d);
    uq = kpi * e_q + (c->integ_q + ff_q);
    mag2 = ud * ud + uq * uq;
    vmax2 = v_max * v_max;
    c->saturated = mag2 > vmax2;
    /* conditional integration: an axis integrates unless the vector is limited and that axis'
     * error pushes its voltage further out */
    if (!c->saturated || (e_d > LS_R(0.0)) != (ud > LS_R(0.0))) {
        c->integ_d = ls_clamp(c->integ_d + id_step, -v_max, v_max);
    }
    if (!c->saturated || (e_q > LS_R(0.0)) != (uq > LS_R(0.0))) {
        c->integ_q = ls_clamp(c->integ_q + iq_step, -v_max, v_max);
    }
    if (c->saturated) {
        const LS_REAL scale = v_max / LS_SQRT(mag2);
        if (scale > LS_R(0.0)) {
            ud *= scale;
            uq *= scale;
        } else { /* ud^2 + uq^2 overflowed to Inf (scale 0): scale before squaring */
            ls_current_limit_wide(v_max, &ud, &uq);
        }
    }
    *v_d = ud;
    *v_q = uq;
}

/* i_d, i_q: measured (A); i_d_ref, i_q_ref (A); omega: electrical speed (rad/s); v_max (V):
 * radius of the allowed voltage circle. Writes v_d, v_q (V); 0 for non-finite inputs. */
static inline void ls_current_step(ls_current *c, LS_REAL i_d, LS_REAL i_q, LS_REAL i_d_ref,
                                   LS_REAL i_q_ref, LS_REAL omega, LS_REAL v_max, LS_REAL *v_d, LS_REAL *v_q)
{
    if (!LS_ISFINITE3(i_d_ref - i_d, i_q_ref - i_q, omega)) {
        *v_d = LS_R(0.0);
        *v_q = LS_R(0.0);
        return;
    }
    ls_current_step_finite(c, i_d, i_q, i_d_ref, i_q_ref, omega, v_max, v_d, v_q);
}

/* ------------------------------------------------------------------------------- position */
typedef enum {
    LS_POSCTRL_P = 0,  /* position P -> speed reference -> speed PI -> force */
    LS_POSCTRL_PD = 1  /* position PD -> force */
} ls_posctrl_type;

typedef struct {
    ls_posctrl_type type; /* structure */
    LS_REAL kp_x;         /* P: 1/s (m/s per m); PD: N/m, > 0 */
    LS_REAL kd_x;         /* PD: N s/m (damping on the speed error), >= 0 */
    LS_REAL v_max;        /* m/s, speed-reference limit (P), > 0 */
    ls_pi_cfg speed;      /* speed PI (P type): N per m/s, N per m; limits in N */
    LS_REAL mass;         /* kg, for the acceleration feed-forward, >= 0 */
    LS_REAL force_max;    /* N, force limit, > 0 */
} ls_posctrl_cfg;

typedef struct {
    ls_posctrl_cfg cfg; /* copy of the configuration */
    ls_pi speed;        /* speed PI (P type) */
    LS_REAL v_ref;      /* m/s, speed reference at the last step (P type) */
} ls_posctrl;

ls_status ls_posctrl_init(ls_posctrl *p, const ls_posctrl_cfg *cfg);
void ls_posctrl_reset(ls_posctrl *p);
/* ls_posctrl_step for finite x_err, v, v_ff and mass a_ff (and a finite v_ref - v). */
static inline LS_REAL ls_posctrl_step_finite(ls_posctrl *p, LS_REAL x_err, LS_REAL v, LS_REAL v_ff,
                                             LS_REAL a_ff)
{
    const ls_posctrl_cfg *k = &p->cfg;
    const LS_REAL f_ff = k->mass * a_ff;
    if (k->type == LS_POSCTRL_P) {
        p->v_ref = ls_clamp(k->kp_x * x_err + v_ff, -k->v_max, k->v_max);
        return ls_pi_step_finite(&p->speed, p->v_ref - v, f_ff);
    }
    return ls_clamp(k->kp_x * x_err + k->kd_x * (v_ff - v) + f_ff, -k->force_max, k->force_max);
}

/* x_err = x_ref - x (m), v (m/s), v_ff (m/s), a_ff (m/s^2). Returns the force reference (N); 0
 * for non-finite inputs. */
static inline LS_REAL ls_posctrl_step(ls_posctrl *p, LS_REAL x_err, LS_REAL v, LS_REAL v_ff, LS_REAL a_ff)
{
    const ls_posctrl_cfg *k = &p->cfg;
    const LS_REAL f_ff = k->mass * a_ff;
    if (!LS_ISFINITE4(x_err, v, v_ff, f_ff)) {
        return LS_R(0.0);
    }
    if (k->type == LS_POSCTRL_P) {
        p->v_ref = ls_clamp(k->kp_x * x_err + v_ff, -k->v_max, k->v_max);
        return ls_pi_step(&p->speed, p->v_ref - v, f_ff); /* v_ref - v may still overflow */
    }
    return ls_clamp(k->kp_x * x_err + k->kd_x * (v_ff - v) + f_ff, -k->force_max, k->force_max);
}

#endif /* LINSENSE_LS_CTRL_H */
