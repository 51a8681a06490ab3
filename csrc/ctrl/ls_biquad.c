/* Biquad design and reset (see linsense/ls_biquad.h). */
#include <math.h>

#include "linsense/ls_biquad.h"
#include "linsense/ls_math.h"

ls_status ls_biquad_init(ls_biquad *f, const ls_biquad_cfg *cfg)
{
    LS_REAL w0, cw, sw, alpha, a0;
    if (f == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (cfg->type == LS_BIQUAD_DIFF) {
        if (!LS_ISFINITE(cfg->fs) || cfg->fs <= LS_R(0.0)) {
            return LS_ERR_PARAM;
        }
        f->b0 = LS_R(1.0);
        f->b1 = LS_R(-1.0);
        f->b2 = f->a1 = f->a2 = LS_R(0.0);
        ls_biquad_reset(f);
        return LS_OK;
    }
    if (!LS_ISFINITE(cfg->f0) || !LS_ISFINITE(cfg->q) || !LS_ISFINITE(cfg->fs) || cfg->fs <= LS_R(0.0) ||
        cfg->f0 <= LS_R(0.0) || cfg->f0 >= LS_R(0.5) * cfg->fs || !(cfg->q >= LS_BIQUAD_Q_MIN) ||
        !(cfg->q <= LS_BIQUAD_Q_MAX)) {
        return LS_ERR_PARAM;
    }
    w0 = LS_TWO_PI * cfg->f0 / cfg->fs;
    ls_sincos_full(w0, &cw, &sw); /* (out of line: init code) */
    alpha = sw / (LS_R(2.0) * cfg->q);
    a0 = LS_R(1.0) + alpha;
    switch (cfg->type) {
    case LS_BIQUAD_LOWPASS:
        f->b0 = (LS_R(1.0) - cw) / (LS_R(2.0) * a0);
        f->b1 = (LS_R(1.0) - cw) / a0;
        f->b2 = f->b0;
        break;
    case LS_BIQUAD_BANDPASS:
        f->b0 = alpha / a0;
        f->b1 = LS_R(0.0);
        f->b2 = -alpha / a0;
        break;
    case LS_BIQUAD_NOTCH:
        f->b0 = LS_R(1.0) / a0;
        f->b1 = LS_R(-2.0) * cw / a0;
        f->b2 = f->b0;
        break;
    default:
        return LS_ERR_PARAM;
    }
    f->a1 = LS_R(-2.0) * cw / a0;
    f->a2 = (LS_R(1.0) - alpha) / a0;
    if (!LS_ISFINITE4(f->b0, f->b1, f->b2, f->a1) || !LS_ISFINITE(f->a2)) { /* (f0 / fs too small) */
        return LS_ERR_PARAM;
    }
    ls_biquad_reset(f);
    return LS_OK;
}

void ls_biquad_reset(ls_biquad *f)
{
    f->z1 = LS_R(0.0);
    f->z2 = LS_R(0.0);
}
