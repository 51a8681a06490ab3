/* LS_MODE_SENSORLESS_LUT and LS_MODE_SENSORLESS_NOLUT with the pulsating or elliptical injection
 * (the paper's), or a rotating one whose sep is not bpf's complement (ls_drive.c, "The step
 * table"): the HF estimate closes every loop.
 *
 * The fundamental separated by sep (notch or low-pass); the HF band-pass of the currents less what
 * the dead-time residual drove (hf_dtres, ls_dtres.h); the demodulator in the compensated frame
 * (the table in LS_MODE_SENSORLESS_LUT), its error advanced by the axis's turn over the HF path's
 * delay (hf_delay); the HF observer; position and current control at the estimate; the injection on
 * the estimated d-axis (rotating: in the stationary frame). */
#include "ls_drive_internal.h"

void ls_drive_sensorless_step_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd)
{
    ls_drive_io io;
    if (!ls_drive_est_open_(d, meas, cmd, &io)) {
        return;
    }
    /* fundamental separation of the measured currents, and HF band-pass of the currents less what
     * the dead-time residual drove */
    ls_drive_hf_(d, meas, &io, LS_DRIVE_RES_ADAPT);

    /* HF demodulation and observer, on the axis the injection used */
    {
        /* (advanced by the axis's turn over the HF path's delay) */
        const LS_REAL err = ls_drive_demod_(d, &io, d->obs.pos.theta) +
                            d->cfg.hf_delay * d->obs.omega;
        if (ls_drive_observe_(d, cmd, &io, err)) {
            return;
        }
    }

    /* position reference and control -> force -> current reference */
    ls_drive_force_(d, &io);
    /* current control in the estimated frame, plus the HF injection on the estimated d-axis with the
     * optional quadrature component on q (rotating: the stationary-frame vector) */
    ls_drive_current_(d, meas->v_dc, &io);
    ls_drive_inject_(d, &io);
    ls_drive_close_(d, meas, cmd, &io, false);
}
