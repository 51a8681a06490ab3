/* ls_drive_step in the sensorless modes with the square wave (ls_drive.h), in a translation unit
 * of its own, as the rotating vector's (ls_drive_rotating.c): what the square wave needs against
 * the dead time costs the other shapes nothing here (docs/firmware.md, "Injection shapes";
 * docs/theory.md, "The dead time and the square wave"):
 *   - the dead-time compensation with each leg's two edges apart by the PWM ripple
 *     (ls_mod_step_ripple_finite, cfg.mod.l_ripple), which knows when a small phase current loses
 *     the dead time at one edge only, in step with the square wave;
 *   - the d-current schedule: i_d_near instead of i_d_inj near the six positions where the
 *     estimated d-axis is normal to a phase axis (cfg.near_in, cfg.near_out, with hysteresis);
 *   - no residual model, encoder, calibration or elliptical branches (sensorless only).
 * ls_drive.c dispatches here (d->path); the square wave in the sensored and calibration modes
 * runs the encoder modes' step (ls_drive_encoder.c, without the two measures above). */
#include <math.h>
#include <string.h>

#include "linsense/ls_drive.h"
#include "linsense/ls_math.h"
#include "ls_drive_cmd.h"
#include "ls_drive_path.h"

void ls_drive_sq_step_(ls_drive *d, const ls_meas *meas, ls_cmd *cmd)
{
    const ls_drive_cfg *cfg = &d->cfg;
    LS_REAL i_a, i_b, ihf_a, ihf_b, if_a, if_b, c_est, s_est, v_hf, v_d, v_q, v_a, v_b;
    LS_REAL i_d, i_q, i_q_ref, omega, err, duty[3];
    ls_pos x_ref, pos;
    uint32_t fault = ls_protect_check_power(&d->prot, meas->i_abc, meas->v_dc);

    if (fault != LS_FAULT_NONE) {
        ls_drive_disable_report_(d, cmd, fault);
        return;
    }
    i_a = meas->i_abc[0];
    i_b = (meas->i_abc[1] - meas->i_abc[2]) * (LS_R(1.0) / LS_SQRT3);
    ls_drive_path_align_(d);
    ls_sincos(d->obs.pos.theta, &c_est, &s_est);

    /* the fundamental (low-pass, zeros at fs/2) and the current's change over the period */
    if_a = ls_biquad_step(&d->sep[0], i_a);
    if_b = ls_biquad_step(&d->sep[1], i_b);
    ihf_a = ls_biquad_step(&d->bpf[0], i_a);
    ihf_b = ls_biquad_step(&d->bpf[1], i_b);

    /* product demodulation with the table, and observer (the error counts once the injection is up) */
    err = ls_demod_step_cs_norm(&d->demod, ihf_a, ihf_b, d->obs.pos.theta, c_est, s_est, d->inj.c, d->inj.s,
                           LS_R(0.0));
    if (ls_drive_path_observe_(d, err)) {
        ls_drive_disable_report_(d, cmd, d->prot.fault);
        return;
    }
    pos = d->obs.pos;
    omega = d->obs.omega;

    /* position reference and control -> force -> current reference */
    i_q_ref = ls_drive_path_force_(d, pos, omega, &x_ref);

    /* the d-current schedule: |cos(3 theta_est)| = |sin(3 e)|, e the distance to the nearest
     * position where the d-axis is normal to a phase axis (pi/6 + k pi/3), with hysteresis */
    if (d->near_c3_out > LS_R(0.0)) {
        const LS_REAL a3 = LS_FABS(c_est * (LS_R(4.0) * c_est * c_est - LS_R(3.0)));
        if (a3 < d->near_c3_in) {
            d->i_d_ref = cfg->i_d_near;
        } else if (a3 > d->near_c3_out) {
            d->i_d_ref = cfg->i_d_inj;
        }
    }

    /* current control in the estimated frame */
    ls_drive_path_current_(d, meas->v_dc, c_est, s_est, if_a, if_b, i_q_ref, omega, &i_d, &i_q, &v_d, &v_q, &v_a,
                           &v_b);
    /* plus the square wave on the estimated d-axis */
    v_hf = ls_inject_step(&d->inj);
    v_a += v_hf * c_est;
    v_b += v_hf * s_est;
    (void)ls_mod_step_ripple_finite(&d->mod, v_a, v_b, meas->v_dc, meas->i_abc, duty);
    ls_drive_cmd_out_(cmd, d, duty, pos, x_ref, omega, i_d, i_q, i_q_ref, v_d, v_q, v_hf, false);
}
