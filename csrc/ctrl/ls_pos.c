/* Long-travel position: the general normalisation (see linsense/ls_pos.h). */
#include <math.h>

#include "linsense/ls_pos.h"

/* floor(q), bit for bit as LS_FLOOR's for every q (a signed zero aside, which the caller's
 * k * 2 pi subtraction and period count do not see): the conversion to int32_t only where |q| < 2^30
 * (in range), beyond q itself (a float there is an integer; a double beyond the positions' range
 * saturates in the caller either way; NaN stays NaN). No libm call: newlib's floorf costs about 20
 * cycles and a call on a Cortex-M4F, on every step of a move longer than a pole pitch (ls_traj's
 * reference, in ls_pos_norm_wide). */
static LS_REAL floor_(LS_REAL q)
{
    LS_REAL k;
    if (!(LS_FABS(q) < LS_R(1073741824.0))) {
        return q;
    }
    k = (LS_REAL)(int32_t)q; /* (in range: checked above) */
    return k > q ? k - LS_R(1.0) : k;
}

bool ls_pos_norm_full(ls_pos *p)
{
    /* |k| beyond this cannot come back into the range from a period within it */
    const LS_REAL k_lim = LS_R(2.0) * (LS_REAL)LS_POS_PERIOD_MAX + LS_R(4.0);
    LS_REAL th = p->theta, k;
    int32_t n = p->period;
    int round;
    if (th >= LS_R(0.0) && th < LS_TWO_PI && n <= LS_POS_PERIOD_MAX && n >= -LS_POS_PERIOD_MAX) {
        return false; /* (already normalised: the usual case of a mode change's ls_traj_reset) */
    }
    if (!LS_ISFINITE(th)) {
        th = LS_R(0.0);
    }
    if (n > LS_POS_PERIOD_MAX || n < -LS_POS_PERIOD_MAX) {
        p->period = n > 0 ? LS_POS_PERIOD_MAX : -LS_POS_PERIOD_MAX;
        p->theta = LS_R(0.0);
        return true;
    }
    /* two rounds: a large theta leaves a remainder of a few periods after the first (its
     * rounding), which the second takes exactly */
    for (round = 0; round < 2 && !(th >= LS_R(0.0) && th < LS_TWO_PI); ++round) {
        k = floor_(th / LS_TWO_PI);
        if (!(LS_FABS(k) <= k_lim)) { /* (th / 2 pi is finite: k is too) */
            p->period = k > LS_R(0.0) ? LS_POS_PERIOD_MAX : -LS_POS_PERIOD_MAX;
            p->theta = LS_R(0.0);
            return true;
        }
        n += (int32_t)k; /* |n| <= 3 2^24 + 8 */
        th -= k * LS_TWO_PI;
    }
    if (th >= LS_TWO_PI) { /* rounding */
        th -= LS_TWO_PI;
        n += 1;
    } else if (th < LS_R(0.0)) {
        th += LS_TWO_PI;
        n -= 1;
        if (!(th < LS_TWO_PI)) { /* a negative theta too small for th / 2 pi (it underflows to -0, so
                                    the rounds leave it) rounds to 2 pi: it is the period's start */
            th = LS_R(0.0);
            n += 1;
        }
    }
    if (!(th >= LS_R(0.0) && th < LS_TWO_PI)) { /* (not reached; an angle in range whatever) */
        th = LS_R(0.0);
    }
    if (n > LS_POS_PERIOD_MAX || n < -LS_POS_PERIOD_MAX) {
        p->period = n > 0 ? LS_POS_PERIOD_MAX : -LS_POS_PERIOD_MAX;
        p->theta = LS_R(0.0);
        return true;
    }
    p->period = n;
    p->theta = th;
    return false;
}

ls_pos ls_pos_norm_wide(ls_pos p)
{
    /* a step across one end of the period (the usual way out of [0, 2 pi)), with the period
     * inside the range: what ls_pos_norm_full computes there, without its division and floor
     * (theta in [2 pi, 3 pi): floor(theta / 2 pi) = 1 and theta - 2 pi is exact; theta in
     * [-pi, 0): -1, and theta + 2 pi may round up to 2 pi, the next period's start) */
    if (p.period < LS_POS_PERIOD_MAX && p.period > -LS_POS_PERIOD_MAX) {
        if (p.theta >= LS_TWO_PI && p.theta < LS_R(1.5) * LS_TWO_PI) {
            p.theta -= LS_TWO_PI;
            p.period += 1;
            return p;
        }
        if (p.theta < LS_R(0.0) && p.theta >= -LS_PI) {
            p.theta += LS_TWO_PI;
            if (p.theta < LS_TWO_PI) {
                p.period -= 1;
            } else {
                p.theta = LS_R(0.0);
            }
            return p;
        }
        {
            /* further out (a trajectory's reference: its start plus the distance travelled, many
             * periods on a long move): ls_pos_norm_full's first round, which leaves theta in range
             * but at the rounding edges; those, a k beyond the range and a non-finite theta (th is
             * then NaN) go to ls_pos_norm_full. |k| <= 2 LS_POS_PERIOD_MAX keeps the conversion in
             * range and the sum free of overflow. */
            const LS_REAL k = floor_(p.theta / LS_TWO_PI);
            const LS_REAL th = p.theta - k * LS_TWO_PI;
            if (th >= LS_R(0.0) && th < LS_TWO_PI && LS_FABS(k) <= LS_R(2.0) * (LS_REAL)LS_POS_PERIOD_MAX) {
                const int32_t n = p.period + (int32_t)k;
                if (n <= LS_POS_PERIOD_MAX && n >= -LS_POS_PERIOD_MAX) {
                    p.period = n;
                    p.theta = th;
                    return p;
                }
            }
        }
    }
    (void)ls_pos_norm_full(&p);
    return p;
}
