/* Trapezoidal trajectory generator (see linsense/ls_traj.h). */
#include <math.h>

#include "linsense/ls_traj.h"

ls_status ls_traj_init(ls_traj *t, const ls_traj_cfg *cfg)
{
    ls_pos zero = {0, LS_R(0.0)};
    if (t == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!LS_ISFINITE(cfg->v_max) || !LS_ISFINITE(cfg->a_max) || !LS_ISFINITE(cfg->fs) ||
        !LS_ISFINITE(cfg->pole_pitch) || !(cfg->v_max > LS_R(0.0)) || !(cfg->a_max > LS_R(0.0)) ||
        !(cfg->fs > LS_R(0.0)) || !(cfg->pole_pitch > LS_R(0.0))) {
        return LS_ERR_PARAM;
    }
    if (!LS_ISFINITE(cfg->v_step) || !LS_ISFINITE(cfg->a_step) || !(cfg->v_step >= LS_R(0.0)) ||
        !(cfg->a_step >= LS_R(0.0)) || (cfg->a_step > LS_R(0.0) && !(cfg->v_step > LS_R(0.0)))) {
        return LS_ERR_PARAM;
    }
    if (!LS_ISFINITE(cfg->a_lpf) || !(cfg->a_lpf >= LS_R(0.0)) || !(cfg->a_lpf <= cfg->fs)) {
        return LS_ERR_PARAM;
    }
    t->cfg = *cfg;
    t->ts = LS_R(1.0) / cfg->fs;
    t->kx = LS_TWO_PI / cfg->pole_pitch;
    /* (2 pi a_lpf Ts, at most 1: the output follows within the step) */
    t->a_k = cfg->a_lpf > LS_R(0.0) ? ls_clamp(LS_TWO_PI * cfg->a_lpf * t->ts, LS_R(0.0), LS_R(1.0)) : LS_R(1.0);
    ls_traj_reset(t, zero);
    return LS_OK;
}

void ls_traj_reset(ls_traj *t, ls_pos p)
{
    (void)ls_pos_norm_full(&p); /* any p: normalised, within the range */
    t->start = p;
    t->target = t->start;
    t->dist = LS_R(0.0);
    t->sign = LS_R(1.0);
    t->t_acc = LS_R(0.0);
    t->t_total = LS_R(0.0);
    t->v_peak = LS_R(0.0);
    t->acc = t->cfg.a_max;
    t->a_out = LS_R(0.0);
    t->k = 0u;
    t->active = false;
}

/* A minimum-time move from the present reference to target under v and a (> 0). */
static void plan(ls_traj *t, ls_pos target, LS_REAL v, LS_REAL a)
{
    ls_pos x;
    LS_REAL d;
    LS_REAL dummy_v, dummy_a;
    /* start from where the reference is now (a move may interrupt another one) */
    t->k = t->k > 0u ? t->k - 1u : 0u;
    ls_traj_step(t, &x, &dummy_v, &dummy_a);
    (void)ls_pos_norm_full(&target);
    d = ls_pos_diff(target, x) / t->kx;
    t->start = x;
    t->target = target;
    t->sign = d < LS_R(0.0) ? LS_R(-1.0) : LS_R(1.0);
    t->dist = LS_FABS(d);
    /* the step counter k covers LS_TRAJ_STEPS_MAX steps: a longer move stops, in its direction,
     * where that many steps take it (its end becomes the target; command the rest again) */
    {
        const LS_REAL t_lim = LS_TRAJ_STEPS_MAX * t->ts;
        const LS_REAL d_lim = t_lim >= LS_R(2.0) * v / a ? v * (t_lim - v / a) : LS_R(0.25) * a * t_lim * t_lim;
        if (t->dist > d_lim) {
            t->dist = d_lim;
            t->target = ls_pos_add(x, t->sign * d_lim * t->kx);
        }
    }
    if (t->dist >= v * v / a) {
        t->t_acc = v / a;
        t->v_peak = v;
        t->t_total = t->dist / v + v / a;
    } else {
        t->t_acc = LS_SQRT(t->dist / a);
        t->v_peak = a * t->t_acc;
        t->t_total = LS_R(2.0) * t->t_acc;
    }
    t->acc = a;
    t->k = 0u;
    t->active = t->dist > LS_R(0.0);
}

void ls_traj_move(ls_traj *t, ls_pos target)
{
    plan(t, target, t->cfg.v_max, t->cfg.a_max);
}

void ls_traj_jump(ls_traj *t, ls_pos target)
{
    if (t->cfg.a_step > LS_R(0.0)) {
        plan(t, target, t->cfg.v_step, t->cfg.a_step);
    } else {
        ls_traj_reset(t, target);
    }
}
