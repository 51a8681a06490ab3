/* linsense firmware library: periodic look-up table over one electrical period.
 *
 * The table holds N values at theta_k = 2*pi*k/N rad, k = 0..N-1 (as written by
 * `linsense lut --format c`), read with periodic linear interpolation:
 *   u = theta*N/(2*pi) wrapped into [0, N), k = floor(u), f = u - k,
 *   value = (1 - f)*table[k] + f*table[(k + 1) mod N].
 * Python's linsense.compensation.lut.interpolate implements the same rule.
 */
#ifndef LINSENSE_LS_LUT_H
#define LINSENSE_LS_LUT_H

#include "linsense/ls_types.h"

typedef struct {
    const float *table; /* table values (unit of the table, e.g. rad); not copied */
    uint32_t len;       /* number of points over one electrical period, >= 4 */
} ls_lut_cfg;

typedef struct {
    const float *table; /* table values, borrowed from the configuration */
    uint32_t len;       /* number of points */
    LS_REAL points_per_rad; /* len / (2 pi), 1/rad */
} ls_lut;

/* Validate cfg and prepare lut. Returns LS_ERR_NULL or LS_ERR_PARAM (len < 4, non-finite
 * value) without touching lut on failure. */
ls_status ls_lut_init(ls_lut *lut, const ls_lut_cfg *cfg);

/* A LUT holds no dynamic state; reset is provided for uniformity and does nothing. */
void ls_lut_reset(ls_lut *lut);

/* ls_lut_step for an angle outside [0, 2 pi): out of line (the per-step path never takes it). */
LS_REAL ls_lut_step_wide(const ls_lut *lut, LS_REAL theta);

/* ls_lut_step for theta in [0, 2 pi), as every ls_pos keeps its theta (ls_pos.h), without the
 * check: the drive's per-step path. */
static inline LS_REAL ls_lut_step_norm(const ls_lut *lut, LS_REAL theta)
{
    LS_REAL u;
    LS_REAL f;
    LS_REAL t0;
    LS_REAL t1;
    uint32_t k;
    u = theta * lut->points_per_rad; /* in [0, n]: the conversion is in range */
    k = (uint32_t)u;
    f = u - (LS_REAL)k;
    if (k + 1u < lut->len) {
        t0 = (LS_REAL)lut->table[k];
        t1 = (LS_REAL)lut->table[k + 1u];
    } else if (k < lut->len) { /* the last interval wraps to the first point */
        t0 = (LS_REAL)lut->table[k];
        t1 = (LS_REAL)lut->table[0];
    } else { /* u rounded up to n */
        return (LS_REAL)lut->table[0];
    }
    return t0 + f * (t1 - t0); /* = (1 - f) t0 + f t1 */
}

/* Interpolated value at electrical angle theta (rad, any value). A non-finite theta gives 0; one
 * so large that it has no fraction of a period left (|theta| >= 2^24 2 pi in float) gives table[0].
 * Inline (called every PWM period); an angle in [0, 2 pi), as ls_pos keeps it, needs no wrap. */
static inline LS_REAL ls_lut_step(const ls_lut *lut, LS_REAL theta)
{
    if (!(theta >= LS_R(0.0) && theta < LS_TWO_PI)) { /* (true for NaN, Inf) */
        return ls_lut_step_wide(lut, theta);
    }
    return ls_lut_step_norm(lut, theta);
}

#endif /* LINSENSE_LS_LUT_H */
