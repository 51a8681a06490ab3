/* Tracking observer (see linsense/ls_observer.h). */
#include <math.h>

#include "linsense/ls_math.h"
#include "linsense/ls_observer.h"

void ls_observer_gains(ls_observer_cfg *cfg, LS_REAL f_bw)
{
    LS_REAL w = LS_TWO_PI * f_bw;
    if (cfg->type == LS_OBS_MECH) {
        cfg->k1 = LS_R(3.0) * w;
        cfg->k2 = LS_R(3.0) * w * w;
        cfg->k3 = w * w * w;
    } else {
        cfg->k1 = LS_R(2.0) * w;
        cfg->k2 = w * w;
        cfg->k3 = LS_R(0.0);
    }
}

ls_status ls_observer_init(ls_observer *o, const ls_observer_cfg *cfg)
{
    ls_pos zero = {0, LS_R(0.0)};
    if (o == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!(cfg->fs > LS_R(0.0)) || !(cfg->k1 > LS_R(0.0)) || !(cfg->k2 > LS_R(0.0)) ||
        !(cfg->pole_pitch > LS_R(0.0)) || !(cfg->omega_max > LS_R(0.0)) || !LS_ISFINITE(cfg->fs) ||
        !LS_ISFINITE(cfg->k1) || !LS_ISFINITE(cfg->k2) || !LS_ISFINITE(cfg->pole_pitch) ||
        !LS_ISFINITE(cfg->omega_max)) {
        return LS_ERR_PARAM;
    }
    if (cfg->type == LS_OBS_MECH) {
        if (!(cfg->k3 > LS_R(0.0)) || !(cfg->mass > LS_R(0.0)) || !(cfg->force_max > LS_R(0.0)) ||
            !LS_ISFINITE(cfg->k3) || !LS_ISFINITE(cfg->mass) || !LS_ISFINITE(cfg->force_max) ||
            !ls_friction_slope(cfg->fric_c, cfg->fric_v, cfg->fric_band, &o->fric_kw)) {
            return LS_ERR_PARAM;
        }
    } else if (cfg->type != LS_OBS_PLL) {
        return LS_ERR_PARAM;
    }
    o->cfg = *cfg;
    o->ts = LS_R(1.0) / cfg->fs;
    o->kx = LS_TWO_PI / cfg->pole_pitch;
    o->inv_kx = cfg->pole_pitch / LS_TWO_PI;
    o->k1_ts = cfg->k1 * o->ts;
    o->k2_ts = cfg->k2 * o->ts;
    if (cfg->type == LS_OBS_MECH) {
        o->acc_ts = o->kx * o->ts / cfg->mass;
        o->k3_ts = cfg->k3 * (cfg->mass / o->kx) * o->ts;
        o->fric_kw *= o->inv_kx; /* (fric_c / fric_band, checked above) */
        o->fric_vw = cfg->fric_v * o->inv_kx;
        o->fric_on = cfg->fric_c > LS_R(0.0) || cfg->fric_v > LS_R(0.0);
    } else {
        o->acc_ts = LS_R(0.0);
        o->k3_ts = LS_R(0.0);
        o->fric_kw = LS_R(0.0);
        o->fric_vw = LS_R(0.0);
        o->fric_on = false;
    }
    /* per-step gains (see the header): beyond them the discrete observer is unstable; and the
     * derived values a tiny or huge input could overflow */
    if (!(o->k1_ts <= LS_OBS_K1_TS_MAX) || !(o->k2_ts * o->ts <= LS_OBS_K2_TS2_MAX) ||
        (cfg->type == LS_OBS_MECH && !(o->k3_ts * (o->kx / cfg->mass) * o->ts * o->ts <= LS_OBS_K3_TS3_MAX)) ||
        !(cfg->omega_max * o->ts <= LS_PI) ||
        !LS_ISFINITE4(o->kx, o->inv_kx, o->acc_ts, o->k3_ts) || !(o->inv_kx > LS_R(0.0)) ||
        /* the model's damping within one step (its friction's slope ts / mass below 1) */
        (cfg->type == LS_OBS_MECH && !((o->fric_kw + o->fric_vw) * o->acc_ts <= LS_R(1.0))) ||
        (cfg->type == LS_OBS_MECH && !(cfg->force_max * o->acc_ts * o->ts <= LS_PI))) {
        return LS_ERR_PARAM;
    }
    ls_observer_reset(o, zero);
    return LS_OK;
}

void ls_observer_reset(ls_observer *o, ls_pos p)
{
    (void)ls_pos_norm_full(&p); /* any p: normalised, within the range */
    o->pos = p;
    o->omega = LS_R(0.0);
    o->f_load = LS_R(0.0);
}
