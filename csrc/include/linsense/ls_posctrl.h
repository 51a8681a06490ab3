/* linsense firmware library: position controller.
 *
 * ls_posctrl  position P (-> speed PI -> force) or PD (-> force), with speed and acceleration
 *             feed-forward, and (P) the friction fed forward at the speed PI's reference v_ref:
 *             viscous fric_v v plus Coulomb
 *             clamp(fric_c v / fric_band, -fric_c, fric_c), the Coulomb force linear below fric_band
 *             (the dither of an injection averages the relay into that slope: docs/tuning.md,
 *             "Friction and thrust ripple").
 */
#ifndef LINSENSE_LS_POSCTRL_H
#define LINSENSE_LS_POSCTRL_H

#include "linsense/ls_pi.h"
#include "linsense/ls_types.h"

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
    LS_REAL fric_c;       /**< unit: N, Coulomb friction fed forward (P type), >= 0 (0: none) */
    LS_REAL fric_v;       /**< unit: N s/m, viscous friction fed forward (P type), >= 0 (0: none) */
    LS_REAL fric_band;    /**< unit: m/s, the speed below which the Coulomb force is linear (its slope
                               fric_c / fric_band), > 0 with fric_c > 0 */
} ls_posctrl_cfg;

typedef struct {
    ls_posctrl_cfg cfg; /* copy of the configuration */
    ls_pi speed;        /* speed PI (P type) */
    LS_REAL v_ref;      /* m/s, speed reference at the last step (P type) */
    LS_REAL fric_k;     /* N s/m, fric_c / fric_band (0 without Coulomb friction) */
    bool fric_on;       /* fric_c or fric_v > 0 (else the friction costs no cycle) */
} ls_posctrl;

ls_status ls_posctrl_init(ls_posctrl *p, const ls_posctrl_cfg *cfg);
void ls_posctrl_reset(ls_posctrl *p);
/* ls_posctrl_step for finite x_err, v, v_ff and mass a_ff (and a finite v_ref - v). */
static inline LS_REAL ls_posctrl_step_finite(ls_posctrl *p, LS_REAL x_err, LS_REAL v, LS_REAL v_ff,
                                             LS_REAL a_ff)
{
    const ls_posctrl_cfg *k = &p->cfg;
    LS_REAL f_ff = k->mass * a_ff;
    if (k->type == LS_POSCTRL_P) {
        p->v_ref = ls_clamp(k->kp_x * x_err + v_ff, -k->v_max, k->v_max);
        if (p->fric_on) {
            f_ff += ls_friction(p->v_ref, p->fric_k, k->fric_c, k->fric_v);
        }
        return ls_pi_step_finite(&p->speed, p->v_ref - v, f_ff);
    }
    return ls_clamp(k->kp_x * x_err + k->kd_x * (v_ff - v) + f_ff, -k->force_max, k->force_max);
}

/* x_err = x_ref - x (m), v (m/s), v_ff (m/s), a_ff (m/s^2). Returns the force reference (N); 0
 * for non-finite inputs. */
static inline LS_REAL ls_posctrl_step(ls_posctrl *p, LS_REAL x_err, LS_REAL v, LS_REAL v_ff, LS_REAL a_ff)
{
    const ls_posctrl_cfg *k = &p->cfg;
    LS_REAL f_ff = k->mass * a_ff;
    if (!LS_ISFINITE4(x_err, v, v_ff, f_ff)) {
        return LS_R(0.0);
    }
    if (k->type == LS_POSCTRL_P) {
        p->v_ref = ls_clamp(k->kp_x * x_err + v_ff, -k->v_max, k->v_max);
        if (p->fric_on) {
            f_ff += ls_friction(p->v_ref, p->fric_k, k->fric_c, k->fric_v);
        }
        return ls_pi_step(&p->speed, p->v_ref - v, f_ff); /* v_ref - v may still overflow */
    }
    return ls_clamp(k->kp_x * x_err + k->kd_x * (v_ff - v) + f_ff, -k->force_max, k->force_max);
}

#endif /* LINSENSE_LS_POSCTRL_H */
