/* LS_MODE_SENSORLESS_LUT and LS_MODE_SENSORLESS_NOLUT with the square wave at fs/2 (ls_drive.c,
 * "The step table"): what the square wave needs against the dead time costs the other shapes
 * nothing here (docs/firmware.md, "Injection shapes"; docs/theory.md, "The dead time and the square
 * wave"):
 *   - the dead-time compensation with each leg's two edges apart by the PWM ripple
 *     (ls_mod_step_ripple_finite, cfg.mod.l_ripple), which knows when a small phase current loses
 *     the dead time at one edge only, in step with the square wave;
 *   - the d-current schedule: i_d_near instead of i_d_inj near the six positions where the
 *     estimated d-axis is normal to a phase axis (cfg.near_in, cfg.near_out, with hysteresis);
 *   - no residual model, encoder, calibration or elliptical branches (sensorless only).
 * The square wave in the sensored and calibration modes runs those modes' steps
 * (ls_drive_sensored.c, ls_drive_calibration.c), without the two measures above. */
#include "ls_drive_internal.h"

void ls_drive_square_step_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd)
{
    const ls_drive_cfg *cfg = &d->cfg;
    ls_drive_io io;
    LS_REAL err;
    if (!ls_drive_est_open_(d, meas, cmd, &io)) {
        return;
    }
    /* the fundamental (low-pass, zeros at fs/2) and the current's change over the period */
    io.if_a = ls_biquad_step(&d->sep[0], io.i_a);
    io.if_b = ls_biquad_step(&d->sep[1], io.i_b);
    io.ihf_a = ls_biquad_step(&d->bpf[0], io.i_a);
    io.ihf_b = ls_biquad_step(&d->bpf[1], io.i_b);

    /* product demodulation with the table, and observer (the error counts once the injection is up) */
    err = ls_drive_demod_(d, &io, d->obs.pos.theta);
    if (ls_drive_observe_(d, cmd, &io, err)) {
        return;
    }

    /* position reference and control -> force -> current reference */
    ls_drive_force_(d, &io);

    /* the d-current schedule: |cos(3 theta_est)| = |sin(3 e)|, e the distance to the nearest
     * position where the d-axis is normal to a phase axis (pi/6 + k pi/3), with hysteresis */
    if (d->near_c3_out > LS_R(0.0)) {
        const LS_REAL a3 = LS_FABS(io.c * (LS_R(4.0) * io.c * io.c - LS_R(3.0)));
        if (a3 < d->near_c3_in) {
            d->i_d_ref = cfg->i_d_near;
        } else if (a3 > d->near_c3_out) {
            d->i_d_ref = cfg->i_d_inj;
        }
    }

    /* current control in the estimated frame, plus the square wave on the estimated d-axis */
    ls_drive_current_(d, meas->v_dc, &io);
    io.v_hf = ls_inject_step(&d->inj);
    io.v_a += io.v_hf * io.c;
    io.v_b += io.v_hf * io.s;
    (void)ls_mod_step_ripple_finite(&d->mod, io.v_a, io.v_b, meas->v_dc, meas->i_abc, io.duty);
    ls_drive_cmd_out_(cmd, d, &io, false);
}
