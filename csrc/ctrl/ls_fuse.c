/* The hand-over between the HF and the EMF estimates (see linsense/ls_fuse.h). */
#include "linsense/ls_fuse.h"

ls_status ls_fuse_init(ls_fuse *f, const ls_fuse_cfg *cfg)
{
    LS_REAL kx, n;
    uint32_t k;
    if (f == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!LS_ISFINITE4(cfg->fs, cfg->pole_pitch, cfg->v_lo, cfg->v_hi) ||
        !LS_ISFINITE3(cfg->v_off, cfg->v_on, cfg->t_settle) || !(cfg->fs > LS_R(0.0)) ||
        !(cfg->pole_pitch > LS_R(0.0)) || !(cfg->v_lo > LS_R(0.0)) || !(cfg->v_hi > cfg->v_lo) ||
        !(cfg->v_on >= cfg->v_hi) || !(cfg->v_off > cfg->v_on) || cfg->t_settle < LS_R(0.0) ||
        !(cfg->t_settle < LS_R(1.0))) {
        return LS_ERR_PARAM;
    }
    kx = LS_TWO_PI / cfg->pole_pitch;
    n = cfg->t_settle * cfg->fs;
    f->cfg = *cfg;
    f->w_lo = cfg->v_lo * kx;
    f->inv_band = LS_R(1.0) / ((cfg->v_hi - cfg->v_lo) * kx);
    f->w_off = cfg->v_off * kx;
    f->w_on = cfg->v_on * kx;
    f->w_emf_on = LS_FUSE_EMF_ON * f->w_lo;
    f->w_emf_off = LS_FUSE_EMF_OFF * f->w_lo;
    if (!LS_ISFINITE4(f->w_lo, f->inv_band, f->w_off, f->w_on) || !(f->inv_band > LS_R(0.0)) ||
        !(n >= LS_R(0.0)) || !(n < LS_R(4.0e9))) {
        return LS_ERR_PARAM; /* (a pitch so small that the speeds overflow; t_settle fs beyond 32 bits) */
    }
    k = (uint32_t)n; /* (in range: checked above) */
    f->n_settle = (LS_REAL)k < n ? k + 1u : k; /* (rounded up) */
    ls_fuse_reset(f);
    return LS_OK;
}

void ls_fuse_reset(ls_fuse *f)
{
    f->n_full = f->n_settle;
    f->inject = true;
    f->w = LS_R(0.0);
    f->hf_used = false;
    f->emf_run = false;
}
