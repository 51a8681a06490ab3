/* LS_MODE_SENSORLESS_LUT and LS_MODE_SENSORLESS_NOLUT with the square wave at fs/2 (ls_drive.c,
 * "The step table"): what the square wave needs against the dead time costs the other shapes
 * nothing here (docs/firmware.md, "Injection shapes"; docs/theory.md, "The dead time and the square
 * wave"):
 *   - the dead-time compensation with each leg's two edges apart by the PWM ripple
 *     (ls_mod_step_ripple_finite, cfg.mod.l_ripple), which knows when a small phase current loses
 *     the dead time at one edge only, in step with the square wave;
 *   - the d-current schedule: i_d_near instead of i_d_inj near the six positions where the
 *     current reference's vector (i_d_inj, i_q_ref) is normal to a phase axis (cfg.near_in,
 *     cfg.near_out, with hysteresis; at no load the estimated d-axis);
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

    /* the d-current schedule, keyed to the current reference's vector (i_d_inj, i_q_ref) in the
     * estimated frame, at the angle phi = theta_est + atan2(i_q_ref, i_d_inj): a phase's current
     * crosses zero where its axis is normal to that vector (phi = pi/6 + k pi/3), at no load where
     * the d-axis is, under a force turned by atan(i_q / i_d). |cos(3 phi)| = |sin(3 e)|, e the
     * distance to the nearest of those positions, with hysteresis; without trigonometry, squared:
     * u = |i| cos(phi) (the unit vector (c, s) rotated by the current's), |i|^3 cos(3 phi) =
     * u (4 u^2 - 3 |i|^2). Decided on i_d_inj, the schedule's far current, not on the reference
     * it sets: the angle then does not jump when the schedule switches (docs/tuning.md, "Why the
     * rotating vector and the square wave cycle"). A zero vector (|i|^6 not above 0, i_d_inj = 0
     * without a force: no design gives a schedule there) keeps the last decision. */
    if (d->near_c3_out > LS_R(0.0)) {
        const LS_REAL i_d = cfg->i_d_inj, i_q = io.i_q_ref;
        const LS_REAL n2 = i_d * i_d + i_q * i_q;
        const LS_REAL n6 = n2 * n2 * n2;
        const LS_REAL u = io.c * i_d - io.s * i_q;
        LS_REAL p2 = u * (LS_R(4.0) * u * u - LS_R(3.0) * n2);
        p2 *= p2;
        if (p2 < d->near_c3_in * d->near_c3_in * n6) {
            ls_drive_set_i_d_(d, cfg->i_d_near);
        } else if (p2 > d->near_c3_out * d->near_c3_out * n6) {
            ls_drive_set_i_d_(d, cfg->i_d_inj);
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
