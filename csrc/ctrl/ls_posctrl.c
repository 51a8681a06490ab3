/* Position controller (see linsense/ls_posctrl.h). */
#include <math.h>

#include "linsense/ls_math.h"
#include "linsense/ls_posctrl.h"

static bool finite_pos(LS_REAL x)
{
    return LS_ISFINITE(x) && x > LS_R(0.0);
}

static bool finite_nonneg(LS_REAL x)
{
    return LS_ISFINITE(x) && x >= LS_R(0.0);
}

ls_status ls_posctrl_init(ls_posctrl *p, const ls_posctrl_cfg *cfg)
{
    ls_pi_cfg sp;
    if (p == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!finite_pos(cfg->kp_x) || !finite_nonneg(cfg->kd_x) || !finite_pos(cfg->v_max) ||
        !finite_nonneg(cfg->mass) || !finite_pos(cfg->force_max) ||
        (cfg->type != LS_POSCTRL_P && cfg->type != LS_POSCTRL_PD) ||
        !ls_friction_slope(cfg->fric_c, cfg->fric_v, cfg->fric_band, &p->fric_k)) {
        return LS_ERR_PARAM;
    }
    p->fric_on = cfg->fric_c > LS_R(0.0) || cfg->fric_v > LS_R(0.0);
    sp = cfg->speed;
    sp.out_min = -cfg->force_max;
    sp.out_max = cfg->force_max;
    if (cfg->type == LS_POSCTRL_P && ls_pi_init(&p->speed, &sp) != LS_OK) {
        return LS_ERR_PARAM;
    }
    p->cfg = *cfg;
    ls_posctrl_reset(p);
    return LS_OK;
}

void ls_posctrl_reset(ls_posctrl *p)
{
    if (p->cfg.type == LS_POSCTRL_P) {
        ls_pi_reset(&p->speed);
    }
    p->v_ref = LS_R(0.0);
}
