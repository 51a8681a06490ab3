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
 * Both are ratios, so the result does not depend on the injection amplitude. Near zero
 * delta = -(L_q - L_d)/L_q * (theta_est - theta), so the output
 *   err = g * ratio,  g = L_q/(L_q - L_d)  (from `gain`, or position-scheduled from `gain_table`)
 * estimates theta - theta_est in rad. The scheduled gain normalises the error gain, which is
 * otherwise proportional to the local saliency (an improvement over the paper).
 */
#ifndef LINSENSE_LS_DEMOD_H
#define LINSENSE_LS_DEMOD_H

#include "linsense/ls_filter.h"
#include "linsense/ls_lut.h"
#include "linsense/ls_types.h"

typedef enum {
    LS_DEMOD_PRODUCT = 0,
    LS_DEMOD_HETERODYNE = 1
} ls_demod_method;

typedef struct {
    ls_demod_method method;   /* error estimator */
    LS_REAL f_lpf;            /* Hz, corner of the 2nd-order low-pass filters, < fs/2 */
    LS_REAL fs;               /* Hz, sampling rate */
    LS_REAL gain;             /* -, g = L_q/(L_q - L_d) (nominal); non-zero, negative if L_d > L_q */
    const ls_lut *comp;       /* compensation table Psi_LUT(theta_est), rad; NULL: none */
    const ls_lut *gain_table; /* g(theta_est), -; replaces `gain` when not NULL and enabled */
    LS_REAL min_level;        /* A^2, HF mean-square current below which err is held at 0, >= 0 */
} ls_demod_cfg;

typedef struct {
    ls_demod_cfg cfg;  /* copy of the configuration */
    ls_biquad lp[4];   /* low-pass filters (product: 2 used; heterodyne: 4) */
    bool use_comp;     /* compensation table in use */
    bool use_gain_table; /* gain table in use */
    LS_REAL psi;       /* rad, total compensation angle used at the last step */
    LS_REAL level;     /* A^2, mean-square HF current at the last step */
    LS_REAL ratio;     /* -, normalised error before the gain (~ delta) */
    LS_REAL err;       /* rad, estimate of theta - theta_est at the last step */
    bool valid;        /* level above min_level at the last step */
} ls_demod;

ls_status ls_demod_init(ls_demod *d, const ls_demod_cfg *cfg);
void ls_demod_reset(ls_demod *d);
/* Switch the compensation table on (only if cfg.comp was given) or off. */
void ls_demod_set_comp(ls_demod *d, bool on);
/* Switch the position-scheduled gain on (only if cfg.gain_table was given) or off. */
void ls_demod_set_gain_table(ls_demod *d, bool on);
/* One step. i_a, i_b: band-passed HF currents (A); theta_est (rad); (car_c, car_s): the
 * injection carrier (used by the heterodyne); psi_cal: extra compensation angle (rad).
 * Returns err (rad), 0 while the HF level is too low. */
LS_REAL ls_demod_step(ls_demod *d, LS_REAL i_a, LS_REAL i_b, LS_REAL theta_est, LS_REAL car_c,
                      LS_REAL car_s, LS_REAL psi_cal);

#endif /* LINSENSE_LS_DEMOD_H */
