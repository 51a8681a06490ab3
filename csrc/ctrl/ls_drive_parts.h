/* The definitions of the pieces every step of the drive is made of (declared and described in
 * ls_drive_internal.h; included only there and by ls_drive_parts.c). LS_DRIVE_PART is
 * `static inline` in a build for speed (each step its own inlined copy) and empty in a build for
 * size (-Os: ls_drive_parts.c compiles the one copy; ls_drive_internal.h, "The pieces"). */
#ifndef LINSENSE_LS_DRIVE_PARTS_H
#define LINSENSE_LS_DRIVE_PARTS_H

/* --------------------------------------------------------------------------- openings */
/* After a mode change, once the reference is aligned: the move or step commanded with it. */
static inline void pending_command(ls_drive *LS_RESTRICT d)
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

LS_DRIVE_PART bool ls_drive_est_open_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd,
                                      ls_drive_io *LS_RESTRICT io)
{
    if (!ls_drive_open_(d, meas, cmd, io)) {
        return false;
    }
    if (d->align) {
        ls_traj_reset(&d->traj, d->obs.pos);
    }
    pending_command(d);
    ls_sincos(d->obs.pos.theta, &io->c, &io->s);
    return true;
}

/* The encoder count as a position (enc_counts per electrical period). */
static inline ls_pos enc_pos(int32_t count, int32_t per_period, LS_REAL k_count)
{
    ls_pos p;
    int32_t q = count / per_period;
    int32_t r = count % per_period;
    if (r < 0) {
        r += per_period;
        q -= 1;
    }
    p.period = q;
    p.theta = (LS_REAL)r * k_count;
    return p;
}

/* The encoder's sample plausible: a count change from the last sample of at most enc_jump_max
 * (int64_t: no overflow whatever the counts; |jump| <= max as one unsigned comparison), except at
 * the first step of the mode (d->align: there is no last sample), and its position pe within
 * +-LS_POS_PERIOD_MAX periods (beyond only with enc_counts < 128). */
static inline bool enc_plausible(ls_drive *LS_RESTRICT d, int32_t count, ls_pos pe)
{
    const int64_t jump = (int64_t)count - (int64_t)d->enc_prev;
    const bool ok = d->align || (uint64_t)(jump + d->enc_jump_max) <= (uint64_t)(2 * d->enc_jump_max);
    d->enc_prev = count;
    return ok && pe.period <= LS_POS_PERIOD_MAX && pe.period >= -LS_POS_PERIOD_MAX;
}

LS_DRIVE_PART bool ls_drive_enc_open_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd,
                                      ls_drive_io *LS_RESTRICT io)
{
    const ls_drive_cfg *cfg = &d->cfg;
    ls_pos pe;
    if (!meas->enc_valid) {
        ls_protect_trip(&d->prot, LS_FAULT_ENCODER);
    }
    if (!ls_drive_open_(d, meas, cmd, io)) { /* (and the latched faults) */
        return false;
    }
    pe = enc_pos(meas->enc_count, cfg->enc_counts, d->enc_k);
    if (!enc_plausible(d, meas->enc_count, pe)) {
        ls_protect_trip(&d->prot, LS_FAULT_ENCODER);
        ls_drive_disable_report_(d, cmd, d->prot.fault);
        return false;
    }
    if (d->align) {
        /* load_ff: the sensorless modes held the load in the HF observer's estimate (the speed PI's
         * integrator at 0); the encoder modes hold it in the integrator */
        if (cfg->load_ff && cfg->pos.type == LS_POSCTRL_P) {
            d->pos.speed.integ = ls_clamp(d->obs.f_load, cfg->pos.speed.out_min, cfg->pos.speed.out_max);
        }
        ls_observer_reset(&d->enc, pe);
        ls_observer_reset(&d->obs, pe);
        ls_traj_reset(&d->traj, pe);
        pending_command(d); /* (the move or step commanded with the mode change) */
    }
    ls_observer_step_finite(&d->enc, ls_pos_diff(pe, d->enc.pos), d->f_ref);
    ls_sincos(d->enc.pos.theta, &io->c, &io->s);
    return true;
}

/* --------------------------------------------------------------------------- HF path and estimation */
LS_DRIVE_PART void ls_drive_residual_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas,
                                      const ls_drive_io *LS_RESTRICT io, LS_REAL i_res[2], unsigned model)
{
    LS_REAL v_err[2], li[3];
    const LS_REAL *li_step = NULL; /* (the interpolation's: none) */
    if (d->dtres.cfg.forward && model != LS_DRIVE_RES_INTERP) {
        /* the back-EMF at the trajectory's speed, not the estimate's: no loop from the estimate
         * through the residual back into it (a hold's limit cycle otherwise, docs/firmware.md) */
        LS_REAL g[6], ge[3], i_end[3], i_drop[3];
        const bool fit = d->dtres.cfg.adapt && model >= LS_DRIVE_RES_ADAPT; /* (the end currents are for it) */
        ls_dtres_phase_g(&d->dtres, io->c, io->s, d->w_ref * d->cfg.current.psi_pm, li, g, ge);
        if (ls_mod_residual(&d->mod, meas->i_abc, meas->v_dc, g, ge, d->dtres.cfg.r_s * d->dtres.k_r, v_err,
                            fit ? i_end : NULL, i_drop) &&
            fit) {
            /* (k_r held while the angle is not the motor's: the start-up, the table off) */
            ls_dtres_adapt(&d->dtres, d->mod.i_prev, meas->i_abc, i_end, i_drop,
                           !d->starting && d->mode != LS_MODE_SENSORLESS_NOLUT, model == LS_DRIVE_RES_SPREAD);
            if (d->dtres.n_solve == 0u) { /* (k_r solved for) */
                ls_drive_follow_r_(d);
            }
        }
        li_step = li;
    } else {
        (void)ls_mod_residual_interp(&d->mod, meas->i_abc, meas->v_dc, d->dtres.k_rip, v_err);
    }
    ls_dtres_step(&d->dtres, v_err, io->c, io->s, li_step, i_res);
}

LS_DRIVE_PART void ls_drive_hf_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_drive_io *LS_RESTRICT io,
                                unsigned model)
{
    ls_drive_sep_(d, io);
    if (d->cfg.hf_dtres) { /* (bpf is then the band-pass: not with the square wave, ls_drive_init) */
        LS_REAL i_res[2];
        ls_drive_residual_(d, meas, io, i_res, model);
        io->ihf_a = ls_biquad_step_bp(&d->bpf[0], io->i_a - i_res[0]);
        io->ihf_b = ls_biquad_step_bp(&d->bpf[1], io->i_b - i_res[1]);
    } else {
        io->ihf_a = ls_biquad_step(&d->bpf[0], io->i_a);
        io->ihf_b = ls_biquad_step(&d->bpf[1], io->i_b);
    }
}

LS_DRIVE_PART LS_REAL ls_drive_demod_(ls_drive *LS_RESTRICT d, const ls_drive_io *LS_RESTRICT io, LS_REAL theta)
{
    return ls_demod_step_cs_norm(&d->demod, io->ihf_a, io->ihf_b, theta, io->c, io->s, d->inj.c, d->inj.s,
                                 LS_R(0.0));
}

LS_DRIVE_PART bool ls_drive_observe_(ls_drive *LS_RESTRICT d, ls_cmd *LS_RESTRICT cmd, ls_drive_io *LS_RESTRICT io,
                                     LS_REAL err)
{
    const LS_REAL e_obs = d->inj.amp >= d->cfg.inject.amplitude ? err : LS_R(0.0);
    return ls_drive_observe_checked_(d, cmd, io, e_obs, d->demod.valid);
}

/* --------------------------------------------------------------------------- force and current */
/* The force constant at theta with its ripple (cfg.ripple_order != 0), N/A. */
static inline LS_REAL ripple_kf(const ls_drive *LS_RESTRICT d, LS_REAL theta)
{
    const ls_drive_cfg *cfg = &d->cfg;
    LS_REAL c, s;
    ls_sincos_full((LS_REAL)cfg->ripple_order * theta, &c, &s); /* (out of line: the frictionless drives pay no code) */
    return d->kf * (LS_R(1.0) + cfg->ripple_c * c + cfg->ripple_s * s);
}

/* The current reference of force f at theta, clamped to i_max, and the force it makes (d->f_ref,
 * the observer's): f / K_f, or with cfg.ripple_order the force constant's ripple divided out. */
static inline LS_REAL force_current(ls_drive *LS_RESTRICT d, LS_REAL f, LS_REAL theta)
{
    const ls_drive_cfg *cfg = &d->cfg;
    LS_REAL i_q;
    if (cfg->ripple_order != 0) {
        const LS_REAL kf = ripple_kf(d, theta);
        i_q = ls_clamp(f / kf, -cfg->i_max, cfg->i_max);
        d->f_ref = i_q * kf;
        return i_q;
    }
    i_q = ls_clamp(f * d->inv_kf, -cfg->i_max, cfg->i_max);
    d->f_ref = i_q * d->kf;
    return i_q;
}

LS_DRIVE_PART void ls_drive_force_(ls_drive *LS_RESTRICT d, ls_drive_io *LS_RESTRICT io)
{
    LS_REAL v_ff, a_ff, x_err, f;
    ls_traj_step(&d->traj, &io->x_ref, &v_ff, &a_ff);
    d->w_ref = v_ff * d->kx;
    x_err = ls_pos_diff(io->x_ref, io->pos) * d->inv_kx;
    a_ff += d->ff_load_k * d->obs.f_load; /* load_ff: the observer's load-force estimate, */
    d->pos.speed.integ *= d->integ_keep;   /* which is then the integral action */
    f = ls_posctrl_step_finite(&d->pos, x_err, io->omega * d->inv_kx, v_ff, a_ff);
    io->i_q_ref = force_current(d, f, io->pos.theta);
}

LS_DRIVE_PART void ls_drive_enc_force_(ls_drive *LS_RESTRICT d, ls_drive_io *LS_RESTRICT io, bool dithered,
                                       LS_REAL dither)
{
    LS_REAL v_ff, a_ff, x_err, f, kf = d->kf;
    ls_traj_step(&d->traj, &io->x_ref, &v_ff, &a_ff);
    x_err = ls_pos_diff(io->x_ref, io->pos) * d->inv_kx;
    f = ls_posctrl_step_finite(&d->pos, x_err, io->omega * d->inv_kx, v_ff, a_ff);
    if (d->cfg.ripple_order != 0) { /* (the force constant's ripple divided out) */
        kf = ripple_kf(d, io->pos.theta);
        io->i_q_ref = f / kf;
    } else {
        io->i_q_ref = f * d->inv_kf;
    }
    d->obs.f_load = ls_clamp(d->pos.speed.integ, -d->cfg.obs.force_max, d->cfg.obs.force_max);
    if (dithered) {
        io->i_q_ref += dither;
    }
    io->i_q_ref = ls_clamp(io->i_q_ref, -d->cfg.i_max, d->cfg.i_max);
    d->f_ref = io->i_q_ref * kf;
}

LS_DRIVE_PART void ls_drive_current_(ls_drive *LS_RESTRICT d, LS_REAL v_dc, ls_drive_io *LS_RESTRICT io)
{
    const LS_REAL c = io->c, s = io->s;
    const LS_REAL v_lim = v_dc * (LS_R(1.0) / LS_SQRT3) - d->v_hf_max;
    const LS_REAL dlt = d->delay_ts * io->omega;
    const LS_REAL c_adv = c - s * dlt, s_adv = s + c * dlt;
    LS_REAL vd, vq;
    io->i_d = c * io->if_a + s * io->if_b;
    io->i_q = -s * io->if_a + c * io->if_b;
    ls_current_step_finite(&d->cur, io->i_d, io->i_q, d->i_d_ref, io->i_q_ref, io->omega, v_lim, &vd, &vq);
    io->v_d = vd;
    io->v_q = vq;
    io->v_a = c_adv * vd - s_adv * vq;
    io->v_b = s_adv * vd + c_adv * vq;
}

/* --------------------------------------------------------------------------- close */
LS_DRIVE_PART void ls_drive_cmd_out_(ls_cmd *LS_RESTRICT cmd, ls_drive *LS_RESTRICT d,
                                     const ls_drive_io *LS_RESTRICT io,
                                     bool cal_done)
{
    if (!LS_ISFINITE(io->duty[0] + io->duty[1] + io->duty[2])) {
        ls_protect_trip(&d->prot, LS_FAULT_NONFINITE);
        ls_drive_disable_(d, cmd, d->prot.fault);
        return;
    }
    ls_drive_cmd_(cmd, d, io, d->mode, io->omega * d->inv_kx, d->i_d_ref, cal_done);
}

LS_DRIVE_PART void ls_drive_close_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd,
                                   ls_drive_io *LS_RESTRICT io, bool cal_done)
{
    (void)ls_mod_step_finite(&d->mod, io->v_a, io->v_b, meas->v_dc, meas->i_abc, io->duty);
    ls_drive_cmd_out_(cmd, d, io, cal_done);
}

#endif /* LINSENSE_LS_DRIVE_PARTS_H */
