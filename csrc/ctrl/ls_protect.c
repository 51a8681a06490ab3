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

void ls_protect_trip(ls_protect *p, uint32_t bits)
{
    p->fault |= bits;
}

uint32_t ls_protect_check_power(ls_protect *p, const LS_REAL i_abc[3], LS_REAL v_dc)
{
    int k;
    for (k = 0; k < 3; ++k) {
        if (!LS_ISFINITE(i_abc[k])) {
            p->fault |= LS_FAULT_NONFINITE;
        } else if (LS_FABS(i_abc[k]) > p->cfg.i_max) {
            p->fault |= LS_FAULT_OVERCURRENT;
        }
    }
    if (!LS_ISFINITE(v_dc)) {
        p->fault |= LS_FAULT_NONFINITE;
    } else if (v_dc < p->cfg.v_dc_min) {
        p->fault |= LS_FAULT_UNDERVOLTAGE;
    } else if (v_dc > p->cfg.v_dc_max) {
        p->fault |= LS_FAULT_OVERVOLTAGE;
    }
    return p->fault;
}

uint32_t ls_protect_check_observer(ls_protect *p, LS_REAL err, bool valid, LS_REAL omega)
{
    if (!LS_ISFINITE(err) || !LS_ISFINITE(omega)) {
        p->fault |= LS_FAULT_NONFINITE;
        return p->fault;
    }
    if (!valid || LS_FABS(err) > p->cfg.err_max) {
        if (++p->err_count > p->err_limit) {
            p->fault |= LS_FAULT_OBSERVER;
        }
    } else {
        p->err_count = 0u;
    }
    if (LS_FABS(omega) > p->cfg.omega_max) {
        p->fault |= LS_FAULT_OVERSPEED;
    }
    return p->fault;
}
