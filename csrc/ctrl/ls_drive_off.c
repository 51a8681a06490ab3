/* LS_MODE_OFF (ls_drive.c, "The step table"): outputs off, estimators idle; the protection still
 * checks the measurements (and the command reports them, the estimate and the reference). */
#include "ls_drive_internal.h"

void ls_drive_off_step_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd)
{
    ls_drive_io io;
    if (ls_drive_open_(d, meas, cmd, &io)) {
        ls_drive_disable_report_(d, cmd, LS_FAULT_NONE);
    }
}
