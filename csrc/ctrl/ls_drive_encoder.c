/* ls_drive_step in the encoder modes, LS_MODE_SENSORED and LS_MODE_CALIBRATION (ls_drive.h), in a
 * translation unit of their own: the encoder's tracking loop and the calibration sequence cost the
 * sensorless steps nothing, and the encoder modes pay no sensorless branch (docs/firmware.md,
 * "Instructions per step in the encoder modes").
 *
 * One frame, the encoder's: the current control, the HF injection and the demodulation all work at
 * the encoder's angle (one sine and cosine per step).
 *   - LS_MODE_CALIBRATION: the sequence of paper Fig. 9 (theta_err = 0 by construction); the
 *     demodulator turns the currents by psi_cal through its cosine and sine, which the adaptation
 *     turns by its small steps (exact again at every averaging window) instead of evaluating them.
 *   - LS_MODE_SENSORED with the injection (inject_sensored): the HF estimate beside the encoder is
 *     the encoder's position plus the error demodulated there, with the table,
 *       theta_hf = theta_enc + err(theta_enc),
 *     where a sensorless observer would settle (err(theta_est) = 0; to first order in its distance
 *     from the encoder, the demodulator's gain being normalised to 1 rad/rad, demod.gain): its
 *     bias and its ripple after the demodulator's low-pass, without an observer's lag.
 * ls_drive.c dispatches here (d->path). */
#include <math.h>
#include <string.h>

#include "linsense/ls_drive.h"
#include "linsense/ls_math.h"
#include "ls_drive_cmd.h"
#include "ls_drive_path.h"

#if defined(__GNUC__)
#define LS_DRIVE_NOINLINE __attribute__((noinline)) /* (out of the sensored mode's step) */
#else
#define LS_DRIVE_NOINLINE
#endif

/* rad, the largest step of psi_cal turned without trigonometry (ls_drive.h cal_c): dp^3/6 < 2e-7 */
#define LS_CAL_TURN_MAX LS_R(0.01)

/* The encoder's sample plausible: a count change from the last sample of at most enc_jump_max
 * (int64_t: no overflow whatever the counts; |jump| <= max as one unsigned comparison), except at
 * the first step of the mode (d->align: there is no last sample), and its position pe within
 * +-LS_POS_PERIOD_MAX periods (beyond only with enc_counts < 128). */
static bool enc_plausible(ls_drive *d, int32_t count, ls_pos pe)
{
    const int64_t jump = (int64_t)count - (int64_t)d->enc_prev;
    const bool ok = d->align || (uint64_t)(jump + d->enc_jump_max) <= (uint64_t)(2 * d->enc_jump_max);
    d->enc_prev = count;
    return ok && pe.period <= LS_POS_PERIOD_MAX && pe.period >= -LS_POS_PERIOD_MAX;
}

static ls_pos enc_pos(int32_t count, int32_t per_period, LS_REAL k_count)
{
    ls_pos p;
    int32_t q = count / per_period;
    int32_t r = count % per_period;
    if (r < 0) {
        r += per_period;
        q -= 1;
    }
    p.period = q;
    p.theta = (LS_REAL)r * k_count;
    return p;
}

/* Calibration sequence (paper Fig. 9). The HF injection and the demodulator work on the encoder
 * angle, so theta_err = 0 exactly, and the integrator drives the demodulated error to zero:
 * d psi_cal/dt = k_int * ratio, ratio ~ Psi_true - psi_cal. That is the condition under which the
 * sensorless observer's equilibrium error against the encoder vanishes, reached at the rate k_int
 * whatever the local saliency (adapting on the observer's own error instead would scale the loop
 * gain by L_q/(L_q - L_d), up to 13 for ecce2010, and let the observer slip). */
LS_DRIVE_NOINLINE static void calibration_step(ls_drive *d)
{
    const ls_cal_cfg *c = &d->cfg.cal;
    ls_pos target;
    switch (d->cal_phase) {
    case LS_CAL_MOVE:
        if (d->cal_timer == 0u) {
            target.period = c->period;
            target.theta = LS_TWO_PI * (LS_REAL)d->cal_index / (LS_REAL)c->points;
            ls_traj_move(&d->traj, target);
        }
        d->cal_timer++;
        if (!d->traj.active) {
            d->cal_phase = LS_CAL_SETTLE;
            d->cal_amp = c->dither_amp; /* the dither, while settling and adapting */
            d->cal_timer = 0u;
        }
        break;
    case LS_CAL_SETTLE:
        if (++d->cal_timer >= d->cal_n_settle) {
            d->cal_phase = LS_CAL_ADAPT;
            d->cal_timer = 0u;
            ls_drive_cal_window_reset_(d);
        }
        break;
    case LS_CAL_ADAPT:
        if (d->demod.valid) {
            const LS_REAL psi = ls_clamp(d->psi_cal + c->k_int * d->demod.ratio * d->ts, -LS_PI / LS_R(4.0),
                                         LS_PI / LS_R(4.0));
            const LS_REAL dp = psi - d->psi_cal;
            d->psi_cal = psi;
            if (LS_FABS(dp) <= LS_CAL_TURN_MAX) {
                /* its cosine and sine turned by dp (cos dp = 1 - dp^2/2 and sin dp = dp to
                 * dp^4/24 and dp^3/6 < 2e-7 dp: the demodulator's rotation without trigonometry) */
                const LS_REAL cd = LS_R(1.0) - LS_R(0.5) * dp * dp;
                const LS_REAL c0 = d->cal_c, s0 = d->cal_s;
                d->cal_c = c0 * cd - s0 * dp;
                d->cal_s = s0 * cd + c0 * dp;
            } else {
                ls_drive_cal_cs_(d);
            }
        }
        /* windows of t_hold: a point is accepted when the mean of the demodulated error (the
         * observer's error against the encoder) over a whole window is below tol; the table gets the
         * window's mean angle (the HF currents and the dead time make both ripple) */
        if (!d->demod.valid) { /* a window counts whole and valid only */
            ls_drive_cal_window_reset_(d);
            ls_drive_cal_cs_(d); /* (rare: its cosine and sine exact again, as at a window's end) */
        } else {
            d->cal_sum_err += d->demod.err;
            d->cal_sum_psi += d->psi_cal;
            d->cal_hold++;
        }
        d->cal_timer++;
        if (d->cal_hold >= d->cal_n_hold) {
            const LS_REAL inv_n = LS_R(1.0) / (LS_REAL)d->cal_hold;
            if (LS_FABS(d->cal_sum_err * inv_n) < c->tol) {
                c->table[d->cal_index] = (float)(d->cal_sum_psi * inv_n);
                d->cal_index++;
                d->cal_timer = 0u;
                d->cal_phase = d->cal_index >= c->points ? LS_CAL_DONE : LS_CAL_MOVE;
                d->cal_amp = LS_R(0.0);
            }
            ls_drive_cal_window_reset_(d);
            ls_drive_cal_cs_(d); /* exact again: the turns' rounding does not add up */
        }
        if (d->cal_phase == LS_CAL_ADAPT && d->cal_timer >= d->cal_n_max) {
            ls_protect_trip(&d->prot, LS_FAULT_OBSERVER);
        }
        break;
    case LS_CAL_DONE:
    default:
        break;
    }
}

void ls_drive_enc_step_(ls_drive *d, const ls_meas *meas, ls_cmd *cmd)
{
    const ls_drive_cfg *cfg = &d->cfg;
    const bool calibrating = d->mode == LS_MODE_CALIBRATION;
    LS_REAL i_a, i_b, ihf_a, ihf_b, if_a, if_b, c_fb, s_fb, v_hf, v_d, v_q, v_a, v_b;
    LS_REAL i_d, i_q, i_q_ref, omega, duty[3];
    ls_pos x_ref, pos, pe;
    uint32_t fault;

    if (!meas->enc_valid) {
        ls_protect_trip(&d->prot, LS_FAULT_ENCODER);
    }
    fault = ls_protect_check_power(&d->prot, meas->i_abc, meas->v_dc); /* (and the latched faults) */
    if (fault != LS_FAULT_NONE) {
        ls_drive_disable_report_(d, cmd, fault);
        return;
    }
    i_a = meas->i_abc[0];
    i_b = (meas->i_abc[1] - meas->i_abc[2]) * (LS_R(1.0) / LS_SQRT3);

    /* the encoder's tracking loop; after a mode change every estimate and the reference start at
     * the encoder's position */
    pe = enc_pos(meas->enc_count, cfg->enc_counts, d->enc_k);
    if (!enc_plausible(d, meas->enc_count, pe)) {
        ls_protect_trip(&d->prot, LS_FAULT_ENCODER);
        ls_drive_disable_report_(d, cmd, d->prot.fault);
        return;
    }
    if (d->align) {
        /* load_ff: the sensorless modes held the load in the HF observer's estimate (the speed PI's
         * integrator at 0); the encoder modes hold it in the integrator */
        if (cfg->load_ff && cfg->pos.type == LS_POSCTRL_P) {
            d->pos.speed.integ = ls_clamp(d->obs.f_load, cfg->pos.speed.out_min, cfg->pos.speed.out_max);
        }
        ls_observer_reset(&d->enc, pe);
        ls_observer_reset(&d->obs, pe);
        ls_traj_reset(&d->traj, pe);
        ls_drive_path_pending_(d); /* (the move or step commanded with the mode change) */
    }
    ls_observer_step_finite(&d->enc, ls_pos_diff(pe, d->enc.pos), d->f_ref);
    ls_sincos(d->enc.pos.theta, &c_fb, &s_fb);

    /* the fundamental, and the HF current less what the dead-time residual drove (ls_dtres.h); the
     * band-pass, or the square wave's first difference */
    /* (LS_MODE_SENSORED without inject_sensored runs the same step: its injection was reset to zero
     * amplitude at the mode change, so v_hf = 0, the demodulator finds no level and the estimate
     * beside the encoder is the encoder's position) */
    ls_drive_path_hf_(d, meas, i_a, i_b, c_fb, s_fb, &if_a, &if_b, &ihf_a, &ihf_b);
    {
        /* with the table in sensored mode; while calibrating, at psi_cal (by its cosine and sine) */
        LS_REAL psi, c_psi, s_psi, err;
        if (calibrating) {
            psi = d->psi_cal;
            c_psi = d->cal_c;
            s_psi = d->cal_s;
        } else {
            psi = ls_demod_comp_norm(&d->demod, d->enc.pos.theta, LS_R(0.0), &c_psi, &s_psi);
        }
        err = ls_demod_step_psi(&d->demod, ihf_a, ihf_b, d->enc.pos.theta, c_fb, s_fb, d->inj.c, d->inj.s, psi,
                                c_psi, s_psi);
        if (calibrating) {
            /* the HF axis is the encoder's: theta_err = 0 (the position is normalised already) */
            d->obs.pos = d->enc.pos; /* (its speed and load were cleared at the alignment) */
            calibration_step(d);
            if (d->prot.fault != LS_FAULT_NONE) {
                ls_drive_disable_report_(d, cmd, d->prot.fault);
                return;
            }
        } else {
            /* the HF estimate beside the encoder (commissioning; unchecked): the encoder's position
             * plus the demodulated error there, from the injection's full amplitude on */
            d->obs.pos = ls_pos_add(d->enc.pos, d->inj.amp >= cfg->inject.amplitude ? err : LS_R(0.0));
            d->obs.omega = d->enc.omega;
        }
    }

    pos = d->enc.pos;
    omega = d->enc.omega;

    /* position reference and control -> force -> current reference, with the calibration's dither */
    {
        LS_REAL v_ff, a_ff, x_err, f;
        ls_traj_step(&d->traj, &x_ref, &v_ff, &a_ff);
        x_err = ls_pos_diff(x_ref, pos) * d->inv_kx;
        f = ls_posctrl_step_finite(&d->pos, x_err, omega * d->inv_kx, v_ff, a_ff);
        i_q_ref = f * d->inv_kf;
        /* the HF observer slaved to the encoder carries the integrator's load too: a change to a
         * sensorless mode with load_ff starts from it (ls_drive_path_force_) */
        d->obs.f_load = ls_clamp(d->pos.speed.integ, -cfg->obs.force_max, cfg->obs.force_max);
        if (calibrating) { /* the dither, one step on (the sine at the phase's nearest of 256 points) */
            d->cal_acc += d->cal_inc;
            i_q_ref += d->cal_amp * (LS_REAL)ls_sin_tab[(d->cal_acc + 0x800000u) >> 24]; /* (mod 2^32) */
        }
        i_q_ref = ls_clamp(i_q_ref, -cfg->i_max, cfg->i_max);
        d->f_ref = i_q_ref * cfg->force_constant;
    }

    /* current control in the encoder's frame */
    ls_drive_path_current_(d, meas->v_dc, c_fb, s_fb, if_a, if_b, i_q_ref, omega, &i_d, &i_q, &v_d, &v_q, &v_a,
                           &v_b);
    /* plus the HF injection on the encoder's d-axis (rotating: in the stationary frame) */
    v_hf = ls_drive_path_inject_(d, c_fb, s_fb, &v_a, &v_b);
    (void)ls_mod_step_finite(&d->mod, v_a, v_b, meas->v_dc, meas->i_abc, duty);
    ls_drive_cmd_out_(cmd, d, duty, pos, x_ref, omega, i_d, i_q, i_q_ref, v_d, v_q, v_hf,
                      calibrating && d->cal_phase == LS_CAL_DONE);
}

