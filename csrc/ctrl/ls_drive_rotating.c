/* ls_drive_step in the sensorless modes with the rotating injection (ls_drive.h), in a translation
 * unit of its own: the rotating vector's negative-sequence demodulator costs about 40 instructions
 * more than the pulsating product, and this path takes them back where the shape allows,
 * without touching the other shapes' code (docs/firmware.md, "Injection shapes"):
 *   - no band-pass: the notch at the band-pass's f0 and q is 1 - band-pass (cookbook designs), so
 *     the band-passed current is the current less its fundamental, and the dead-time residual's
 *     current is taken out of it unfiltered (required: sep the notch at bpf's f0 and q);
 *   - no encoder, calibration or elliptical branches (sensorless only).
 * ls_drive.c dispatches here (d->path) and keeps the sensorless modes' other shapes. */
#include <math.h>
#include <string.h>

#include "linsense/ls_drive.h"
#include "linsense/ls_math.h"
#include "ls_drive_cmd.h"
#include "ls_drive_path.h"

void ls_drive_rot_step_(ls_drive *d, const ls_meas *meas, ls_cmd *cmd)
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

    /* the fundamental (notch), and the HF current as its complement less the residual's */
    if_a = ls_biquad_step(&d->sep[0], i_a);
    if_b = ls_biquad_step(&d->sep[1], i_b);
    ihf_a = i_a - if_a;
    ihf_b = i_b - if_b;
    if (cfg->hf_dtres) {
        LS_REAL i_res[2];
        ls_drive_path_residual_(d, meas, c_est, s_est, i_res);
        ihf_a -= i_res[0];
        ihf_b -= i_res[1];
    }

    /* negative-sequence demodulation and observer (the error counts once the injection is up) */
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

    /* current control in the estimated frame */
    ls_drive_path_current_(d, meas->v_dc, c_est, s_est, if_a, if_b, i_q_ref, omega, &i_d, &i_q, &v_d, &v_q, &v_a,
                           &v_b);
    /* plus the rotating vector in the stationary frame */
    v_hf = ls_inject_step(&d->inj);
    v_a += v_hf;
    v_b += d->inj.v_q;
    (void)ls_mod_step_finite(&d->mod, v_a, v_b, meas->v_dc, meas->i_abc, duty);
    ls_drive_cmd_out_(cmd, d, duty, pos, x_ref, omega, i_d, i_q, i_q_ref, v_d, v_q, v_hf, false);
}
