/* The outputs-off helpers every step calls (ls_drive_internal.h), and in a build for size (-Os) the
 * one compiled copy of the pieces every step is made of (ls_drive_parts.h; ls_drive_internal.h,
 * "The pieces"). They call nothing of the drive's above them. */
#include <string.h>

#include "ls_drive_internal.h"

/* --------------------------------------------------------------------------- outputs off */
void ls_drive_disable_(ls_drive *LS_RESTRICT d, ls_cmd *LS_RESTRICT cmd, uint32_t fault)
{
    memset(cmd, 0, sizeof *cmd);
    cmd->mode = d->starting ? LS_MODE_STARTUP : d->mode;
    cmd->fault = fault;
    ls_current_reset(&d->cur);
    ls_posctrl_reset(&d->pos);
    d->f_ref = LS_R(0.0);
    d->w_ref = LS_R(0.0);
}

void ls_drive_disable_report_(ls_drive *LS_RESTRICT d, ls_cmd *LS_RESTRICT cmd, uint32_t fault)
{
    ls_drive_disable_(d, cmd, fault);
    cmd->pos_est = d->obs.pos;
    cmd->pos_fb = d->obs.pos;
    cmd->pos_ref = d->traj.target;
}

#if defined(LS_DRIVE_SHARED_PARTS) /* (-Os, or asked for; else every step has them inline: ls_drive_internal.h) */
#include "ls_drive_parts.h"
#endif
