/* linsense firmware library: protection.
 *
 * Latching fault bits; once any bit is set the drive disables its outputs until
 * ls_protect_reset. Observer loss is detected as an error signal beyond err_max for longer than
 * err_time, an invalid (too weak) HF signal for longer than err_time, or an implausible speed.
 */
#ifndef LINSENSE_LS_PROTECT_H
#define LINSENSE_LS_PROTECT_H

#include "linsense/ls_types.h"

#define LS_FAULT_NONE 0u
#define LS_FAULT_OVERCURRENT 0x01u  /* |i_phase| > i_max */
#define LS_FAULT_UNDERVOLTAGE 0x02u /* v_dc < v_dc_min */
#define LS_FAULT_OVERVOLTAGE 0x04u  /* v_dc > v_dc_max */
#define LS_FAULT_OBSERVER 0x08u     /* error signal out of range or HF signal lost */
#define LS_FAULT_OVERSPEED 0x10u    /* |speed estimate| > omega_max */
#define LS_FAULT_NONFINITE 0x20u    /* NaN or Inf in a measurement or an internal signal */
#define LS_FAULT_CONFIG 0x40u       /* the drive was stepped without a successful init */

typedef struct {
    LS_REAL i_max;     /* A, phase over-current threshold, > 0 */
    LS_REAL v_dc_min;  /* V, DC-bus under-voltage threshold, >= 0 */
    LS_REAL v_dc_max;  /* V, DC-bus over-voltage threshold, > v_dc_min */
    LS_REAL err_max;   /* rad, observer error-signal plausibility limit, > 0 */
    LS_REAL err_time;  /* s, how long the error may stay out of range, > 0 */
    LS_REAL omega_max; /* rad/s, electrical speed plausibility limit, > 0 */
    LS_REAL fs;        /* Hz, sampling rate, > 0 */
} ls_protect_cfg;

typedef struct {
    ls_protect_cfg cfg;  /* copy of the configuration */
    uint32_t fault;      /* latched LS_FAULT_* bits */
    uint32_t err_count;  /* steps the observer error has been out of range */
    uint32_t err_limit;  /* steps allowed out of range */
} ls_protect;

ls_status ls_protect_init(ls_protect *p, const ls_protect_cfg *cfg);
/* Clear the latched faults. */
void ls_protect_reset(ls_protect *p);
/* The checks are inline (called every PWM period). */
/* Latch extra fault bits (e.g. LS_FAULT_NONFINITE found elsewhere). */
static inline void ls_protect_trip(ls_protect *p, uint32_t bits)
{
    p->fault |= bits;
}

/* Electrical checks (currents and bus); returns the latched faults. */
static inline uint32_t ls_protect_check_power(ls_protect *p, const LS_REAL i_abc[3], LS_REAL v_dc)
{
    const LS_REAL i_max = p->cfg.i_max;
    int k;
    /* fast path: everything in range (false for NaN and Inf, which take the full checks) */
    if (LS_FABS(i_abc[0]) <= i_max && LS_FABS(i_abc[1]) <= i_max && LS_FABS(i_abc[2]) <= i_max &&
        v_dc >= p->cfg.v_dc_min && v_dc <= p->cfg.v_dc_max) {
        return p->fault;
    }
    for (k = 0; k < 3; ++k) {
        if (!LS_ISFINITE(i_abc[k])) {
            p->fault |= LS_FAULT_NONFINITE;
        } else if (LS_FABS(i_abc[k]) > i_max) {
            p->fault |= LS_FAULT_OVERCURRENT;
        }
    }
    if (!LS_ISFINITE(v_dc)) {
        p->fault |= LS_FAULT_NONFINITE;
    } else if (v_dc < p->cfg.v_dc_min) {
        p->fault |= LS_FAULT_UNDERVOLTAGE;
    } else if (v_dc > p->cfg.v_dc_max) {
        p->fault |= LS_FAULT_OVERVOLTAGE;
    }
    return p->fault;
}

/* Observer checks: err (rad) and its validity, estimated electrical speed (rad/s). */
static inline uint32_t ls_protect_check_observer(ls_protect *p, LS_REAL err, bool valid, LS_REAL omega)
{
    /* fast path: a valid error and a speed in range (false for NaN, which takes the full checks) */
    if (valid && LS_FABS(err) <= p->cfg.err_max && LS_FABS(omega) <= p->cfg.omega_max) {
        p->err_count = 0u;
        return p->fault;
    }
    if (!LS_ISFINITE2(err, omega)) {
        p->fault |= LS_FAULT_NONFINITE;
        return p->fault;
    }
    if (!valid || LS_FABS(err) > p->cfg.err_max) {
        if (++p->err_count > p->err_limit) {
            p->fault |= LS_FAULT_OBSERVER;
        }
    } else {
        p->err_count = 0u;
    }
    if (LS_FABS(omega) > p->cfg.omega_max) {
        p->fault |= LS_FAULT_OVERSPEED;
    }
    return p->fault;
}

#endif /* LINSENSE_LS_PROTECT_H */
