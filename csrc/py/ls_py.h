/* linsense: C helpers of the Python binding (linsense._ctrl), not firmware.
 *
 * Compiled into the cffi extension beside the library (tools/build_ctrl.py), which declares them
 * to Python from this header as it does the library's public headers (whose functions, static
 * inline ones too, Python calls directly). Whole-array helpers: one call per array, no Python per
 * sample. Inputs and outputs are double arrays of n samples; each
 * sample is converted to LS_REAL on the way in, as an ADC value would be. Optional pointers (may
 * be NULL) are marked. Angles returned are unwrapped: 2 pi period + theta, in double.
 */
#ifndef LINSENSE_LS_PY_H
#define LINSENSE_LS_PY_H

#include "linsense/ls_drive.h"

/* Digest of the sources the extension was compiled from (defined by the build script, which
 * computes it; linsense.ctrl compares it with the source tree's). */
const char *ls_py_source_digest(void);

/* ls_lut_step at each theta (rad). */
void ls_py_lut_run(const ls_lut *lut, const double *theta, size_t n, double *out);
/* ls_biquad_step over x. */
void ls_py_biquad_run(ls_biquad *f, const double *x, size_t n, double *y);
/* v_out: HF voltage of each step; car_c_out, car_s_out (optional): the carrier phasor the step
 * used (the state before ls_inject_step advances it), as the drive hands it to the demodulator. */
void ls_py_inject_run(ls_inject *inj, size_t n, double *v_out, double *car_c_out, double *car_s_out);
/* ls_demod_step over the arrays; car_c, car_s, psi_cal (NULL: 0), ratio_out, level_out optional. */
void ls_py_demod_run(ls_demod *d, const double *i_a, const double *i_b, const double *theta_est,
                     const double *car_c, const double *car_s, const double *psi_cal, size_t n,
                     double *err_out, double *ratio_out, double *level_out);
/* Open loop: the observer driven by a given error sequence eps (rad). f_motor optional (0 N).
 * theta_out: unwrapped estimate after each step (rad); omega_out, f_load_out optional. */
void ls_py_observer_run(ls_observer *o, const double *eps, const double *f_motor, size_t n,
                        double *theta_out, double *omega_out, double *f_load_out);
/* Closed loop as with an encoder: eps = theta[k] - theta_est (unwrapped, rad), as ls_pos_diff of
 * the true and estimated positions. theta: true unwrapped angle (rad). Outputs as above. */
void ls_py_observer_track(ls_observer *o, const double *theta, const double *f_motor, size_t n,
                          double *theta_out, double *omega_out, double *f_load_out);
/* The drive on recorded measurements (no plant): i_abc is n x 3 (row-major), v_dc n values,
 * enc_count optional (NULL: encoder not valid). duty_out n x 3, fault_out, enable_out n values;
 * theta_est_out (unwrapped HF estimate, rad) and err_out (demodulated error) optional. */
void ls_py_drive_run(ls_drive *d, const double *i_abc, const double *v_dc, const int32_t *enc_count,
                     size_t n, double *duty_out, uint32_t *fault_out, uint8_t *enable_out,
                     double *theta_est_out, double *err_out);

#endif /* LINSENSE_LS_PY_H */
