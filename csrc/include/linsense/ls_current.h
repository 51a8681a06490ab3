/* linsense firmware library: d/q current controller.
 *
 * ls_current  d/q current PI with decoupling (-omega L_q i_q, omega (L_d i_d + psi_pm)) and a
 *             voltage vector limited to a circle of radius v_max (from the DC bus), with the
 *             same conditional-integration anti-windup per axis as ls_pi (ls_pi.h).
 */
#ifndef LINSENSE_LS_CURRENT_H
#define LINSENSE_LS_CURRENT_H

#include "linsense/ls_types.h"

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

#endif /* LINSENSE_LS_CURRENT_H */
