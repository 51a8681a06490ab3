/* PI controller (see linsense/ls_pi.h). */
#include <math.h>

#include "linsense/ls_pi.h"

static bool finite_pos(LS_REAL x)
{
    return LS_ISFINITE(x) && x > LS_R(0.0);
}

static bool finite_nonneg(LS_REAL x)
{
    return LS_ISFINITE(x) && x >= LS_R(0.0);
}

ls_status ls_pi_init(ls_pi *pi, const ls_pi_cfg *cfg)
{
    if (pi == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!finite_pos(cfg->kp) || !finite_nonneg(cfg->ki) || !finite_pos(cfg->fs) ||
        !LS_ISFINITE(cfg->out_min) || !LS_ISFINITE(cfg->out_max) || !(cfg->out_min < cfg->out_max)) {
        return LS_ERR_PARAM;
    }
    pi->cfg = *cfg;
    pi->ts = LS_R(1.0) / cfg->fs;
    pi->ki_ts = cfg->ki * pi->ts;
    ls_pi_reset(pi);
    return LS_OK;
}

void ls_pi_reset(ls_pi *pi)
{
    pi->integ = LS_R(0.0);
    pi->saturated = false;
}
