/* Pieces the steps of ls_drive_step share (ls_drive.c, ls_drive_startup.c, ls_drive_rotating.c,
 * ls_drive_square.c, ls_drive_encoder.c): private to the library, static inline so that each step
 * keeps its own compiled copy. (The checks, Clarke and alignment at the start of the rotating and
 * square steps are written out in each: shared, they cost those steps 5 and 13 instructions; so is
 * the encoder step's force with the calibration's dither: through ls_drive_path_force_ with the
 * dither as an argument it cost the encoder modes 5 and 7, and they have 12 to spare.) */
#ifndef LINSENSE_LS_DRIVE_PATH_H
#define LINSENSE_LS_DRIVE_PATH_H

#include "linsense/ls_drive.h"
#include "linsense/ls_math.h"

/* psi_cal's cosine and sine, exactly (|psi_cal| <= pi/4). */
static inline void ls_drive_cal_cs_(ls_drive *d)
{
#ifdef LS_REAL_DOUBLE
    d->cal_c = cos(d->psi_cal);
    d->cal_s = sin(d->psi_cal);
#else
    ls_sincos_kernel(d->psi_cal, 0u, &d->cal_c, &d->cal_s);
#endif
}

/* A new averaging window of the calibration (ls_drive_encoder.c, calibration_step). */
static inline void ls_drive_cal_window_reset_(ls_drive *d)
{
    d->cal_hold = 0u;
    d->cal_sum_err = LS_R(0.0);
    d->cal_sum_psi = LS_R(0.0);
}

/* After a mode change, once the reference is aligned: the move or step commanded with it. */
static inline void ls_drive_path_pending_(ls_drive *d)
{
    if (d->align) {
        if (d->pending) {
            d->pending = false;
            if (d->pending_move) {
                ls_traj_move(&d->traj, d->pending_target);
            } else {
                ls_traj_jump(&d->traj, d->pending_target);
            }
        }
        d->align = false;
    }
}

/* The reference at the estimate after a mode change, then the move or step commanded with it. */
static inline void ls_drive_path_align_(ls_drive *d)
{
    if (d->align) {
        ls_traj_reset(&d->traj, d->obs.pos);
    }
    ls_drive_path_pending_(d);
}

/* The HF observer on the demodulated error (counted once the injection has reached its
 * amplitude) and its plausibility check; true: a fault tripped. */
static inline bool ls_drive_path_observe_(ls_drive *d, LS_REAL err)
{
    const LS_REAL e_obs = d->inj.amp >= d->cfg.inject.amplitude ? err : LS_R(0.0);
    ls_observer_step_finite(&d->obs, e_obs, d->f_ref);
    ls_protect_check_observer(&d->prot, e_obs, d->demod.valid, d->obs.omega);
    return d->prot.fault != LS_FAULT_NONE;
}

/* Position reference and control at the estimate -> force -> q-current reference (A); the
 * reference's position through *x_ref. */
static inline LS_REAL ls_drive_path_force_(ls_drive *d, ls_pos pos, LS_REAL omega, ls_pos *x_ref)
{
    LS_REAL v_ff, a_ff, x_err, f, i_q_ref;
    ls_traj_step(&d->traj, x_ref, &v_ff, &a_ff);
    x_err = ls_pos_diff(*x_ref, pos) * d->inv_kx;
    a_ff += d->ff_load_k * d->obs.f_load; /* load_ff: the observer's load-force estimate, */
    d->pos.speed.integ *= d->integ_keep;   /* which is then the integral action */
    f = ls_posctrl_step_finite(&d->pos, x_err, omega * d->inv_kx, v_ff, a_ff);
    i_q_ref = ls_clamp(f * d->inv_kf, -d->cfg.i_max, d->cfg.i_max);
    d->f_ref = i_q_ref * d->cfg.force_constant;
    return i_q_ref;
}

/* What follows the residual model's measured resistance scale k_r (ls_dtres_adapt): the
 * demodulator's tables' resistance correction (ls_demod.h) and the current PI's zero on the
 * winding's R/L pole (ki = R_s w_c: linsense.tune.design.current_gains). */
static inline void ls_drive_path_follow_r_(ls_drive *d)
{
    d->demod.k_r = d->dtres.k_r;
    d->cur.ki_ts = d->cur.cfg.ki * d->cur.ts * d->dtres.k_r;
}

/* The current the dead-time residual drove over the period that has just ended (A, alpha-beta;
 * ls_dtres.h): the modulator's forward model of the period with the inductance model at the angle
 * (c, s), its voltage error through the R-L model, and the model's inductance and resistance scales
 * measured from the period's current change (dtres.cfg.adapt; the resistance's passed to the
 * demodulator's tables); or the interpolation (dtres.cfg.forward false).
 * Call before ls_mod_step. */
static inline void ls_drive_path_residual_(ls_drive *d, const ls_meas *meas, LS_REAL c, LS_REAL s, LS_REAL i_res[2])
{
    LS_REAL v_err[2];
    if (d->dtres.cfg.forward) {
        LS_REAL g[6], i_end[3], i_drop[3];
        ls_dtres_phase_g(&d->dtres, c, s, g);
        if (ls_mod_residual(&d->mod, meas->i_abc, meas->v_dc, g, d->dtres.cfg.r_s * d->dtres.k_r, v_err, i_end,
                            i_drop) &&
            d->dtres.cfg.adapt) {
            /* (k_r held while the angle is not the motor's: the start-up, the table off) */
            ls_dtres_adapt(&d->dtres, d->mod.i_prev, meas->i_abc, i_end, i_drop,
                           !d->starting && d->mode != LS_MODE_SENSORLESS_NOLUT);
            if (d->dtres.n_solve == 0u) { /* (k_r solved for) */
                ls_drive_path_follow_r_(d);
            }
        }
    } else {
        (void)ls_mod_residual_interp(&d->mod, meas->i_abc, meas->v_dc, d->dtres.k_rip, v_err);
    }
    ls_dtres_step(&d->dtres, v_err, c, s, i_res);
}

/* The fundamental of the measured currents (sep: *if_a, *if_b), and their HF part (bpf: *ihf_a,
 * *ihf_b) less what the dead-time residual drove (ls_dtres.h; the residual in the frame (c, s) of
 * the injection), in A, alpha-beta. */
static inline void ls_drive_path_hf_(ls_drive *d, const ls_meas *meas, LS_REAL i_a, LS_REAL i_b, LS_REAL c,
                                     LS_REAL s, LS_REAL *if_a, LS_REAL *if_b, LS_REAL *ihf_a, LS_REAL *ihf_b)
{
    if (d->cfg.sep.type == LS_BIQUAD_NOTCH) {
        *if_a = ls_biquad_step_notch(&d->sep[0], i_a);
        *if_b = ls_biquad_step_notch(&d->sep[1], i_b);
    } else {
        *if_a = ls_biquad_step(&d->sep[0], i_a);
        *if_b = ls_biquad_step(&d->sep[1], i_b);
    }
    if (d->cfg.hf_dtres) { /* (bpf is then the band-pass: not with the square wave, ls_drive_init) */
        LS_REAL i_res[2];
        ls_drive_path_residual_(d, meas, c, s, i_res);
        *ihf_a = ls_biquad_step_bp(&d->bpf[0], i_a - i_res[0]);
        *ihf_b = ls_biquad_step_bp(&d->bpf[1], i_b - i_res[1]);
    } else {
        *ihf_a = ls_biquad_step(&d->bpf[0], i_a);
        *ihf_b = ls_biquad_step(&d->bpf[1], i_b);
    }
}

/* Current control in the frame (c, s) of the fundamental currents (if_a, if_b): the currents
 * (*i_d, *i_q, A) and the voltages (*v_d, *v_q, V) there, and the fundamental voltage in
 * alpha-beta (*v_a, *v_b, V) at the angle advanced over the computation delay (small-angle
 * rotation by delay_ts omega), to which the step adds its injection. */
static inline void ls_drive_path_current_(ls_drive *d, LS_REAL v_dc, LS_REAL c, LS_REAL s, LS_REAL if_a,
                                          LS_REAL if_b, LS_REAL i_q_ref, LS_REAL omega, LS_REAL *i_d,
                                          LS_REAL *i_q, LS_REAL *v_d, LS_REAL *v_q, LS_REAL *v_a, LS_REAL *v_b)
{
    const LS_REAL v_lim = v_dc * (LS_R(1.0) / LS_SQRT3) - d->v_hf_max;
    const LS_REAL dlt = d->delay_ts * omega;
    const LS_REAL c_adv = c - s * dlt, s_adv = s + c * dlt;
    LS_REAL vd, vq;
    *i_d = c * if_a + s * if_b;
    *i_q = -s * if_a + c * if_b;
    ls_current_step_finite(&d->cur, *i_d, *i_q, d->i_d_ref, i_q_ref, omega, v_lim, &vd, &vq);
    *v_d = vd;
    *v_q = vq;
    *v_a = c_adv * vd - s_adv * vq;
    *v_b = s_adv * vd + c_adv * vq;
}

/* The injection's next sample added to the fundamental voltage (*v_a, *v_b, V): on the d-axis of the
 * frame (c, s), with the elliptical injection's component on its q-axis, or the rotating vector in
 * the stationary frame. Returns the d-axis sample v_hf (V). */
static inline LS_REAL ls_drive_path_inject_(ls_drive *d, LS_REAL c, LS_REAL s, LS_REAL *v_a, LS_REAL *v_b)
{
    const LS_REAL v_hf = ls_inject_step(&d->inj);
    if (d->cfg.inject.shape != LS_INJ_ROTATING) {
        *v_a += v_hf * c - d->inj.v_q * s;
        *v_b += v_hf * s + d->inj.v_q * c;
    } else {
        *v_a += v_hf;
        *v_b += d->inj.v_q;
    }
    return v_hf;
}

#endif /* LINSENSE_LS_DRIVE_PATH_H */
