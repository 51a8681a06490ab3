/* ls_drive_step's LS_MODE_STARTUP path (ls_drive.h, ls_startup.h), in a translation unit of its
 * own: ls_drive.c calls it from the outputs-off branch (d->starting) and handles its end. */
#include <math.h>

#include "linsense/ls_drive.h"
#include "linsense/ls_math.h"
#include "ls_drive_cmd.h"
#include "ls_drive_path.h"

/* The HF chain of the sensorless modes (separation, residual, band-pass, demodulator with the
 * table, observer) with zero current references instead of the position loop; during the pulses
 * the observer is frozen, the injection off and the d-voltage the pulse's; at the end of the
 * pulses the estimate is turned by pi if they say so. Returns the sequence's phase after the step
 * (LS_SU_FAILED also for a non-finite output, with LS_FAULT_NONFINITE latched); writes cmd
 * unless it fails. */
ls_startup_phase ls_drive_startup_step_(ls_drive *d, const ls_meas *meas, ls_cmd *cmd)
{
    const ls_drive_cfg *cfg = &d->cfg;
    ls_startup *su = &d->su;
    LS_REAL i_a, i_b, ihf_a, ihf_b, if_a, if_b, c_est, s_est, i_d, i_q, i_dr, v_d, v_q, v_a, v_b;
    LS_REAL v_hf = LS_R(0.0), v_lim, duty[3];
    ls_startup_phase ph;

    i_a = meas->i_abc[0];
    i_b = (meas->i_abc[1] - meas->i_abc[2]) * (LS_R(1.0) / LS_SQRT3);
    ls_sincos(d->obs.pos.theta, &c_est, &s_est);
    ls_drive_path_hf_(d, meas, i_a, i_b, c_est, s_est, &if_a, &if_b, &ihf_a, &ihf_b);
    {
        const LS_REAL err = ls_demod_step_cs_norm(&d->demod, ihf_a, ihf_b, d->obs.pos.theta, c_est, s_est, d->inj.c,
                                             d->inj.s, LS_R(0.0));
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
        i_d = i_dr;
        i_q = -s_est * i_a + c_est * i_b;
        v_d = ls_clamp(su->v_d, -v_max, v_max);
        v_q = LS_R(0.0);
        v_a = c_est * v_d;
        v_b = s_est * v_d;
    } else {
        /* zero currents, on the fundamental currents, plus the injection (no speed loop even once
         * the polarity is known: the observer's speed while it relocks after the pulses is no
         * motion, and a loop on it pushes the mover) */
        i_d = c_est * if_a + s_est * if_b;
        i_q = -s_est * if_a + c_est * if_b;
        v_lim = meas->v_dc * (LS_R(1.0) / LS_SQRT3) - d->v_hf_max;
        /* at zero speed: the observer's speed while it slews onto the axis is no motion, and its
         * back-EMF feed-forward would push the mover */
        ls_current_step_finite(&d->cur, i_d, i_q, LS_R(0.0), LS_R(0.0), LS_R(0.0), v_lim, &v_d, &v_q);
        const LS_REAL g = su->env * su->env * (LS_R(3.0) - LS_R(2.0) * su->env);
        LS_REAL v_hq;
        v_hf = g * ls_inject_step(&d->inj);
        v_hq = g * d->inj.v_q;
        v_a = c_est * v_d - s_est * v_q;
        v_b = s_est * v_d + c_est * v_q;
        if (cfg->inject.shape != LS_INJ_ROTATING) { /* on the estimated axes */
            v_a += v_hf * c_est - v_hq * s_est;
            v_b += v_hf * s_est + v_hq * c_est;
        } else { /* the rotating vector, in the stationary frame */
            v_a += v_hf;
            v_b += v_hq;
        }
    }
    (void)ls_mod_step_finite(&d->mod, v_a, v_b, meas->v_dc, meas->i_abc, duty);
    if (!LS_ISFINITE(duty[0] + duty[1] + duty[2])) {
        ls_protect_trip(&d->prot, LS_FAULT_NONFINITE);
        return LS_SU_FAILED;
    }
    ls_drive_cmd_(cmd, d, duty, LS_MODE_STARTUP, d->obs.pos, d->obs.pos, ls_observer_speed(&d->obs), i_d, i_q,
                  LS_R(0.0), LS_R(0.0), v_d, v_q, v_hf, 0u, false, LS_R(0.0));
    return ph;
}

