/* Dead-time residual response model (see linsense/ls_dtres.h). */
#include "linsense/ls_dtres.h"
#include "linsense/ls_math.h"

/* One axis's gain b = (1 - a) / R = (T / L) (1 - e^-x) / x from its decay a = e^-x (x = R T / L;
 * its series where x is tiny: no 0/0 at R = 0); ts_l = T / L. */
static LS_REAL gain(LS_REAL x, LS_REAL a, LS_REAL ts_l)
{
    return ts_l * (x > LS_R(1e-4) ? (LS_R(1.0) - a) / x : LS_R(1.0) - LS_R(0.5) * x);
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
    r->x_d = cfg->r_s * ts / cfg->l_d;
    r->x_q = cfg->r_s * ts / cfg->l_q;
    r->ts_l_d = ts / cfg->l_d;
    r->ts_l_q = ts / cfg->l_q;
    /* an inductance so small against R Ts that the response overflows: refused */
    r->k_rip = LS_R(2.0) * ts / (cfg->l_d + cfg->l_q);
    ls_dtres_reset(r);
    if (!LS_ISFINITE4(r->a_d, r->b_d, r->a_q, r->b_q) || !LS_ISFINITE4(r->x_d, r->x_q, r->ts_l_d, r->ts_l_q) ||
        !LS_ISFINITE(r->k_rip)) {
        return LS_ERR_PARAM;
    }
    return LS_OK;
}

void ls_dtres_resistance_(ls_dtres *r)
{
    r->k_r_resp = r->k_r;
    r->resp_stage = 0u;
    if (!(r->cfg.fs > LS_R(0.0)) || !(r->cfg.l_d > LS_R(0.0)) || !(r->cfg.l_q > LS_R(0.0))) {
        return; /* (not initialised: a drive without hf_dtres resets it too) */
    }
    r->resp_stage = 1u; /* (the four parts of ls_dtres_response_step_ at once) */
    while (r->resp_stage != 0u) {
        ls_dtres_response_step_(r);
    }
}

void ls_dtres_response_step_(ls_dtres *r)
{
    switch (r->resp_stage) {
    case 1u:
        r->a_next[0] = ls_exp(-(r->x_d * r->k_r_resp));
        break;
    case 2u:
        r->b_next = gain(r->x_d * r->k_r_resp, r->a_next[0], r->ts_l_d);
        break;
    case 3u:
        r->a_next[1] = ls_exp(-(r->x_q * r->k_r_resp));
        break;
    default:
        r->a_d = r->a_next[0];
        r->b_d = r->b_next;
        r->a_q = r->a_next[1];
        r->b_q = gain(r->x_q * r->k_r_resp, r->a_next[1], r->ts_l_q);
        r->resp_stage = 0u;
        return;
    }
    r->resp_stage++;
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
