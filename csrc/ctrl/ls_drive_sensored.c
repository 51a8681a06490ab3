/* LS_MODE_SENSORED, every injection shape (ls_drive.c, "The step table"): the encoder closes every
 * loop. One frame, the encoder's: the current control, the HF injection and the demodulation all
 * work at the encoder's angle (one sine and cosine per step; ls_drive_enc_open_).
 *
 * With the injection (inject_sensored) the HF estimate beside the encoder is the encoder's position
 * plus the error demodulated there, with the table,
 *     theta_hf = theta_enc + err(theta_enc),
 * where a sensorless observer would settle (err(theta_est) = 0; to first order in its distance
 * from the encoder, the demodulator's gain being normalised to 1 rad/rad, demod.gain): its bias and
 * its ripple after the demodulator's low-pass, without an observer's lag. Without inject_sensored
 * the same step runs: the injection was reset to zero amplitude at the mode change, so v_hf = 0,
 * the demodulator finds no level and the estimate beside the encoder is the encoder's position. */
#include "ls_drive_internal.h"

void ls_drive_sensored_step_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd)
{
    ls_drive_io io;
    if (!ls_drive_enc_open_(d, meas, cmd, &io)) {
        return;
    }
    /* the fundamental, and the HF current less what the dead-time residual drove (ls_dtres.h); the
     * band-pass, or the square wave's first difference */
    ls_drive_hf_(d, meas, &io, LS_DRIVE_RES_ADAPT);
    {
        /* with the table, at the encoder's angle */
        const LS_REAL err = ls_drive_demod_(d, &io, d->enc.pos.theta);
        /* the HF estimate beside the encoder (commissioning; unchecked): the encoder's position plus
         * the demodulated error there, from the injection's full amplitude on */
        d->obs.pos = ls_pos_add(d->enc.pos, d->inj.amp >= d->cfg.inject.amplitude ? err : LS_R(0.0));
        d->obs.omega = d->enc.omega;
    }
    io.pos = d->enc.pos;
    io.omega = d->enc.omega;

    /* position reference and control -> force -> current reference */
    ls_drive_enc_force_(d, &io, false, LS_R(0.0));
    /* current control in the encoder's frame, plus the HF injection on the encoder's d-axis
     * (rotating: in the stationary frame) */
    ls_drive_current_(d, meas->v_dc, &io);
    ls_drive_inject_(d, &io);
    ls_drive_close_(d, meas, cmd, &io, false);
}
