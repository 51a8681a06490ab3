/* linsense firmware library: the back-EMF (extended-EMF) position error in the estimated frame, for
 * speed (docs/theory.md, "The EMF observer at speed").
 *
 * A salient PM motor's voltage equation written with the extended EMF (Chen, Tomita, Doki, Okuma,
 * IEEE TIE 50(2), 2003) is rotationally symmetric: in alpha-beta
 *   v_ab = R i_ab + L_d d(i_ab)/dt + omega (L_q - L_d) J i_ab + E_ex (-sin theta, cos theta),
 *   E_ex = omega (psi_pm + (L_d - L_q) i_d) - (L_d - L_q) d(i_q)/dt,   J = [0 -1; 1 0],
 * so the EMF vector is read from the voltage and the currents without the angle or psi_pm, and
 * points along the true q-axis. Over the period that has just ended (its mean voltage v_ab, its
 * start and end currents i0 and i1, the trapezoidal mean current i_m = (i0 + i1) / 2):
 *   e_ab = v_ab - k_r r_s i_m - l_d (i1 - i0) fs - omega (l_q - l_d) J i_m,
 * turned into the estimated frame at the period's middle (theta_est - omega Ts / 2) and low-passed
 * there (first order, corner f_lpf: in steady state the vector is constant in that frame). With
 * theta_est = theta + theta_err, e_dq_est = E_ex (sin theta_err, cos theta_err), so the position
 * error, the observer's eps = theta - theta_est, is
 *   eps = atan2(-sg e_d, sg e_q),  sg = the sign of the estimated speed (E_ex follows omega).
 * A trust measure for the speed-scheduled fusion: the bound on |eps| that the model's uncertainty
 * allows. The estimate is e = e_true + de, de = a i + b J i + n with |a| <= err_r k_r r_s (a
 * resistance error, and the inverter's error, which follows the current: u_err), |b| <= err_l l_q
 * |omega| (an inductance error) and n the rest (current noise, b_noise; the inverter error's ripple
 * across the current, u_err / 2 turning at 6 omega, through the low-pass). With i_par and i_perp the
 * current's parts along and across e, de's parts along and across e are at most
 *   par  = err_r k_r r_s i_par + err_l l_q |omega| i_perp + u_err + b_noise,
 *   perp = err_r k_r r_s i_perp + err_l l_q |omega| i_par + u_err (i_perp / |i| + rip) + b_noise,
 *   rip  = sqrt 2 w_c / (2 (w_c + 6 |omega|))   (>= half the low-pass's gain at 6 omega),
 * and the true EMF's angle differs from e's by at most atan(perp / (|e| - par)) <= perp / (|e| -
 * par): the bound (pi / 2 when |e| <= par or beyond). psi_pm enters neither eps nor the bound
 * (balanced).
 * The magnets' imbalance (docs/theory.md, "The end effect on the magnets' flux"): phases linking
 * unequal magnet flux make the EMF jw psi_pm P (e^{j theta} - n e^{-j theta}) (alpha-beta as a complex
 * number; the zero sequence drives no current with the floating star point and the Clarke transform
 * of the currents and of the commanded voltages holds none), P the positive sequence (1 balanced),
 * n = conj(N) / P the negative sequence's ratio to it (0 balanced). Read raw, eps then carries an
 * offset arg P and a ripple |n| at 2 theta; with the motor file's values in the cfg (psi_pm = |P|
 * times the file's psi_pm, pm_shift = arg P, neg = n) the step adds the negative sequence's EMF
 * predicted at the estimated angle, jw psi_pm e^{j pm_shift} n e^{-j theta_m}, to e_ab before the
 * frame turn and the low-pass, and turns (sg e_q, -sg e_d) by -pm_shift before the atan2: what is
 * left is |n| times the estimate's own error (second order) and the flux's harmonics. All four at 0:
 * the balanced block, bit for bit.
 * ls_emf_omega_min inverts it for the design: the speed above which the bound holds (the hand-over).
 */
#ifndef LINSENSE_LS_EMF_H
#define LINSENSE_LS_EMF_H

#include "linsense/ls_types.h"

/* The low-pass corner's largest share of the sampling rate (f_lpf <= LS_EMF_FLPF_FS_MAX fs): the
 * period model (trapezoidal mean, the half-period angle) holds to a tenth of the Nyquist rate. */
#define LS_EMF_FLPF_FS_MAX LS_R(0.05)
/* The largest electrical angle per period of the speed range (omega_max Ts): the trapezoidal mean's
 * error, (omega Ts)^2 / 12 of the EMF, stays below 0.6 % and the half-period rotation's series
 * below 1e-5 rad. */
#define LS_EMF_OMEGA_TS_MAX LS_R(0.25)
/* The largest relative uncertainty of r_s and l_q (err_r, err_l): below 1 (at 1 the model is
 * nothing). */
#define LS_EMF_ERR_REL_MAX LS_R(0.9)
/* The largest negative sequence of the magnets' flux relative to the positive one (|n|, refused at
 * and above): a motor that unbalanced (as if one phase linked no magnet flux at all: scale (0, 1, 1)
 * gives |n| = 0.5) is not a three-phase motor, and the compensation's second-order residual
 * |n| |theta_err| is no longer small. */
#define LS_EMF_NEG_MAX LS_R(0.5)
/* The largest phase of the magnets' positive sequence (|pm_shift|, rad): 30 deg; the end effect
 * moves the phases' axes by a few degrees, a positive sequence this far off means the motor file's
 * phase order or position origin is wrong. */
#define LS_EMF_PM_SHIFT_MAX LS_R(0.523598776)
/* The magnets' flux harmonics the block compensates (docs/theory.md, "The hand-over"): at most
 * LS_EMF_HARM_N of them (a motor file's largest two: the 5th and 7th of a flat magnet), each of an
 * order n with n mod 3 != 0 (a triplen is zero sequence, which the star winding does not see) up to
 * LS_EMF_HARM_ORDER_MAX, and a coefficient |c| below LS_EMF_HARM_MAX psi_pm. */
#define LS_EMF_HARM_N 2
#define LS_EMF_HARM_ORDER_MAX 25u
#define LS_EMF_HARM_MAX LS_R(0.2)

typedef struct {
    LS_REAL fs;        /**< unit: Hz, sampling rate (one step per PWM period), > 0 */
    LS_REAL r_s;       /**< unit: ohm, phase resistance at k_r = 1, >= 0 */
    LS_REAL l_d;       /**< unit: H, d-axis inductance of the fundamental, > 0 */
    LS_REAL l_q;       /**< unit: H, q-axis inductance of the fundamental, > 0 */
    LS_REAL f_lpf;     /**< unit: Hz, corner of the EMF's first-order low-pass in the estimated frame,
                            > 0, <= LS_EMF_FLPF_FS_MAX fs */
    LS_REAL omega_max; /**< unit: rad/s, the electrical speed range (the speed input is clamped to it),
                            > 0, omega_max / fs <= LS_EMF_OMEGA_TS_MAX */
    LS_REAL err_r;     /**< unit: -, relative uncertainty of the resistance k_r r_s (after the online
                            estimate), in [0, LS_EMF_ERR_REL_MAX] */
    LS_REAL err_l;     /**< unit: -, relative uncertainty of l_q, in [0, LS_EMF_ERR_REL_MAX] */
    LS_REAL u_err;     /**< unit: V, bound of the inverter's voltage error (the dead time's residual
                            after compensation, the bus measurement's error), >= 0 */
    LS_REAL i_noise;   /**< unit: A, rms white noise of a current sample per axis, >= 0 */
    LS_REAL psi_pm;    /**< unit: Wb, the magnets' positive-sequence flux linkage |P| psi_pm (the motor
                            file's psi_pm when balanced), >= 0; > 0 when neg_re or neg_im is not 0 */
    LS_REAL pm_shift;  /**< unit: rad, the magnets' positive sequence's phase advance arg P (electrical),
                            |pm_shift| <= LS_EMF_PM_SHIFT_MAX; 0 balanced */
    LS_REAL neg_re;    /**< unit: -, real part of n = conj(N) / P, the magnets' negative sequence
                            relative to the positive one; |n| < LS_EMF_NEG_MAX; 0 balanced */
    LS_REAL neg_im;    /**< unit: -, imaginary part of n; 0 balanced */
    uint32_t harm_order[LS_EMF_HARM_N]; /**< unit: -, the orders n of the magnets' flux harmonics
                            compensated (0: none), n mod 3 != 0, n <= LS_EMF_HARM_ORDER_MAX: their
                            flux vector c e^{j s n theta} (alpha-beta; s = +1 for n mod 3 = 1, -1 for
                            n mod 3 = 2) and EMF j omega s n c e^{j s n theta} are taken out of e_ab */
    LS_REAL harm_re[LS_EMF_HARM_N]; /**< unit: Wb, real part of c: psi_pm a cos(s phi) for the motor
                            file's harmonic a cos(n u + phi) of each phase's flux */
    LS_REAL harm_im[LS_EMF_HARM_N]; /**< unit: Wb, imaginary part of c: psi_pm a sin(s phi); |c| <=
                            LS_EMF_HARM_MAX psi_pm */
} ls_emf_cfg;

typedef struct {
    ls_emf_cfg cfg;      /**< unit: -, copy of the configuration */
    LS_REAL alpha;       /**< unit: -, the low-pass's step 1 - exp(-2 pi f_lpf Ts) */
    LS_REAL l_fs;        /**< unit: ohm, l_d fs (the inductive drop per ampere of change) */
    LS_REAL half_ts;     /**< unit: s, Ts / 2 (the period's middle) */
    LS_REAL b_noise;     /**< unit: V, 3 sigma of the low-passed EMF from i_noise */
    LS_REAL w_rip;       /**< unit: rad/s, sqrt 2 w_c / 2 (the ripple's attenuation: w_rip / (w_c + 6 |omega|)) */
    LS_REAL w_c;         /**< unit: rad/s, 2 pi f_lpf */
    LS_REAL k_neg[2];    /**< unit: Wb, psi_pm e^{j pm_shift} n (re, im): the negative sequence's flux */
    LS_REAL c_pm, s_pm;  /**< unit: -, cos and sin of pm_shift */
    bool pm_comp;        /**< unit: -, the imbalance is compensated (a field of it is not 0) */
    LS_REAL harm_m[LS_EMF_HARM_N]; /**< unit: -, s n of each harmonic (0: none) */
    bool harm_on;        /**< unit: -, a harmonic is compensated */
    LS_REAL i0[2];       /**< unit: A, the currents at the start of the period (alpha-beta) */
    bool primed;         /**< unit: -, i0 holds a sample (false: the first step only stores it) */
    LS_REAL e_d, e_q;    /**< unit: V, the low-passed EMF in the estimated frame */
    LS_REAL i_d, i_q;    /**< unit: A, the low-passed current in the estimated frame */
    LS_REAL mag;         /**< unit: V, |(e_d, e_q)| */
    LS_REAL eps;         /**< unit: rad, the position error theta - theta_est (0 before the first
                              period and while mag is 0) */
    LS_REAL bound;       /**< unit: rad, the bound on |eps| the uncertainties allow, in (0, pi/2];
                              pi / 2: no trust */
} ls_emf;

ls_status ls_emf_init(ls_emf *e, const ls_emf_cfg *cfg);
/* The filters and the stored current back to zero, no trust (bound pi / 2). */
void ls_emf_reset(ls_emf *e);
/* The bound on |eps| (rad, in [0, pi/2]) for an EMF of magnitude mag (V) and a current with parts
 * i_par along it and i_perp across it (A, >= 0), at the electrical speed omega (rad/s) and the
 * resistance scale k_r (the header's formula; pi / 2 for |e| <= par or a non-finite argument). */
LS_REAL ls_emf_bound(const ls_emf *e, LS_REAL mag, LS_REAL i_par, LS_REAL i_perp, LS_REAL omega, LS_REAL k_r);
/* The lowest electrical speed (rad/s) from which the bound is at most eps_max (rad, in (0, pi/2)) in
 * the steady state of a current i_mag (A) on the q-axis and an EMF of omega psi (psi: Wb, the
 * magnets' flux linkage), the resistance scale k_r: ls_emf_bound falls with the speed and is found
 * by bisection (to 1e-4 relative); LS_REAL_MAX when omega_max does not reach it or an argument is
 * out of range. */
LS_REAL ls_emf_omega_min(const ls_emf *e, LS_REAL i_mag, LS_REAL psi, LS_REAL eps_max, LS_REAL k_r);

/* One PWM period: v_ab, the mean voltage applied over the period that has just ended (V, alpha-beta:
 * the command of the step before, one-period PWM update); i_ab, the currents sampled now at its end
 * (A, alpha-beta); (c, s), cos and sin of the estimated angle now; omega, the estimated electrical
 * speed (rad/s, clamped to +-omega_max); k_r, the online resistance scale (ls_dtres's k_r; 1
 * without; clamped to [LS_DTRES_KR_MIN, LS_DTRES_KR_MAX] here and in ls_emf_bound).
 * Updates e_d, e_q, i_d, i_q, mag, eps and bound; returns eps (rad). A non-finite input leaves the
 * filters as they were and drops the stored current (the next step only stores its sample). */
LS_REAL ls_emf_step(ls_emf *e, const LS_REAL v_ab[2], const LS_REAL i_ab[2], LS_REAL c, LS_REAL s,
                    LS_REAL omega, LS_REAL k_r);
/* ls_emf_step_eps in two parts, for a caller that needs the angle only on some periods (ls_drive: where
 * the hand-over weighs the EMF error, above handover_v_lo). ls_emf_update: the period's filters
 * (e_d, e_q, i_d, i_q; the inputs as ls_emf_step's); true when they moved (false: a non-finite input,
 * or the first sample only stored). ls_emf_angle: mag and eps from the filters as they are, omega
 * giving the direction (rad/s, finite); returns eps (rad). The filters run every period whatever
 * the caller does with the angle: the angle is ready, bit for bit as ls_emf_step_eps's, on the
 * first period it is asked for. ls_emf_step_eps = ls_emf_update, then ls_emf_angle when the
 * filters moved. */
bool ls_emf_update(ls_emf *e, const LS_REAL v_ab[2], const LS_REAL i_ab[2], LS_REAL c, LS_REAL s, LS_REAL omega,
                   LS_REAL k_r);
LS_REAL ls_emf_angle(ls_emf *e, LS_REAL omega);
/* ls_emf_update without its guard against non-finite inputs, for a caller whose inputs are finite by
 * construction (ls_drive: it checks its measurements first and its outputs last); the same filters
 * bit for bit on finite inputs, eight finiteness tests less. */
bool ls_emf_update_finite(ls_emf *e, const LS_REAL v_ab[2], const LS_REAL i_ab[2], LS_REAL c, LS_REAL s,
                          LS_REAL omega, LS_REAL k_r);
/* The same step without the bound (eps, mag and the filters bit for bit as ls_emf_step's; bound left
 * as it was): for a caller that does not use it, such as ls_drive (its hand-over is scheduled on the
 * estimated speed), one square root and four divisions less per step. */
LS_REAL ls_emf_step_eps(ls_emf *e, const LS_REAL v_ab[2], const LS_REAL i_ab[2], LS_REAL c, LS_REAL s,
                        LS_REAL omega, LS_REAL k_r);

#endif /* LINSENSE_LS_EMF_H */
