/* linsense firmware library: PI controller.
 *
 * ls_pi  PI with output limits and anti-windup by conditional integration (no integration while
 *        the output is limited in the direction the error pushes, and the integrator kept within
 *        the output range): leaves the limit as soon as the error reverses.
 *
 * The step functions are inline (called every PWM period). Each ls_<x>_step of the controllers
 * (ls_pi.h, ls_current.h, ls_posctrl.h) guards its inputs against NaN and Inf;
 * ls_<x>_step_finite is the same step without that guard, for a caller whose inputs are finite by
 * construction (the drive, after its own checks).
 */
#ifndef LINSENSE_LS_PI_H
#define LINSENSE_LS_PI_H

#include "linsense/ls_types.h"

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

#endif /* LINSENSE_LS_PI_H */
