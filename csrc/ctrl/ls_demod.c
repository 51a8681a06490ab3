/* HF demodulator (see linsense/ls_demod.h). */
#include <math.h>

#include "linsense/ls_demod.h"

ls_status ls_demod_init(ls_demod *d, const ls_demod_cfg *cfg)
{
    ls_biquad_cfg lp;
    int k;
    if (d == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if ((cfg->method != LS_DEMOD_PRODUCT && cfg->method != LS_DEMOD_HETERODYNE) ||
        !LS_ISFINITE(cfg->gain) || cfg->gain == LS_R(0.0) || !LS_ISFINITE(cfg->min_level) ||
        cfg->min_level < LS_R(0.0)) {
        return LS_ERR_PARAM;
    }
    if ((cfg->comp != NULL && cfg->comp->len < 4u) || (cfg->gain_table != NULL && cfg->gain_table->len < 4u)) {
        return LS_ERR_PARAM;
    }
    lp.type = LS_BIQUAD_LOWPASS;
    lp.f0 = cfg->f_lpf;
    lp.q = LS_R(0.70710678);
    lp.fs = cfg->fs;
    for (k = 0; k < 4; ++k) {
        if (ls_biquad_init(&d->lp[k], &lp) != LS_OK) {
            return LS_ERR_PARAM;
        }
    }
    d->cfg = *cfg;
    d->use_comp = cfg->comp != NULL;
    d->use_gain_table = cfg->gain_table != NULL;
    ls_demod_reset(d);
    return LS_OK;
}

void ls_demod_reset(ls_demod *d)
{
    int k;
    for (k = 0; k < 4; ++k) {
        ls_biquad_reset(&d->lp[k]);
    }
    d->psi = LS_R(0.0);
    d->level = LS_R(0.0);
    d->ratio = LS_R(0.0);
    d->err = LS_R(0.0);
    d->valid = false;
}

void ls_demod_set_comp(ls_demod *d, bool on)
{
    d->use_comp = on && d->cfg.comp != NULL;
}

void ls_demod_set_gain_table(ls_demod *d, bool on)
{
    d->use_gain_table = on && d->cfg.gain_table != NULL;
}

LS_REAL ls_demod_step(ls_demod *d, LS_REAL i_a, LS_REAL i_b, LS_REAL theta_est, LS_REAL car_c,
                      LS_REAL car_s, LS_REAL psi_cal)
{
    LS_REAL psi = psi_cal;
    LS_REAL c, s, i_d, i_q, num, den, g;
    if (d->use_comp) {
        psi += ls_lut_step(d->cfg.comp, theta_est);
    }
    c = LS_COS(theta_est + psi);
    s = LS_SIN(theta_est + psi);
    i_d = c * i_a + s * i_b;
    i_q = -s * i_a + c * i_b;
    if (d->cfg.method == LS_DEMOD_PRODUCT) {
        num = ls_biquad_step(&d->lp[0], i_d * i_q);
        den = ls_biquad_step(&d->lp[1], i_d * i_d + i_q * i_q);
        d->level = den;
    } else {
        LS_REAL id_i = ls_biquad_step(&d->lp[0], i_d * car_c);
        LS_REAL id_q = ls_biquad_step(&d->lp[1], i_d * car_s);
        LS_REAL iq_i = ls_biquad_step(&d->lp[2], i_q * car_c);
        LS_REAL iq_q = ls_biquad_step(&d->lp[3], i_q * car_s);
        num = iq_i * id_i + iq_q * id_q;
        den = id_i * id_i + id_q * id_q;
        d->level = LS_R(2.0) * den;
    }
    d->psi = psi;
    d->valid = LS_ISFINITE(d->level) && d->level > d->cfg.min_level && den > LS_R(1e-30);
    if (!d->valid) {
        d->ratio = LS_R(0.0);
        d->err = LS_R(0.0);
        return d->err;
    }
    d->ratio = num / den;
    g = d->use_gain_table ? ls_lut_step(d->cfg.gain_table, theta_est) : d->cfg.gain;
    d->err = g * d->ratio;
    return d->err;
}
