/* The command every one of ls_drive_step's paths writes (ls_drive.c, ls_drive_startup.c,
 * ls_drive_rotating.c, ls_drive_square.c, ls_drive_encoder.c): private to the library, static
 * inline so that each path keeps its own compiled copy. Every field exactly once; the drive's own
 * fields are read from d, the step's values are the arguments. */
#ifndef LINSENSE_LS_DRIVE_CMD_H
#define LINSENSE_LS_DRIVE_CMD_H

#include "linsense/ls_drive.h"

static inline void ls_drive_cmd_(ls_cmd *cmd, const ls_drive *d, const LS_REAL duty[3], ls_mode mode,
                                 ls_pos pos_fb, ls_pos pos_ref, LS_REAL v_fb, LS_REAL i_d, LS_REAL i_q,
                                 LS_REAL i_d_ref, LS_REAL i_q_ref, LS_REAL v_d, LS_REAL v_q, LS_REAL v_hf,
                                 uint32_t cal_index, bool cal_done, LS_REAL psi_cal)
{
    cmd->duty[0] = duty[0];
    cmd->duty[1] = duty[1];
    cmd->duty[2] = duty[2];
    cmd->enable = true;
    cmd->fault = d->prot.fault;
    cmd->mode = mode;
    cmd->pos_fb = pos_fb;
    cmd->pos_est = d->obs.pos;
    cmd->pos_ref = pos_ref;
    cmd->v_est = ls_observer_speed(&d->obs);
    cmd->v_fb = v_fb;
    cmd->f_load_est = d->obs.f_load;
    cmd->err_sig = d->demod.err;
    cmd->err_valid = d->demod.valid;
    cmd->hf_level = d->demod.level;
    cmd->psi_comp = d->demod.psi;
    cmd->i_dq[0] = i_d;
    cmd->i_dq[1] = i_q;
    cmd->i_dq_ref[0] = i_d_ref;
    cmd->i_dq_ref[1] = i_q_ref;
    cmd->v_dq[0] = v_d;
    cmd->v_dq[1] = v_q;
    cmd->v_hf = v_hf;
    cmd->cal_index = cal_index;
    cmd->cal_done = cal_done;
    cmd->psi_cal = psi_cal;
}

/* The step's end once its duties are written: nothing non-finite ever leaves a step (a non-finite
 * v_a or v_b makes every duty NaN, the zero-sequence offset being Inf - Inf; the positions are
 * finite by ls_pos_norm), so a non-finite duty trips LS_FAULT_NONFINITE and turns the outputs off;
 * else the command. */
static inline void ls_drive_cmd_out_(ls_cmd *cmd, ls_drive *d, const LS_REAL duty[3], ls_pos pos_fb,
                                     ls_pos pos_ref, LS_REAL omega, LS_REAL i_d, LS_REAL i_q, LS_REAL i_q_ref,
                                     LS_REAL v_d, LS_REAL v_q, LS_REAL v_hf, bool cal_done)
{
    if (!LS_ISFINITE(duty[0] + duty[1] + duty[2])) {
        ls_protect_trip(&d->prot, LS_FAULT_NONFINITE);
        ls_drive_disable_(d, cmd, d->prot.fault);
        return;
    }
    ls_drive_cmd_(cmd, d, duty, d->mode, pos_fb, pos_ref, omega * d->inv_kx, i_d, i_q, d->i_d_ref, i_q_ref, v_d,
                  v_q, v_hf, d->cal_index, cal_done, d->psi_cal);
}

#endif /* LINSENSE_LS_DRIVE_CMD_H */
