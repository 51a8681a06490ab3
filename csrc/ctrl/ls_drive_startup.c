/* LS_MODE_STARTUP, every injection shape (ls_drive.h, ls_startup.h): ls_drive.c's step of the
 * mode (ls_drive.c, "The step table") opens the step (ls_drive_open_), runs this and handles its
 * end. */
#include "ls_drive_internal.h"

/* The HF chain of the sensorless modes (separation, residual, band-pass, demodulator with the
 * table, observer) with zero current references instead of the position loop; during the pulses
 * the observer is frozen, the injection off and the d-voltage the pulse's; at the end of the
 * pulses the estimate is turned by pi if they say so. Returns the sequence's phase after the step
 * (LS_SU_FAILED also for a non-finite output, with LS_FAULT_NONFINITE latched); writes cmd
 * unless it fails. io: the step's values, opened (ls_drive_open_). */
ls_startup_phase ls_drive_startup_run_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas,
                                       ls_cmd *LS_RESTRICT cmd,
                                       ls_drive_io *LS_RESTRICT io)
{
    const ls_drive_cfg *cfg = &d->cfg;
    ls_startup *su = &d->su;
    LS_REAL i_dr, v_lim;
    ls_startup_phase ph;
    const LS_REAL i_a = io->i_a, i_b = io->i_b;
    LS_REAL c_est, s_est;

    ls_sincos(d->obs.pos.theta, &io->c, &io->s);
    c_est = io->c;
    s_est = io->s;
    ls_drive_hf_(d, meas, io, LS_DRIVE_RES_ADAPT);
    io->v_hf = LS_R(0.0);
    {
        const LS_REAL err = ls_drive_demod_(d, io, d->obs.pos.theta);
        if (su->phase == LS_SU_LOCK || su->phase == LS_SU_SETTLE) { /* frozen in between */
            ls_observer_step_finite(&d->obs, su->env >= LS_R(1.0) ? err * cfg->startup.lock_gain : LS_R(0.0),
                                    LS_R(0.0));
            /* (no load estimate while it slews onto the axis at zero current: a mechanical
             * observer's would hold what the slewing looked like, and load_ff push it) */
            d->obs.f_load = LS_R(0.0);
        }
        /* the raw currents in the estimated frame (the pulses' start and end) */
        i_dr = c_est * i_a + s_est * i_b;
        ph = ls_startup_step(su, i_dr, err, d->demod.valid);
    }
    if (ph == LS_SU_FAILED) {
        return ph; /* the caller trips LS_FAULT_OBSERVER and turns the outputs off */
    }
    if (su->turned && su->flip) { /* the other pole: by pi, in the same period as the guess */
        d->obs.pos = ls_pos_add(d->obs.pos, d->obs.pos.theta < LS_PI ? LS_PI : -LS_PI);
        d->obs.omega = LS_R(0.0);
    }
    /* the injection: the carrier at full amplitude times a smoothstep envelope (a linear ramp's
     * corners leave a DC current, a force impulse that a free mover keeps as a drift): up while
     * locking and settling, down while quiet, zero during the pulses */
    {
        const LS_REAL du = d->inj.amp_step / cfg->inject.amplitude;
        const bool up = ph == LS_SU_LOCK || ph == LS_SU_SETTLE || ph == LS_SU_DONE;
        su->env = ls_clamp(up ? su->env + du : su->env - du, LS_R(0.0), LS_R(1.0));
        if (ph == LS_SU_PULSE) {
            su->env = LS_R(0.0);
        }
        ls_inject_enable(&d->inj, true);
        d->inj.amp = cfg->inject.amplitude;
    }
    if (ph == LS_SU_PULSE || su->turned) {
        /* open loop: the pulse's d-voltage, or zero (the current decays freely, no controller
         * overshoot to bias the next pulse); the controller starts again afterwards */
        const LS_REAL v_max = meas->v_dc * (LS_R(0.95) / LS_SQRT3); /* 95 % of the linear range */
        ls_current_reset(&d->cur);
        (void)ls_inject_step(&d->inj); /* the carrier goes on */
        io->i_d = i_dr;
        io->i_q = -s_est * i_a + c_est * i_b;
        io->v_d = ls_clamp(su->v_d, -v_max, v_max);
        io->v_q = LS_R(0.0);
        io->v_a = c_est * io->v_d;
        io->v_b = s_est * io->v_d;
    } else {
        /* zero currents, on the fundamental currents, plus the injection (no speed loop even once
         * the polarity is known: the observer's speed while it relocks after the pulses is no
         * motion, and a loop on it pushes the mover) */
        io->i_d = c_est * io->if_a + s_est * io->if_b;
        io->i_q = -s_est * io->if_a + c_est * io->if_b;
        v_lim = meas->v_dc * (LS_R(1.0) / LS_SQRT3) - d->v_hf_max;
        /* at zero speed: the observer's speed while it slews onto the axis is no motion, and its
         * back-EMF feed-forward would push the mover */
        LS_REAL v_d, v_q, v_hq, g;
        ls_current_step_finite(&d->cur, io->i_d, io->i_q, LS_R(0.0), LS_R(0.0), LS_R(0.0), v_lim, &v_d, &v_q);
        g = su->env * su->env * (LS_R(3.0) - LS_R(2.0) * su->env);
        io->v_d = v_d;
        io->v_q = v_q;
        io->v_hf = g * ls_inject_step(&d->inj);
        v_hq = g * d->inj.v_q;
        io->v_a = c_est * v_d - s_est * v_q;
        io->v_b = s_est * v_d + c_est * v_q;
        if (cfg->inject.shape != LS_INJ_ROTATING) { /* on the estimated axes */
            io->v_a += io->v_hf * c_est - v_hq * s_est;
            io->v_b += io->v_hf * s_est + v_hq * c_est;
        } else { /* the rotating vector, in the stationary frame */
            io->v_a += io->v_hf;
            io->v_b += v_hq;
        }
    }
    (void)ls_mod_step_finite(&d->mod, io->v_a, io->v_b, meas->v_dc, meas->i_abc, io->duty);
    if (!LS_ISFINITE(io->duty[0] + io->duty[1] + io->duty[2])) {
        ls_protect_trip(&d->prot, LS_FAULT_NONFINITE);
        return LS_SU_FAILED;
    }
    /* the estimate is the feedback and the reference; no current references, no calibration */
    io->pos = d->obs.pos;
    io->x_ref = d->obs.pos;
    io->i_q_ref = LS_R(0.0);
    ls_drive_cmd_(cmd, d, io, LS_MODE_STARTUP, ls_observer_speed(&d->obs), LS_R(0.0), false);
    cmd->cal_index = 0u;
    cmd->psi_cal = LS_R(0.0);
    return ph;
}

