/* Pulsating HF injection (see linsense/ls_inject.h). */
#include <math.h>

#include "linsense/ls_inject.h"

ls_status ls_inject_init(ls_inject *inj, const ls_inject_cfg *cfg)
{
    LS_REAL w;
    if (inj == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!LS_ISFINITE(cfg->amplitude) || !LS_ISFINITE(cfg->freq) || !LS_ISFINITE(cfg->fs) ||
        !LS_ISFINITE(cfg->ramp_rate) || cfg->amplitude < LS_R(0.0) || cfg->freq <= LS_R(0.0) ||
        cfg->fs < LS_R(4.0) * cfg->freq || cfg->ramp_rate <= LS_R(0.0)) {
        return LS_ERR_PARAM;
    }
    inj->cfg = *cfg;
    w = LS_TWO_PI * cfg->freq / cfg->fs;
    inj->dc = LS_COS(w);
    inj->ds = LS_SIN(w);
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
}

void ls_inject_enable(ls_inject *inj, bool on)
{
    inj->on = on;
}

LS_REAL ls_inject_step(ls_inject *inj)
{
    LS_REAL v, c, s, g;
    LS_REAL target = inj->on ? inj->cfg.amplitude : LS_R(0.0);
    if (inj->amp < target) {
        inj->amp = inj->amp + inj->amp_step < target ? inj->amp + inj->amp_step : target;
    } else if (inj->amp > target) {
        inj->amp = inj->amp - inj->amp_step > target ? inj->amp - inj->amp_step : target;
    }
    v = inj->amp * inj->c;
    /* rotate the carrier by one step and pull it back onto the unit circle (first-order
     * Newton step for 1/|z|, exact to O(err^2) per step, so the error never accumulates) */
    c = inj->c * inj->dc - inj->s * inj->ds;
    s = inj->s * inj->dc + inj->c * inj->ds;
    g = LS_R(1.5) - LS_R(0.5) * (c * c + s * s);
    inj->c = c * g;
    inj->s = s * g;
    return v;
}
