/* Pieces the steps of ls_drive_step share (ls_drive.c, ls_drive_rotating.c, ls_drive_square.c):
 * private to the library, static inline so that each step keeps its own compiled copy. (The HF
 * band-pass with the residual, and the current control with the advanced angle, are written out in
 * each step: shared, they cost the general or the rotating step 1-5 instructions of the 1,000.) */
#ifndef LINSENSE_LS_DRIVE_PATH_H
#define LINSENSE_LS_DRIVE_PATH_H

#include "linsense/ls_drive.h"

/* After a mode change, once the reference is aligned: the move or step commanded with it. */
static inline void ls_drive_path_pending_(ls_drive *d)
{
    if (d->align) {
        if (d->pending) {
            d->pending = false;
            if (d->pending_move) {
                ls_traj_move(&d->traj, d->pending_target);
            } else {
                ls_traj_jump(&d->traj, d->pending_target);
            }
        }
        d->align = false;
    }
}

/* The reference at the estimate after a mode change, then the move or step commanded with it. */
static inline void ls_drive_path_align_(ls_drive *d)
{
    if (d->align) {
        ls_traj_reset(&d->traj, d->obs.pos);
    }
    ls_drive_path_pending_(d);
}

/* The HF observer on the demodulated error (counted once the injection has reached its
 * amplitude) and its plausibility check; true: a fault tripped. */
static inline bool ls_drive_path_observe_(ls_drive *d, LS_REAL err)
{
    const LS_REAL e_obs = d->inj.amp >= d->cfg.inject.amplitude ? err : LS_R(0.0);
    ls_observer_step_finite(&d->obs, e_obs, d->f_ref);
    ls_protect_check_observer(&d->prot, e_obs, d->demod.valid, d->obs.omega);
    return d->prot.fault != LS_FAULT_NONE;
}

/* Position reference and control at the estimate -> force -> q-current reference (A); the
 * reference's position through *x_ref. */
static inline LS_REAL ls_drive_path_force_(ls_drive *d, ls_pos pos, LS_REAL omega, ls_pos *x_ref)
{
    LS_REAL v_ff, a_ff, x_err, f, i_q_ref;
    ls_traj_step(&d->traj, x_ref, &v_ff, &a_ff);
    x_err = ls_pos_diff(*x_ref, pos) * d->inv_kx;
    f = ls_posctrl_step_finite(&d->pos, x_err, omega * d->inv_kx, v_ff, a_ff);
    i_q_ref = ls_clamp(f * d->inv_kf, -d->cfg.i_max, d->cfg.i_max);
    d->f_ref = i_q_ref * d->cfg.force_constant;
    return i_q_ref;
}

#endif /* LINSENSE_LS_DRIVE_PATH_H */
