/* linsense firmware library: demodulator of the HF currents into a position-error signal.
 *
 * The band-passed HF currents are rotated into the compensated frame
 *   theta_comp = theta_est + Psi_LUT(theta_est) + psi_cal
 * (paper Fig. 10; Psi_LUT from a caller-supplied table, switchable; psi_cal is the calibration
 * mode's adjustable angle). There the HF current has phase delta = psi - Psi_LUT, whose sign is
 * the sign of theta - theta_est (paper Fig. 8b). Two estimators of delta:
 *   LS_DEMOD_PRODUCT:    LP(i_d i_q) / LP(i_d^2 + i_q^2) = sin(2 delta)/2  (the paper's product)
 *   LS_DEMOD_HETERODYNE: synchronous I/Q demodulation of i_d and i_q with the injection carrier,
 *                        Re(i_q / i_d) = tan(delta)
 * Both are ratios, so the result does not depend on the injection amplitude.
 * With the rotating injection (ls_inject.h), LS_DEMOD_ROTATING: the band-passed alpha-beta current
 * times the carrier exp(j phi) brings the negative sequence i_n exp(-j phi) to DC (the positive
 * sequence to 2 f_inj, nulled by f_notch); its phase is 2 theta + 2 psi_rot(theta) + c_ref
 * (docs/theory.md, "Rotating-vector injection"), so with w = LP(i exp(j phi)) exp(-j (2 (theta_est
 * + Psi(theta_est)) + ref_phase)):
 *   ratio = Im(w) / (2 |w|) = sin(2 delta) / 2,  delta = theta + psi_rot(theta) - theta_est - Psi(theta_est)
 * and err = g ratio with g = 1 (gain) or the scheduled 1 / (1 + dPsi/dtheta) (gain_table): the
 * table Psi = psi_rot read at the estimate is the rotating injection's compensation.
 * The square-wave injection (LS_INJ_SQUARE) uses LS_DEMOD_PRODUCT on the signed current
 * differences the drive forms instead of the band-passed currents. Near zero
 * delta = -(L_q - L_d)/L_q * (theta_est - theta), so the output
 *   err = g * ratio,  g = L_q/(L_q - L_d)  (from `gain`, or position-scheduled from `gain_table`)
 * estimates theta - theta_est in rad. The scheduled gain normalises the error gain, which is
 * otherwise proportional to the local saliency (an improvement over the paper).
 */
#ifndef LINSENSE_LS_DEMOD_H
#define LINSENSE_LS_DEMOD_H

#include "linsense/ls_biquad.h"
#include "linsense/ls_lut.h"
#include "linsense/ls_math.h"
#include "linsense/ls_types.h"

/* -, largest |gain| ls_demod_init accepts: L_q/(L_q - L_d) = 1e4 is a saliency of 0.01 %, far too
 * little to estimate a position from */
#define LS_DEMOD_GAIN_MAX LS_R(1.0e4)

typedef enum {
    LS_DEMOD_PRODUCT = 0,
    LS_DEMOD_HETERODYNE = 1,
    LS_DEMOD_ROTATING = 2
} ls_demod_method;

typedef struct {
    ls_demod_method method;   /* error estimator */
    LS_REAL f_lpf;            /* Hz, corner of the 2nd-order low-pass filters, < fs/2 */
    LS_REAL fs;               /* Hz, sampling rate */
    LS_REAL gain;             /* -, g = L_q/(L_q - L_d) (nominal); non-zero, negative if L_d > L_q,
                                 |g| <= LS_DEMOD_GAIN_MAX */
    const ls_lut *comp;       /* compensation table Psi_LUT(theta_est), rad; NULL: none */
    const ls_lut *gain_table; /* g(theta_est), -; replaces `gain` when not NULL and enabled */
    const ls_lut *comp_r;     /* dPsi_LUT/dk_r(theta_est), rad: the table's change per unit of the
                                 resistance's scale k_r (the drive's measured k_r, ls_dtres.h):
                                 Psi_LUT + (k_r - 1) comp_r is used with the table; NULL: none */
    const ls_lut *gain_r;     /* dg/dk_r(theta_est), -: the gain table's change per unit of k_r, used
                                 with it as g + (k_r - 1) gain_r; NULL: none */
    LS_REAL min_level;        /* A^2, HF mean-square current below which err is held at 0, >= 0 */
    LS_REAL f_notch;          /* Hz, the low-pass filters' zeros (instead of at fs/2), 2 f_inj: nulls the
                                 products' ripple at twice the injection frequency (0: plain), < fs/2 */
    LS_REAL ref_phase;        /* rad, LS_DEMOD_ROTATING: c_ref, the negative sequence's phase less
                                 2 theta for a motor without end-effect, plus the carrier's delay
                                 (delay_comp 2 pi f_inj / fs); finite, |ref_phase| <= 4 pi */
} ls_demod_cfg;

typedef struct {
    ls_demod_cfg cfg;  /* copy of the configuration */
    ls_biquad lp[4];   /* low-pass filters (product: 2 used; heterodyne: 4), zeros at f_notch */
    bool use_comp;     /* compensation table in use */
    bool use_gain_table; /* gain table in use */
    LS_REAL k_r;       /* -, the resistance's scale the tables are corrected for (cfg.comp_r,
                          cfg.gain_r; 1 after init and reset; the drive writes it) */
    LS_REAL psi;       /* rad, total compensation angle used at the last step */
    LS_REAL level;     /* A^2, mean-square HF current at the last step */
    LS_REAL ratio;     /* -, normalised error before the gain (~ delta) */
    LS_REAL err;       /* rad, estimate of theta - theta_est at the last step */
    bool valid;        /* level above min_level at the last step */
    LS_REAL ref_c, ref_s; /* -, cos and sin of ref_phase (rotating) */
    LS_REAL den_min;   /* A^2, max(min_level, 1e-30): the product's level, its denominator, is valid
                          above it */
} ls_demod;

ls_status ls_demod_init(ls_demod *d, const ls_demod_cfg *cfg);
void ls_demod_reset(ls_demod *d);
/* Switch the compensation table on (only if cfg.comp was given) or off. */
void ls_demod_set_comp(ls_demod *d, bool on);
/* Switch the position-scheduled gain on (only if cfg.gain_table was given) or off. */
void ls_demod_set_gain_table(ls_demod *d, bool on);
/* ls_demod_step given c_est = cos(theta_est), s_est = sin(theta_est) (the drive has them): the
 * rotation into theta_est + psi is that of theta_est turned by psi. Inline (called every PWM period). */
/* LS_DEMOD_ROTATING's numerator (returned) and denominator (*den) of the ratio, and d->level,
 * given the band-passed alpha-beta current, (c, s) = cos and sin of theta_est + psi and the
 * rotating carrier (out of line: called from ls_demod_step_cs). */
LS_REAL ls_demod_rot_(ls_demod *d, LS_REAL i_a, LS_REAL i_b, LS_REAL c, LS_REAL s, LS_REAL car_c, LS_REAL car_s,
                      LS_REAL *den);

/* ls_demod_step_cs given the compensation angle psi (rad) and its cosine and sine (c_psi, s_psi):
 * the step without the table and the trigonometry (the calibration turns psi_cal's by small
 * steps). Inline (called every PWM period). */
static inline LS_REAL ls_demod_step_psi(ls_demod *d, LS_REAL i_a, LS_REAL i_b, LS_REAL theta_est,
                                        LS_REAL c_est, LS_REAL s_est, LS_REAL car_c, LS_REAL car_s,
                                        LS_REAL psi, LS_REAL c_psi, LS_REAL s_psi)
{
    LS_REAL c, s, i_d, i_q, num, den, g, inv;
    const bool product = d->cfg.method == LS_DEMOD_PRODUCT;
    if (product) {
        /* i_d^2 + i_q^2 = i_a^2 + i_b^2 (a rotation keeps the length): the level, and the
         * division below, do not wait for the angle */
        den = ls_biquad_step_sym(&d->lp[1], i_a * i_a + i_b * i_b);
        d->level = den;
    }
    /* cos and sin of theta_est + psi */
    c = c_est * c_psi - s_est * s_psi;
    s = s_est * c_psi + c_est * s_psi;
    i_d = c * i_a + s * i_b;
    i_q = -s * i_a + c * i_b;
    if (product) {
        num = ls_biquad_step_sym(&d->lp[0], i_d * i_q);
        /* level = den: finite, above min_level and 1e-30 (false for NaN) */
        d->valid = den > d->den_min && den <= LS_REAL_MAX;
    } else if (d->cfg.method == LS_DEMOD_ROTATING) {
        num = ls_demod_rot_(d, i_a, i_b, c, s, car_c, car_s, &den);
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
    if (!product) {
        d->valid = LS_ISFINITE(d->level) && d->level > d->cfg.min_level && den > LS_R(1e-30);
    }
    if (!d->valid) {
        d->ratio = LS_R(0.0);
        d->err = LS_R(0.0);
        return d->err;
    }
    inv = LS_R(1.0) / den; /* the demodulator's one division */
    g = d->cfg.gain;
    if (d->use_gain_table) {
        g = ls_lut_step(d->cfg.gain_table, theta_est);
        if (d->cfg.gain_r != NULL) {
            g += (d->k_r - LS_R(1.0)) * ls_lut_step(d->cfg.gain_r, theta_est);
        }
    }
    d->ratio = num * inv;
    d->err = num * (g * inv); /* = g ratio */
    return d->err;
}

/* The compensation angle psi = psi_cal + Psi_LUT(theta_est) (the table when it is on), returned,
 * and its cosine and sine; theta_norm: theta_est is in [0, 2 pi) (an ls_pos's theta: the table is
 * read without the range check). Inline. */
static inline LS_REAL ls_demod_comp_(const ls_demod *d, LS_REAL theta_est, LS_REAL psi_cal, LS_REAL *c_psi,
                                     LS_REAL *s_psi, const bool theta_norm)
{
    LS_REAL psi = psi_cal;
    LS_REAL c, s; /* (locals: the callers' stay in registers) */
    if (d->use_comp) {
        psi = psi_cal +
              (theta_norm ? ls_lut_step_norm(d->cfg.comp, theta_est) : ls_lut_step(d->cfg.comp, theta_est));
        if (d->cfg.comp_r != NULL) {
            psi += (d->k_r - LS_R(1.0)) * (theta_norm ? ls_lut_step_norm(d->cfg.comp_r, theta_est)
                                                      : ls_lut_step(d->cfg.comp_r, theta_est));
        }
    }
#ifdef LS_REAL_DOUBLE
    c = cos(psi);
    s = sin(psi);
#else
    if (LS_FABS(psi) <= LS_PI / LS_R(4.0)) { /* a compensation angle: no range reduction */
        ls_sincos_kernel(psi, 0u, &c, &s);
    } else {
        ls_sincos(psi, &c, &s); /* also NaN */
    }
#endif
    *c_psi = c;
    *s_psi = s;
    return psi;
}

/* ls_demod_comp_ for theta_est in [0, 2 pi) (an ls_pos's theta: ls_drive's steps). */
static inline LS_REAL ls_demod_comp_norm(const ls_demod *d, LS_REAL theta_est, LS_REAL psi_cal, LS_REAL *c_psi,
                                         LS_REAL *s_psi)
{
    return ls_demod_comp_(d, theta_est, psi_cal, c_psi, s_psi, true);
}

static inline LS_REAL ls_demod_step_cs(ls_demod *d, LS_REAL i_a, LS_REAL i_b, LS_REAL theta_est,
                                       LS_REAL c_est, LS_REAL s_est, LS_REAL car_c, LS_REAL car_s,
                                       LS_REAL psi_cal)
{
    LS_REAL c_psi, s_psi;
    const LS_REAL psi = ls_demod_comp_(d, theta_est, psi_cal, &c_psi, &s_psi, false);
    return ls_demod_step_psi(d, i_a, i_b, theta_est, c_est, s_est, car_c, car_s, psi, c_psi, s_psi);
}

/* ls_demod_step_cs for theta_est in [0, 2 pi) (an ls_pos's theta: ls_drive's steps). */
static inline LS_REAL ls_demod_step_cs_norm(ls_demod *d, LS_REAL i_a, LS_REAL i_b, LS_REAL theta_est,
                                            LS_REAL c_est, LS_REAL s_est, LS_REAL car_c, LS_REAL car_s,
                                            LS_REAL psi_cal)
{
    LS_REAL c_psi, s_psi;
    const LS_REAL psi = ls_demod_comp_norm(d, theta_est, psi_cal, &c_psi, &s_psi);
    return ls_demod_step_psi(d, i_a, i_b, theta_est, c_est, s_est, car_c, car_s, psi, c_psi, s_psi);
}

/* One step. i_a, i_b: band-passed HF currents (A); theta_est (rad); (car_c, car_s): the
 * injection carrier (used by the heterodyne); psi_cal: extra compensation angle (rad).
 * Returns err (rad), 0 while the HF level is too low. Inline (called every PWM period). */
static inline LS_REAL ls_demod_step(ls_demod *d, LS_REAL i_a, LS_REAL i_b, LS_REAL theta_est,
                                    LS_REAL car_c, LS_REAL car_s, LS_REAL psi_cal)
{
    LS_REAL c_est, s_est;
    ls_sincos(theta_est, &c_est, &s_est);
    return ls_demod_step_cs(d, i_a, i_b, theta_est, c_est, s_est, car_c, car_s, psi_cal);
}

#endif /* LINSENSE_LS_DEMOD_H */
