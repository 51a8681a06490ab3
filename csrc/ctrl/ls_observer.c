/* Tracking observer (see linsense/ls_observer.h). */
#include <math.h>

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
            !LS_ISFINITE(cfg->k3) || !LS_ISFINITE(cfg->mass) || !LS_ISFINITE(cfg->force_max)) {
            return LS_ERR_PARAM;
        }
    } else if (cfg->type != LS_OBS_PLL) {
        return LS_ERR_PARAM;
    }
    o->cfg = *cfg;
    o->ts = LS_R(1.0) / cfg->fs;
    o->kx = LS_TWO_PI / cfg->pole_pitch;
    ls_observer_reset(o, zero);
    return LS_OK;
}

void ls_observer_reset(ls_observer *o, ls_pos p)
{
    o->pos = ls_pos_norm(p);
    o->omega = LS_R(0.0);
    o->f_load = LS_R(0.0);
}

void ls_observer_step(ls_observer *o, LS_REAL eps, LS_REAL f_motor)
{
    const ls_observer_cfg *c = &o->cfg;
    LS_REAL dtheta;
    if (!LS_ISFINITE(eps)) {
        eps = LS_R(0.0);
    }
    if (!LS_ISFINITE(f_motor)) {
        f_motor = LS_R(0.0);
    }
    dtheta = (o->omega + c->k1 * eps) * o->ts;
    if (c->type == LS_OBS_MECH) {
        LS_REAL acc = o->kx * (f_motor - o->f_load) / c->mass;
        o->omega += (acc + c->k2 * eps) * o->ts;
        o->f_load -= c->k3 * eps * (c->mass / o->kx) * o->ts;
        o->f_load = ls_clamp(o->f_load, -c->force_max, c->force_max);
    } else {
        o->omega += c->k2 * eps * o->ts;
    }
    o->omega = ls_clamp(o->omega, -c->omega_max, c->omega_max);
    o->pos = ls_pos_add(o->pos, dtheta);
}
