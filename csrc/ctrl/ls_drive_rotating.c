/* LS_MODE_SENSORLESS_LUT and LS_MODE_SENSORLESS_NOLUT with the rotating injection whose sep is the
 * notch at bpf's f0 and q (ls_drive.c, "The step table"). The rotating vector's negative-sequence
 * demodulator costs about 40 instructions more than the pulsating product, and this step takes them
 * back where the shape allows, without touching the other shapes' code (docs/firmware.md,
 * "Injection shapes"):
 *   - no band-pass: the notch at the band-pass's f0 and q is 1 - band-pass (cookbook designs), so
 *     the band-passed current is the current less its fundamental, and the dead-time residual's
 *     current is taken out of it unfiltered;
 *   - no encoder, calibration or elliptical branches (sensorless only). */
#include "ls_drive_internal.h"

void ls_drive_rotating_step_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd)
{
    ls_drive_io io;
    LS_REAL err;
    if (!ls_drive_est_open_(d, meas, cmd, &io)) {
        return;
    }
    /* the fundamental (notch), and the HF current as its complement less the residual's */
    io.if_a = ls_biquad_step(&d->sep[0], io.i_a);
    io.if_b = ls_biquad_step(&d->sep[1], io.i_b);
    io.ihf_a = io.i_a - io.if_a;
    io.ihf_b = io.i_b - io.if_b;
    if (d->cfg.hf_dtres) {
        LS_REAL i_res[2];
        ls_drive_residual_(d, meas, &io, i_res, LS_DRIVE_RES_ADAPT);
        io.ihf_a -= i_res[0];
        io.ihf_b -= i_res[1];
    }

    /* negative-sequence demodulation and observer (the error counts once the injection is up) */
    err = ls_drive_demod_(d, &io, d->obs.pos.theta);
    if (ls_drive_observe_(d, cmd, &io, err)) {
        return;
    }

    /* position reference and control -> force -> current reference */
    ls_drive_force_(d, &io);
    /* current control in the estimated frame, plus the rotating vector in the stationary frame */
    ls_drive_current_(d, meas->v_dc, &io);
    io.v_hf = ls_inject_step(&d->inj);
    io.v_a += io.v_hf;
    io.v_b += d->inj.v_q;
    ls_drive_close_(d, meas, cmd, &io, false);
}
