/* Dead-time residual response model (see linsense/ls_dtres.h). */
#include "linsense/ls_dtres.h"

static void axis(LS_REAL r_s, LS_REAL l, LS_REAL ts, LS_REAL *a, LS_REAL *b)
{
    const LS_REAL x = r_s * ts / l;
    *a = LS_EXP(-x);
    /* (1 - a) / R = (T / L) (1 - e^-x) / x, with its series where x is tiny (no 0/0 at R = 0) */
    *b = (ts / l) * (x > LS_R(1e-4) ? (LS_R(1.0) - *a) / x : LS_R(1.0) - LS_R(0.5) * x);
}

ls_status ls_dtres_init(ls_dtres *r, const ls_dtres_cfg *cfg)
{
    LS_REAL ts;
    if (r == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!LS_ISFINITE4(cfg->fs, cfg->r_s, cfg->l_d, cfg->l_q) || !(cfg->fs > LS_R(0.0)) ||
        cfg->r_s < LS_R(0.0) || !(cfg->l_d > LS_R(0.0)) || !(cfg->l_q > LS_R(0.0)) ||
        !LS_ISFINITE(cfg->l_ea) || !LS_ISFINITE(cfg->l_eb)) {
        return LS_ERR_PARAM;
    }
    /* L_ab positive definite at every angle: its smallest eigenvalue is at least
     * (L_d + L_q)/2 - |L_d - L_q|/2 - |(l_ea, l_eb)| */
    if (!(LS_R(0.5) * (cfg->l_d + cfg->l_q) - LS_R(0.5) * LS_FABS(cfg->l_d - cfg->l_q) >
          LS_SQRT(cfg->l_ea * cfg->l_ea + cfg->l_eb * cfg->l_eb))) {
        return LS_ERR_PARAM;
    }
    r->cfg = *cfg;
    ts = LS_R(1.0) / cfg->fs;
    axis(cfg->r_s, cfg->l_d, ts, &r->a_d, &r->b_d);
    axis(cfg->r_s, cfg->l_q, ts, &r->a_q, &r->b_q);
    /* an inductance so small against R Ts that the response overflows: refused */
    r->k_rip = LS_R(2.0) * ts / (cfg->l_d + cfg->l_q);
    if (!LS_ISFINITE4(r->a_d, r->b_d, r->a_q, r->b_q) || !LS_ISFINITE(r->k_rip)) {
        return LS_ERR_PARAM;
    }
    ls_dtres_reset(r);
    return LS_OK;
}

void ls_dtres_resistance_(ls_dtres *r)
{
    LS_REAL ts;
    r->k_r_resp = r->k_r;
    if (!(r->cfg.fs > LS_R(0.0)) || !(r->cfg.l_d > LS_R(0.0)) || !(r->cfg.l_q > LS_R(0.0))) {
        return; /* (not initialised: a drive without hf_dtres resets it too) */
    }
    ts = LS_R(1.0) / r->cfg.fs;
    axis(r->cfg.r_s * r->k_r, r->cfg.l_d, ts, &r->a_d, &r->b_d);
    axis(r->cfg.r_s * r->k_r, r->cfg.l_q, ts, &r->a_q, &r->b_q);
}

void ls_dtres_restart(ls_dtres *r)
{
    int k;
    r->i_d = LS_R(0.0);
    r->i_q = LS_R(0.0);
    r->k_l = LS_R(1.0);
    for (k = 0; k < 7; ++k) {
        r->s[k] = LS_R(0.0);
    }
    for (k = 0; k < 6; ++k) {
        r->hp[k] = LS_R(0.0);
    }
    r->n_solve = 0u;
}

void ls_dtres_reset(ls_dtres *r)
{
    ls_dtres_restart(r);
    r->k_r = LS_R(1.0);
    ls_dtres_resistance_(r);
}
