/* HF injection (see linsense/ls_inject.h). */
#include <math.h>

#include "linsense/ls_inject.h"
#include "linsense/ls_math.h"

ls_status ls_inject_init(ls_inject *inj, const ls_inject_cfg *cfg)
{
    LS_REAL w;
    if (inj == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!LS_ISFINITE(cfg->amplitude) || !LS_ISFINITE(cfg->freq) || !LS_ISFINITE(cfg->fs) ||
        !LS_ISFINITE(cfg->ramp_rate) || cfg->amplitude < LS_R(0.0) || cfg->freq <= LS_R(0.0) ||
        cfg->ramp_rate <= LS_R(0.0) || !LS_ISFINITE(cfg->quad) ||
        cfg->quad < LS_R(0.0) || cfg->quad >= LS_R(1.0)) {
        return LS_ERR_PARAM;
    }
    switch (cfg->shape) {
    case LS_INJ_PULSATING:
    case LS_INJ_ROTATING:
        if (cfg->fs < LS_R(4.0) * cfg->freq || (cfg->shape == LS_INJ_ROTATING && cfg->quad != LS_R(0.0))) {
            return LS_ERR_PARAM;
        }
        break;
    case LS_INJ_SQUARE:
        if (cfg->freq != LS_R(0.5) * cfg->fs || cfg->quad != LS_R(0.0)) {
            return LS_ERR_PARAM;
        }
        break;
    default:
        return LS_ERR_PARAM;
    }
    inj->cfg = *cfg;
    if (cfg->shape == LS_INJ_SQUARE) { /* a half turn per step, exactly: cos = +-1, sin = 0 */
        inj->dc = LS_R(-1.0);
        inj->ds = LS_R(0.0);
    } else {
        w = LS_TWO_PI * cfg->freq / cfg->fs;
        ls_sincos_full(w, &inj->dc, &inj->ds); /* (out of line: init code) */
    }
    if (cfg->shape == LS_INJ_ROTATING) {
        inj->cfg.quad = LS_R(1.0); /* v_q = A sin(phi): the beta component */
    }
    inj->amp_step = cfg->ramp_rate / cfg->fs;
    ls_inject_reset(inj);
    return LS_OK;
}

void ls_inject_reset(ls_inject *inj)
{
    inj->c = LS_R(1.0);
    inj->s = LS_R(0.0);
    inj->amp = LS_R(0.0);
    inj->on = false;
    inj->v_q = LS_R(0.0);
}

void ls_inject_enable(ls_inject *inj, bool on)
{
    inj->on = on;
}
