/* LS_MODE_OFF (ls_drive.c, "The step table"), and the outputs-off helpers every step calls. */
#include <string.h>

#include "ls_drive_internal.h"

void ls_drive_disable_(ls_drive *d, ls_cmd *cmd, uint32_t fault)
{
    memset(cmd, 0, sizeof *cmd);
    cmd->mode = d->starting ? LS_MODE_STARTUP : d->mode;
    cmd->fault = fault;
    ls_current_reset(&d->cur);
    ls_posctrl_reset(&d->pos);
    d->f_ref = LS_R(0.0);
}

void ls_drive_disable_report_(ls_drive *d, ls_cmd *cmd, uint32_t fault)
{
    ls_drive_disable_(d, cmd, fault);
    cmd->pos_est = d->obs.pos;
    cmd->pos_fb = d->obs.pos;
    cmd->pos_ref = d->traj.target;
}

/* Outputs off, estimators idle: the protection still checks the measurements (and reports). */
void ls_drive_off_step_(ls_drive *d, const ls_meas *meas, ls_cmd *cmd)
{
    ls_drive_io io;
    if (ls_drive_open_(d, meas, cmd, &io)) {
        ls_drive_disable_report_(d, cmd, LS_FAULT_NONE);
    }
}
