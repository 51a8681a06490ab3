/* linsense firmware library: long-travel position as an electrical-period count plus an angle.
 *
 * x = (period + theta / (2 pi)) * tau. A float angle in [0, 2 pi) resolves 2 pi * 2^-22 rad,
 * i.e. 8 nm for tau = 56 mm, anywhere on the supported travel of +-LS_POS_PERIOD_MAX periods
 * (+-2^24: +-940 km for tau = 56 mm): float-only firmware keeps sub-micrometre resolution over
 * any realistic axis length.
 *
 * The range keeps every operation free of overflow: a difference of two periods (ls_pos_diff)
 * fits an int32_t with room to spare, and its float conversion is exact to 2^25. Positions the
 * library produces always lie in it: ls_pos_norm saturates a position beyond an end at that end
 * ({+-LS_POS_PERIOD_MAX, 0}); the drive's setters refuse a target outside it (ls_pos_check).
 */
#ifndef LINSENSE_LS_POS_H
#define LINSENSE_LS_POS_H

#include "linsense/ls_types.h"

/* -, largest |period| of a position (2^24 periods) */
#define LS_POS_PERIOD_MAX 16777216

typedef struct {
    int32_t period; /* -, whole electrical periods, |period| <= LS_POS_PERIOD_MAX */
    LS_REAL theta;  /* rad, electrical angle within the period, [0, 2 pi) */
} ls_pos;

/* The general normalisation (any period, any theta): theta brought into [0, 2 pi) carrying whole
 * periods, a non-finite theta counted as 0, and a position beyond +-LS_POS_PERIOD_MAX periods (or
 * a period beyond it) saturated at that end, {+-LS_POS_PERIOD_MAX, 0}. Returns true when it
 * saturated. Every float-to-int conversion here is range-checked first. Out of line: the slow
 * path of the per-step ls_pos_norm. */
bool ls_pos_norm_full(ls_pos *p);
/* = ls_pos_norm_full on a copy, by value (the slow path of ls_pos_norm: no memory round trip). A
 * step across one end of the period and a theta many periods out (a trajectory's reference: its
 * start plus the distance travelled) take short paths, bit for bit ls_pos_norm_full's result. */
ls_pos ls_pos_norm_wide(ls_pos p);

/* Normalise a target from outside the library: true, with *p normalised, when theta is finite
 * and the position lies within +-LS_POS_PERIOD_MAX periods; false (and *p unchanged) otherwise.
 * The drive's setters refuse a position this rejects. */
static inline bool ls_pos_check(ls_pos *p)
{
    ls_pos q = *p;
    if (!LS_ISFINITE(q.theta) || ls_pos_norm_full(&q)) {
        return false;
    }
    *p = q;
    return true;
}

/* Normalise theta into [0, 2 pi), carrying whole periods (ls_pos_norm_full: a non-finite theta
 * is set to 0, a position beyond the range saturates). The usual case, theta already in range,
 * returns p as it is: its period must then be in range, as every position the library made is. */
static inline ls_pos ls_pos_norm(ls_pos p)
{
    if (p.theta >= LS_R(0.0) && p.theta < LS_TWO_PI) { /* the usual case (false for NaN, Inf) */
        return p;
    }
    return ls_pos_norm_wide(p);
}

/* p + dtheta (rad), normalised. */
static inline ls_pos ls_pos_add(ls_pos p, LS_REAL dtheta)
{
    p.theta += dtheta;
    return ls_pos_norm(p);
}

/* a - b in rad (accurate while the difference itself is moderate, e.g. a position error). Both
 * within the range (|period| <= LS_POS_PERIOD_MAX): the period difference cannot overflow. */
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
