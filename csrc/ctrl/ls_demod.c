/* HF demodulator (see linsense/ls_demod.h). */
#include <math.h>

#include "linsense/ls_demod.h"

ls_status ls_demod_init(ls_demod *d, const ls_demod_cfg *cfg)
{
    ls_biquad_cfg lp;
    LS_REAL cn, sn, g;
    int k;
    if (d == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if ((cfg->method != LS_DEMOD_PRODUCT && cfg->method != LS_DEMOD_HETERODYNE && cfg->method != LS_DEMOD_ROTATING) ||
        !LS_ISFINITE(cfg->ref_phase) || !(LS_FABS(cfg->ref_phase) <= LS_R(2.0) * LS_TWO_PI) ||
        !LS_ISFINITE(cfg->gain) || cfg->gain == LS_R(0.0) || !(LS_FABS(cfg->gain) <= LS_DEMOD_GAIN_MAX) || !LS_ISFINITE(cfg->min_level) ||
        cfg->min_level < LS_R(0.0) || !LS_ISFINITE(cfg->f_notch) || cfg->f_notch < LS_R(0.0) ||
        cfg->f_notch >= LS_R(0.5) * cfg->fs) {
        return LS_ERR_PARAM;
    }
    if ((cfg->comp != NULL && cfg->comp->len < 4u) || (cfg->gain_table != NULL && cfg->gain_table->len < 4u) ||
        (cfg->comp_r != NULL && cfg->comp_r->len < 4u) || (cfg->gain_r != NULL && cfg->gain_r->len < 4u)) {
        return LS_ERR_PARAM;
    }
    d->den_min = cfg->min_level > LS_R(1e-30) ? cfg->min_level : LS_R(1e-30);
    lp.type = LS_BIQUAD_LOWPASS;
    lp.f0 = cfg->f_lpf;
    lp.q = LS_R(0.70710678);
    lp.fs = cfg->fs;
    for (k = 0; k < 4; ++k) {
        if (ls_biquad_init(&d->lp[k], &lp) != LS_OK) {
            return LS_ERR_PARAM;
        }
        if (cfg->f_notch > LS_R(0.0)) {
            /* the numerator's zeros moved from z = -1 to exp(+-j w_n): g (1 - 2 cos w_n z^-1 + z^-2),
             * g for unity DC gain, the poles unchanged (one biquad, the ripple at f_notch nulled) */
            ls_sincos_full(LS_TWO_PI * cfg->f_notch / cfg->fs, &cn, &sn);
            g = (LS_R(1.0) + d->lp[k].a1 + d->lp[k].a2) / (LS_R(2.0) - LS_R(2.0) * cn);
            if (!LS_ISFINITE(g) || !(cn < LS_R(1.0))) { /* a notch too low for the arithmetic */
                return LS_ERR_PARAM;
            }
            d->lp[k].b0 = g;
            d->lp[k].b1 = LS_R(-2.0) * cn * g;
            d->lp[k].b2 = g;
        }
    }
    d->cfg = *cfg;
    ls_sincos_full(cfg->ref_phase, &d->ref_c, &d->ref_s);
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
    d->k_r = LS_R(1.0);
}

void ls_demod_set_comp(ls_demod *d, bool on)
{
    d->use_comp = on && d->cfg.comp != NULL;
}

void ls_demod_set_gain_table(ls_demod *d, bool on)
{
    d->use_gain_table = on && d->cfg.gain_table != NULL;
}

LS_REAL ls_demod_rot_(ls_demod *d, LS_REAL i_a, LS_REAL i_b, LS_REAL c, LS_REAL s, LS_REAL car_c, LS_REAL car_s,
                      LS_REAL *den)
{
    /* cos and sin of 2 (theta_est + psi) + ref_phase */
    const LS_REAL cc = c * c - s * s, ss = LS_R(2.0) * c * s;
    const LS_REAL c2 = cc * d->ref_c - ss * d->ref_s;
    const LS_REAL s2 = ss * d->ref_c + cc * d->ref_s;
    /* the negative sequence at DC: the alpha-beta current times the carrier exp(j phi) */
    const LS_REAL z_r = ls_biquad_step(&d->lp[0], i_a * car_c - i_b * car_s);
    const LS_REAL z_i = ls_biquad_step(&d->lp[1], i_a * car_s + i_b * car_c);
    const LS_REAL level = z_r * z_r + z_i * z_i;
    d->level = level;
    /* Im(z exp(-j (2 (theta_est + psi) + ref_phase))) / (2 |z|) = sin(2 delta) / 2 */
    *den = LS_R(2.0) * LS_SQRT(level);
    return z_i * c2 - z_r * s2;
}
