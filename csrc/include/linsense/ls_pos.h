/* linsense firmware library: long-travel position as an electrical-period count plus an angle.
 *
 * x = (period + theta / (2 pi)) * tau. A float angle in [0, 2 pi) resolves 2 pi * 2^-22 rad,
 * i.e. 8 nm for tau = 56 mm, anywhere on a travel of +-2^31 periods: float-only firmware keeps
 * sub-micrometre resolution over any realistic axis length.
 */
#ifndef LINSENSE_LS_POS_H
#define LINSENSE_LS_POS_H

#include "linsense/ls_types.h"

typedef struct {
    int32_t period; /* -, whole electrical periods */
    LS_REAL theta;  /* rad, electrical angle within the period, [0, 2 pi) */
} ls_pos;

/* Normalise theta into [0, 2 pi), carrying whole periods. A non-finite theta is set to 0. */
static inline ls_pos ls_pos_norm(ls_pos p)
{
    LS_REAL k;
    if (p.theta >= LS_R(0.0) && p.theta < LS_TWO_PI) { /* the usual case (false for NaN, Inf) */
        return p;
    }
    if (!LS_ISFINITE(p.theta)) {
        p.theta = LS_R(0.0);
        return p;
    }
    k = LS_FLOOR(p.theta / LS_TWO_PI);
    p.period += (int32_t)k;
    p.theta -= k * LS_TWO_PI;
    if (p.theta >= LS_TWO_PI) { /* rounding */
        p.theta -= LS_TWO_PI;
        p.period += 1;
    } else if (p.theta < LS_R(0.0)) {
        p.theta += LS_TWO_PI;
        p.period -= 1;
    }
    return p;
}

/* p + dtheta (rad), normalised. */
static inline ls_pos ls_pos_add(ls_pos p, LS_REAL dtheta)
{
    p.theta += dtheta;
    return ls_pos_norm(p);
}

/* a - b in rad (accurate while the difference itself is moderate, e.g. a position error). */
static inline LS_REAL ls_pos_diff(ls_pos a, ls_pos b)
{
    return (LS_REAL)(a.period - b.period) * LS_TWO_PI + (a.theta - b.theta);
}

/* Angle wrapped into [-pi, pi). */
static inline LS_REAL ls_wrap_pi(LS_REAL a)
{
    if (a >= -LS_PI && a < LS_PI) {
        return a;
    }
    return a - LS_TWO_PI * LS_FLOOR((a + LS_PI) / LS_TWO_PI);
}

#endif /* LINSENSE_LS_POS_H */
