/* LS_MODE_SENSORLESS_LUT and LS_MODE_SENSORLESS_NOLUT with the pulsating or elliptical injection and
 * cfg.emf_on: the whole speed range (docs/theory.md, "The hand-over").
 *
 * The step of ls_drive_sensorless.c, with the EMF estimate beside the HF one: the EMF error
 * (ls_emf) from the voltage that drove the period that has just ended (the modulator's record of
 * its duties, less their dead-time compensation) and the currents; the HF chain (residual,
 * band-pass, demodulator) while the injection runs, its error advanced by the HF path's delay; the
 * two errors handed over on the estimated speed (ls_fuse) into the one observer; the injection
 * faded out above the band and back in below it, the voltage it kept given to the fundamental.
 *
 * What runs where (the time budget; docs/theory.md section 11, "What the SPEED step computes
 * where"): below LS_FUSE_EMF_ON v_lo (ls_fuse_emf_run) the EMF's filters are idle, the step the
 * sensorless step with the hand-over's bookkeeping; from there up they run (settled by v_lo, where
 * the EMF error starts to count: the design's rule), their angle from v_lo. The dead-time residual is
 * the forward model where the EMF's filters are idle, its scales measured while the trajectory holds
 * and held through a move, and the interpolated one where they run (the HF error's share falls across
 * the band, and the EMF uses k_r held): each of the forward model, its adaptation and the EMF's filters
 * is a quarter of the step, and the three in one step are over the time budget. LS_MODE_COMMISSION
 * runs the EMF's filters at every speed, so the interpolated residual, and its learning takes turns
 * with the EMF's angle. */
#include "ls_drive_internal.h"

/* The mean voltage (V, alpha-beta) of the period that has just ended: the duties computed two
 * steps ago (the one-period update: the modulator's older record, as ls_mod_residual reads it)
 * less their dead-time compensation, at the bus measured now. */
static inline void applied_voltage(const ls_drive *LS_RESTRICT d, LS_REAL v_dc, LS_REAL v_ab[2])
{
    const ls_mod_hist *h = &d->mod.hist[d->mod.newest ^ 1u];
    const LS_REAL u0 = h->d[0] - h->c[0], u1 = h->d[1] - h->c[1], u2 = h->d[2] - h->c[2];
    v_ab[0] = (LS_R(2.0) * u0 - u1 - u2) * (LS_R(1.0) / LS_R(3.0)) * v_dc;
    v_ab[1] = (u1 - u2) * (LS_R(1.0) / LS_SQRT3) * v_dc;
}

/* The injection starts again after a fade: the HF chain's filters and the residual's start from
 * rest (their states are a fade old), its measured resistance scale kept. */
static void hf_restart(ls_drive *LS_RESTRICT d)
{
    ls_biquad_reset(&d->bpf[0]);
    ls_biquad_reset(&d->bpf[1]);
    ls_demod_reset(&d->demod);
    if (d->cfg.hf_dtres) {
        ls_dtres_restart(&d->dtres);
    }
    ls_drive_follow_r_(d);
}

/* The HF error of the step (the HF chain runs while the injection does; else only the fundamental's
 * separation, and no error). */
static inline LS_REAL hf_error(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_drive_io *LS_RESTRICT io,
                               bool emf_run)
{
    if (d->inj.on || d->inj.amp > LS_R(0.0)) {
        /* where the EMF estimate runs, the residual by interpolation; below, the forward model. Its
         * inductance and resistance scales measured while the trajectory holds (the hold's accuracy;
         * held through a move and where the EMF estimate runs, which uses k_r held) */
        ls_drive_hf_(d, meas, io, emf_run ? LS_DRIVE_RES_INTERP
                                          : (d->traj.active ? LS_DRIVE_RES_HOLD : LS_DRIVE_RES_SPREAD));
        return ls_drive_demod_(d, io, d->obs.pos.theta) + d->cfg.hf_delay * d->obs.omega;
    }
    ls_drive_sep_(d, io);
    io->ihf_a = LS_R(0.0);
    io->ihf_b = LS_R(0.0);
    return LS_R(0.0);
}

/* The observer on the handed-over error and its plausibility (the HF signal's validity while the
 * HF error counts, the EMF's while it does); true: a fault tripped (the step ends). */
static bool observe(ls_drive *LS_RESTRICT d, ls_cmd *LS_RESTRICT cmd, ls_drive_io *LS_RESTRICT io, LS_REAL err)
{
    const bool valid = (!d->fuse.hf_used || d->fuse.w >= LS_R(1.0) || d->demod.valid) &&
                       (d->fuse.w <= LS_R(0.0) || d->emf.mag > LS_R(0.0));
    return ls_drive_observe_checked_(d, cmd, io, err, valid);
}

void ls_drive_speed_run_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd,
                         bool commission)
{
    ls_drive_io io;
    LS_REAL e_emf, e_hf, err;
    bool emf_run;
    if (!ls_drive_est_open_(d, meas, cmd, &io)) {
        return;
    }
    emf_run = commission || ls_fuse_emf_run(&d->fuse, d->obs.omega);
    if (commission) { /* (the learning and the EMF's angle take turns: ls_drive_commission.c) */
        d->learn_turn ^= 1u;
    }
    if (emf_run) {
        /* (the inputs finite: the measurements checked by ls_drive_est_open_, the duties, the estimate
         * and k_r by the step's final check and their bounds) the EMF's filters; its angle (a square
         * root and an atan2) only where the hand-over can weigh it: ls_fuse_step uses eps_emf, and
         * observe the magnitude, only with |omega| > w_lo */
        LS_REAL v_ab[2], i_ab[2];
        applied_voltage(d, meas->v_dc, v_ab);
        i_ab[0] = io.i_a;
        i_ab[1] = io.i_b;
        if (ls_emf_update_finite(&d->emf, v_ab, i_ab, io.c, io.s, d->obs.omega, d->dtres.k_r) &&
            LS_FABS(d->obs.omega) > d->fuse.w_lo && !(commission && d->learn_turn != 0u)) {
            (void)ls_emf_angle(&d->emf, d->obs.omega);
        }
    } else if (d->emf.primed) { /* (idle: its filters start again from rest when it runs again) */
        ls_emf_reset(&d->emf);
    }
    e_emf = d->emf.eps; /* (below w_lo not weighed: the angle of an earlier step, or 0) */
    e_hf = hf_error(d, meas, &io, emf_run);
    err = ls_fuse_step(&d->fuse, d->obs.omega, d->inj.on && d->inj.amp >= d->cfg.inject.amplitude, e_hf,
                       LS_ISFINITE(e_emf) ? e_emf : LS_R(0.0));
    if (observe(d, cmd, &io, err)) {
        return;
    }
    if (commission) { /* the injection kept on; the table learned at speed (ls_drive_commission.c) */
        if (d->learn_turn != 0u) {
            ls_drive_learn_(d);
        }
    } else if (d->fuse.inject != d->inj.on) { /* the injection: faded out above the band, back in
                                                 below it; the voltage it keeps */
        if (d->fuse.inject && !(d->inj.amp > LS_R(0.0))) {
            hf_restart(d);
        }
        ls_inject_enable(&d->inj, d->fuse.inject);
    }
    d->v_hf_max = d->inj.on ? d->cfg.inject.amplitude : d->inj.amp;

    ls_drive_force_(d, &io);
    ls_drive_current_(d, meas->v_dc, &io);
    ls_drive_inject_(d, &io);
    ls_drive_close_(d, meas, cmd, &io, false);
}

void ls_drive_speed_step_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd)
{
    ls_drive_speed_run_(d, meas, cmd, false);
}
