/* Protection (see linsense/ls_protect.h). */
#include <math.h>

#include "linsense/ls_protect.h"

ls_status ls_protect_init(ls_protect *p, const ls_protect_cfg *cfg)
{
    LS_REAL n;
    if (p == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!LS_ISFINITE(cfg->i_max) || !LS_ISFINITE(cfg->v_dc_min) || !LS_ISFINITE(cfg->v_dc_max) ||
        !LS_ISFINITE(cfg->err_max) || !LS_ISFINITE(cfg->err_time) || !LS_ISFINITE(cfg->omega_max) ||
        !LS_ISFINITE(cfg->fs) || !(cfg->i_max > LS_R(0.0)) || cfg->v_dc_min < LS_R(0.0) ||
        !(cfg->v_dc_max > cfg->v_dc_min) || !(cfg->err_max > LS_R(0.0)) || !(cfg->err_time > LS_R(0.0)) ||
        !(cfg->omega_max > LS_R(0.0)) || !(cfg->fs > LS_R(0.0))) {
        return LS_ERR_PARAM;
    }
    n = cfg->err_time * cfg->fs;
    if (n > LS_R(4.0e9)) {
        return LS_ERR_PARAM;
    }
    p->cfg = *cfg;
    p->err_limit = (uint32_t)n;
    ls_protect_reset(p);
    return LS_OK;
}

void ls_protect_reset(ls_protect *p)
{
    p->fault = LS_FAULT_NONE;
    p->err_count = 0u;
}
