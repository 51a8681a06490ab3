/* LS_MODE_CALIBRATION, every injection shape (ls_drive.c, "The step table"): the encoder closes the
 * position loop; at each of cal.points positions of one electrical period (move, settle, adapt) the
 * HF injection and the demodulator run on the encoder angle and an integrator adjusts the
 * compensation angle until the demodulated error is zero, i.e. until the sensorless observer's
 * equilibrium agrees with the encoder; the result is written to cal.table (paper Fig. 9, "measured"
 * LUT).
 *
 * One frame, the encoder's (ls_drive_enc_open_, as LS_MODE_SENSORED's step); the demodulator turns
 * the currents by psi_cal through its cosine and sine, which the adaptation turns by its small
 * steps (exact again at every averaging window) instead of evaluating them; the q-current gets the
 * dither (cal.dither_amp) while settling and adapting. */
#include "ls_drive_internal.h"

/* rad, the largest step of psi_cal turned without trigonometry (ls_drive.h cal_c): dp^3/6 < 2e-7 */
#define LS_CAL_TURN_MAX LS_R(0.01)

/* Calibration sequence (paper Fig. 9). The HF injection and the demodulator work on the encoder
 * angle, so theta_err = 0 exactly, and the integrator drives the demodulated error to zero:
 * d psi_cal/dt = k_int * ratio, ratio ~ Psi_true - psi_cal. That is the condition under which the
 * sensorless observer's equilibrium error against the encoder vanishes, reached at the rate k_int
 * whatever the local saliency (adapting on the observer's own error instead would scale the loop
 * gain by L_q/(L_q - L_d), up to 13 for ecce2010, and let the observer slip). */
static void sequence_step(ls_drive *LS_RESTRICT d)
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

void ls_drive_calibration_step_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd)
{
    ls_drive_io io;
    if (!ls_drive_enc_open_(d, meas, cmd, &io)) {
        return;
    }
    /* the fundamental, and the HF current less what the dead-time residual drove (ls_dtres.h); the
     * band-pass, or the square wave's first difference */
    ls_drive_hf_(d, meas, &io, LS_DRIVE_RES_ADAPT);
    /* demodulated at psi_cal (by its cosine and sine); the HF axis is the encoder's: theta_err = 0
     * (the position is normalised already) */
    (void)ls_demod_step_psi(&d->demod, io.ihf_a, io.ihf_b, d->enc.pos.theta, io.c, io.s, d->inj.c, d->inj.s,
                            d->psi_cal, d->cal_c, d->cal_s);
    d->obs.pos = d->enc.pos; /* (its speed and load were cleared at the alignment) */
    sequence_step(d);
    if (d->prot.fault != LS_FAULT_NONE) {
        ls_drive_disable_report_(d, cmd, d->prot.fault);
        return;
    }
    io.pos = d->enc.pos;
    io.omega = d->enc.omega;

    /* position reference and control -> force -> current reference, with the dither one step on
     * (the sine at the phase's nearest of 256 points) */
    d->cal_acc += d->cal_inc;
    ls_drive_enc_force_(d, &io, true, d->cal_amp * (LS_REAL)ls_sin_tab[(d->cal_acc + 0x800000u) >> 24]);
    /* current control in the encoder's frame, plus the HF injection on the encoder's d-axis
     * (rotating: in the stationary frame) */
    ls_drive_current_(d, meas->v_dc, &io);
    ls_drive_inject_(d, &io);
    ls_drive_close_(d, meas, cmd, &io, d->cal_phase == LS_CAL_DONE);
}
