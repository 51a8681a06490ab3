/* linsense host-side simulator (ls_sim.h): the configuration check, the closed-loop time loop
 * (ls_sim_begin, ls_sim_continue, ls_sim_run) and the open loop, around the parts declared in
 * ls_sim_internal.h. Double precision. */
#include "ls_sim_internal.h"

/* ------------------------------------------------------------------------------ checks */
ls_status ls_sim_check(const ls_sim_cfg *c)
{
    int32_t k, e;
    if (c == NULL) {
        return LS_ERR_NULL;
    }
    if (!(LS_ISFINITE(c->r_s) && c->r_s >= 0.0) || !(LS_ISFINITE(c->pole_pitch) && c->pole_pitch > 0.0) ||
        !(LS_ISFINITE(c->psi_pm) && c->psi_pm >= 0.0) || c->n_order < 1 || c->n_order > LS_SIM_MAX_ORDER ||
        c->n_pm < 0 || c->n_pm > LS_SIM_MAX_PM || !(LS_ISFINITE(c->mass) && c->mass > 0.0) ||
        !(LS_ISFINITE(c->visc) && c->visc >= 0.0) || !(LS_ISFINITE(c->coulomb) && c->coulomb >= 0.0) ||
        !(c->x_min < c->x_max) || !(LS_ISFINITE(c->v_dc) && c->v_dc > 0.0) || !(LS_ISFINITE(c->f_pwm) && c->f_pwm > 0.0) ||
        !(LS_ISFINITE(c->dead_time) && c->dead_time >= 0.0 && c->dead_time * c->f_pwm < 0.1) ||
        !(LS_ISFINITE(c->i_noise) && c->i_noise >= 0.0) || c->adc_bits < 0 || c->adc_bits > 24 ||
        (c->adc_bits > 0 && !(LS_ISFINITE(c->adc_range) && c->adc_range > 0.0)) || c->enc_counts <= 0 ||
        c->decimate < 1 || !(LS_ISFINITE(c->x0) && c->x0 >= c->x_min && c->x0 <= c->x_max) || !LS_ISFINITE(c->v0) ||
        !(LS_ISFINITE(c->i_abort) && c->i_abort > 0.0) || !LS_ISFINITE(c->load_f0) || !LS_ISFINITE(c->load_f1) || !LS_ISFINITE(c->load_t) ||
        !LS_ISFINITE(c->load_incline) || (c->fidelity != LS_SIM_AVERAGE && c->fidelity != LS_SIM_SWITCHING) ||
        (c->motion != LS_SIM_FREE && c->motion != LS_SIM_HELD && c->motion != LS_SIM_PRESCRIBED) ||
        (c->load != LS_SIM_LOAD_CONSTANT && c->load != LS_SIM_LOAD_STEP && c->load != LS_SIM_LOAD_INCLINE)) {
        return LS_ERR_PARAM;
    }
    for (k = 0; k < 3; ++k) {
        if (!LS_ISFINITE(c->i_gain[k]) || !LS_ISFINITE(c->i_offset[k])) {
            return LS_ERR_PARAM;
        }
    }
    for (e = 0; e < 3; ++e) {
        for (k = 0; k < c->n_order; ++k) {
            if (!LS_ISFINITE(c->lab_cos[e][k]) || !LS_ISFINITE(c->lab_sin[e][k])) {
                return LS_ERR_PARAM;
            }
        }
    }
    for (k = 0; k < c->n_pm; ++k) {
        if (!LS_ISFINITE(c->pm_amp[k]) || !LS_ISFINITE(c->pm_phase[k]) || c->pm_order[k] < 1) {
            return LS_ERR_PARAM;
        }
    }
    if (c->sat.on != 0) {
        const ls_sim_sat *s = &c->sat;
        int32_t p;
        if (s->on != 1 || s->n_order < 1 || s->n_order > LS_SIM_MAX_ORDER || s->n_pow < 1 ||
            s->n_pow > LS_SIM_SAT_POW || !(LS_ISFINITE(s->i_m) && s->i_m >= 0.0) ||
            !(LS_ISFINITE(s->i_sat_d) && s->i_sat_d >= 0.0)) {
            return LS_ERR_PARAM;
        }
        for (p = 0; p < s->n_pow; ++p) {
            for (e = 0; e < 3; ++e) {
                for (k = 0; k < s->n_order; ++k) {
                    if (!LS_ISFINITE(s->dq_cos[p][e][k]) || !LS_ISFINITE(s->dq_sin[p][e][k])) {
                        return LS_ERR_PARAM;
                    }
                }
            }
        }
    }
    return LS_OK;
}

/* the plant state is finite and its phase currents below the abort level */
LS_SIM_INLINE bool plant_ok(const ls_sim_cfg *c, const double i[2], double x, double v)
{
    double iabc[3];
    ls_sim_ab_to_abc(i, iabc);
    /* false for a non-finite current too */
    return fabs(iabc[0]) < c->i_abort && fabs(iabc[1]) < c->i_abort && fabs(iabc[2]) < c->i_abort && LS_ISFINITE(x) &&
           LS_ISFINITE(v);
}

/* ------------------------------------------------------------------------------ runs */
/* cos and sin of an angle that moves little from call to call: the previous pair rotated by the
 * increment d (Taylor series of cos d and sin d, truncation < 1e-15 for |d| <= 0.05 rad, i.e. up
 * to ~7 m/s at 16 kHz for tau = 56 mm); computed exactly on the first call, after a larger jump
 * and every 4096 calls, so rounding (~1e-16 per rotation) never accumulates beyond ~1e-12. */
typedef struct {
    double th;    /* rad, angle of the pair */
    double c, s;  /* -, cos th, sin th */
    int32_t left; /* -, rotations before the next exact evaluation */
} angle_track;

LS_SIM_INLINE void angle_to(angle_track *a, double th)
{
    double d = th - a->th;
    if (a->left > 0 && fabs(d) <= 0.05) {
        double d2 = d * d;
        double cd = 1.0 - 0.5 * d2 * (1.0 - d2 * (1.0 / 12.0) * (1.0 - d2 * (1.0 / 30.0)));
        double sd = d * (1.0 - d2 * (1.0 / 6.0) * (1.0 - d2 * (1.0 / 20.0) * (1.0 - d2 * (1.0 / 42.0))));
        double cn = a->c * cd - a->s * sd, sn = a->s * cd + a->c * sd;
        a->c = cn;
        a->s = sn;
        a->left--;
    } else {
        a->c = cos(th);
        a->s = sin(th);
        a->left = 4096;
    }
    a->th = th;
}

ls_status ls_sim_begin(const ls_sim_cfg *c, ls_sim_state *s)
{
    int j;
    if (c == NULL || s == NULL) {
        return LS_ERR_NULL;
    }
    if (ls_sim_check(c) != LS_OK) {
        return LS_ERR_PARAM;
    }
    memset(s, 0, sizeof *s);
    s->rec_count = 1;
    s->rng = c->seed * 0x9E3779B97F4A7C15ull + 0x2545F4914F6CDD1Dull;
    if (s->rng == 0u) {
        s->rng = 1u;
    }
    s->x = c->x0;
    s->v = c->motion == LS_SIM_HELD ? 0.0 : c->v0;
    s->x_lag = s->x;
    s->v_lag = s->v;
    s->v_lag2 = s->v;
    for (j = 0; j < 3; ++j) {
        s->duty[j] = 0.5;
        s->carry_t[j] = ls_sim_no_carry.t[j];
        s->carry_on[j] = ls_sim_no_carry.on[j];
        s->carry_excess[j] = ls_sim_no_carry.excess[j];
    }
    s->carry_any = ls_sim_no_carry.any_excess ? 1 : 0;
    s->ang_th = 0.0;
    s->ang_c = 1.0;
    s->ang_s = 0.0;
    s->ang_left = 0;
    return LS_OK;
}

/* Block statistics of the samples being recorded (ls_sim_out x_min ... i_abc_max) */

LS_SIM_INLINE ls_status continue_impl(const ls_sim_cfg *c, ls_drive *drive, const ls_sim_cmd *cmds, int32_t n_cmds,
                                      ls_sim_state *s, int64_t n_more, const ls_sim_out *out, ls_sim_result *res,
                                      const bool sat)
{
    const double h = 1.0 / c->f_pwm, tau = c->pole_pitch, kx = 2.0 * LS_SIM_PI / tau;
    double x, v, i[2], duty[3], x_lag, v_lag, v_lag2; /* m, m/s: x and v one period back, v two back */
    uint64_t rng;
    int64_t k, k_end, r = 0;
    int32_t next, rec_count, j;
    uint32_t fault;
    bool blk, blk_err;
    ls_meas meas;
    ls_cmd cmd;
    ls_sim_maps pm;
    ls_sim_coef q;
    angle_track ang;
    ls_sim_carry carry;
    ls_sim_block acc;
    ls_sim_frozen fz;
    ls_sim_sat_frame sf;
    if (c == NULL || drive == NULL || s == NULL || out == NULL || res == NULL || (n_cmds > 0 && cmds == NULL) ||
        n_more < 0) {
        return LS_ERR_NULL;
    }
    if (ls_sim_check(c) != LS_OK) {
        return LS_ERR_PARAM;
    }
    blk_err = out->err_min != NULL || out->err_max != NULL || out->err_mean != NULL;
    blk = blk_err || out->x_min != NULL || out->x_max != NULL || out->x_mean != NULL || out->i_abc_min != NULL ||
          out->i_abc_max != NULL;
    if (blk && !s->ended && s->rec_count != 1) { /* a block begun in the previous call */
        return LS_ERR_PARAM;
    }
    memset(res, 0, sizeof *res);
    res->steps_done = s->k;
    res->fault = s->fault;
    res->x_end = s->x;
    res->v_end = s->v;
    if (s->ended) {
        return LS_OK;
    }
    /* the state in locals for the time loop (registers), written back at the end */
    x = s->x;
    v = s->v;
    i[0] = s->i[0];
    i[1] = s->i[1];
    x_lag = s->x_lag;
    v_lag = s->v_lag;
    v_lag2 = s->v_lag2;
    rng = s->rng;
    next = s->next;
    rec_count = s->rec_count;
    fault = s->fault;
    for (j = 0; j < 3; ++j) {
        duty[j] = s->duty[j];
        carry.t[j] = s->carry_t[j];
        carry.on[j] = s->carry_on[j];
        carry.excess[j] = s->carry_excess[j];
    }
    carry.any_excess = s->carry_any != 0;
    ang.th = s->ang_th;
    ang.c = s->ang_c;
    ang.s = s->ang_s;
    ang.left = s->ang_left;
    acc.r = -1;
    acc.n = 0;
    ls_sim_coef_init(c, &q);
    memset(&cmd, 0, sizeof cmd);
    k_end = s->k + n_more;
    for (k = s->k; k < k_end; ++k) {
        double t = (double)k * h, x_mid, f_start, f_avg, u[3], th_mid, cm, sm, dl, cd, sd, om;
        bool bad = false;
        if (k % LS_SIM_STOP_POLL == 0 && out->stop != NULL && *out->stop != 0) {
            fault |= LS_SIM_FAULT_STOPPED;
            break;
        }
        while (next < n_cmds && cmds[next].t <= t) {
            if (cmds[next].move) {
                ls_drive_move_to(drive, ls_sim_pos_of_m(cmds[next].x, tau));
            } else {
                ls_drive_step_to(drive, ls_sim_pos_of_m(cmds[next].x, tau));
            }
            next++;
        }
        /* sample at the carrier peak, run the controller; its duties act next period */
        ls_sim_measure(c, &q, i, x, drive->mode == LS_MODE_SENSORED || drive->mode == LS_MODE_CALIBRATION, &rng, &meas);
        ls_drive_step(drive, &meas, &cmd);
        fault |= cmd.fault;
        u[0] = duty[0]; u[1] = duty[1]; u[2] = duty[2];
        /* the plant over this period with the duties computed one period earlier, frozen at the
         * mid-period position predicted from the state one period back (exact for a constant
         * acceleration; see ls_sim.h), so that this period's matrices do not wait for the last
         * period's force; cos and sin tracked from the previous period; the start angle for
         * recording follows by a small rotation, |dl| < 1e-2 rad, series exact to 1e-13 */
        x_mid = k == 0 ? x + 0.5 * h * v : x_lag + h * (2.5 * v_lag - v_lag2);
        th_mid = kx * x_mid;
        angle_to(&ang, th_mid);
        cm = ang.c;
        sm = ang.s;
        /* the speed at mid-period likewise (exact for a constant acceleration) */
        om = kx * (1.5 * v - 0.5 * v_lag);
        if (!sat) {
            ls_sim_maps_cs(c, &q, th_mid, cm, sm, &pm);
            if (!ls_sim_freeze(c, &pm, om, &fz)) {
                fault |= LS_SIM_FAULT_DIVERGED;
            }
            f_start = ls_sim_force_of(&q, &pm, i);
        } else {
            /* the saturated plant: its values at the mid-period angle, and for the inverter's
             * predictions the system linearised at the period-start currents (L = d lambda/d i,
             * the EMF omega d lambda/d theta frozen) */
            ls_sim_sat_point sp;
            ls_sim_sat_frame_at(c, th_mid, &sf);
            ls_sim_sat_at(c, &sf, i, &sp);
            memcpy(pm.l, sp.l, sizeof pm.l);
            pm.dl[0] = pm.dl[1] = pm.dl[2] = 0.0;
            memcpy(pm.lpm, sp.lam, sizeof pm.lpm);
            memcpy(pm.dlpm, sp.dlam, sizeof pm.dlpm);
            if (!ls_sim_freeze(c, &pm, om, &fz)) {
                fault |= LS_SIM_FAULT_DIVERGED;
            }
            f_start = sp.force;
        }
        if (--rec_count == 0) {
            rec_count = c->decimate;
            dl = kx * (x - x_mid);
            cd = 1.0 - 0.5 * dl * dl * (1.0 - dl * dl * (1.0 / 12.0));
            sd = dl * (1.0 - dl * dl * (1.0 / 6.0) * (1.0 - dl * dl * (1.0 / 20.0)));
            if (blk) { /* the previous sample's block is complete; this sample opens the next */
                ls_sim_block_write(out, &acc);
                ls_sim_block_open(&acc, r, x, blk_err ? ls_sim_est_err(&cmd, x, tau, kx) : 0.0, i);
            }
            ls_sim_record(out, r++, t, x, v, i, cm * cd - sm * sd, sm * cd + cm * sd, u, f_start, &cmd, tau, kx, fault);
        } else if (blk) {
            ls_sim_block_add(&acc, x, blk_err ? ls_sim_est_err(&cmd, x, tau, kx) : 0.0, i);
        }
        if (fault != 0u || cmd.cal_done) { /* a calibration run ends with the calibration */
            s->ended = 1;
            break;
        }
        if (c->fidelity == LS_SIM_SWITCHING) {
            double f_int;
            if (sat) {
                ls_sim_period_switching_sat(c, &q, &fz, u, h, i, &f_int, &carry, &sf, om, &bad);
            } else {
                ls_sim_period_switching(c, &q, &fz, &pm, u, h, i, &f_int, &carry);
            }
            f_avg = f_int / h;
        } else if (sat) {
            double f_end;
            bad = !ls_sim_period_average_sat(c, &q, &fz, &sf, om, u, h, i, &carry, &f_end);
            f_avg = 0.5 * (f_start + f_end);
        } else {
            ls_sim_period_average(c, &q, &fz, u, h, i, &carry);
            f_avg = 0.5 * (f_start + ls_sim_force_of(&q, &pm, i));
        }
        if (bad) {
            fault |= LS_SIM_FAULT_DIVERGED;
        }
        x_lag = x;
        v_lag2 = v_lag;
        v_lag = v;
        ls_sim_mechanics(c, &q, t, h, f_avg, &x, &v);
        if (cmd.enable) {
            duty[0] = (double)cmd.duty[0];
            duty[1] = (double)cmd.duty[1];
            duty[2] = (double)cmd.duty[2];
        } else {
            duty[0] = duty[1] = duty[2] = 0.5;
        }
        if (!plant_ok(c, i, x, v)) {
            fault |= LS_SIM_FAULT_DIVERGED;
        } else if (x < c->x_min || x > c->x_max) {
            fault |= LS_SIM_FAULT_TRAVEL;
        }
        if (fault != 0u) {
            /* record the state that tripped (a block of its own), then stop */
            double nan3[3] = {NAN, NAN, NAN}, f_end = NAN;
            if (LS_ISFINITE(i[0]) && LS_ISFINITE(i[1]) && LS_ISFINITE(x)) {
                f_end = ls_sim_force_at(c, &q, kx * x, i);
            }
            if (blk) {
                ls_sim_block_write(out, &acc);
                ls_sim_block_open(&acc, r, x, blk_err ? ls_sim_est_err(&cmd, x, tau, kx) : 0.0, i);
            }
            ls_sim_record(out, r++, t + h, x, v, i, cos(kx * x), sin(kx * x), nan3, f_end, &cmd, tau, kx, fault);
            k++;
            s->ended = 1;
            break;
        }
    }
    if (fault & LS_SIM_FAULT_STOPPED) {
        s->ended = 1;
    }
    if (blk) {
        ls_sim_block_write(out, &acc); /* complete when the call ends where a block does, or the run ends */
    }
    s->k = k;
    s->n_rec += r;
    s->fault = fault;
    s->x = x;
    s->v = v;
    s->i[0] = i[0];
    s->i[1] = i[1];
    s->x_lag = x_lag;
    s->v_lag = v_lag;
    s->v_lag2 = v_lag2;
    s->rng = rng;
    s->next = next;
    s->rec_count = rec_count;
    for (j = 0; j < 3; ++j) {
        s->duty[j] = duty[j];
        s->carry_t[j] = carry.t[j];
        s->carry_on[j] = carry.on[j];
        s->carry_excess[j] = carry.excess[j];
    }
    s->carry_any = carry.any_excess ? 1 : 0;
    s->ang_th = ang.th;
    s->ang_c = ang.c;
    s->ang_s = ang.s;
    s->ang_left = ang.left;
    res->steps_done = k;
    res->n_rec = r;
    res->fault = fault;
    res->x_end = x;
    res->v_end = v;
    return LS_OK;
}

ls_status ls_sim_continue(const ls_sim_cfg *c, ls_drive *drive, const ls_sim_cmd *cmds, int32_t n_cmds,
                          ls_sim_state *s, int64_t n_more, const ls_sim_out *out, ls_sim_result *res)
{
    if (c != NULL && c->sat.on != 0) {
        return continue_impl(c, drive, cmds, n_cmds, s, n_more, out, res, true);
    }
    return continue_impl(c, drive, cmds, n_cmds, s, n_more, out, res, false);
}

ls_status ls_sim_run(const ls_sim_cfg *c, ls_drive *drive, const ls_sim_cmd *cmds, int32_t n_cmds, int64_t n_steps,
                     const ls_sim_out *out, ls_sim_result *res)
{
    ls_sim_state s;
    ls_status st;
    if (c == NULL || drive == NULL || out == NULL || res == NULL || (n_cmds > 0 && cmds == NULL) || n_steps < 0) {
        return LS_ERR_NULL;
    }
    st = ls_sim_begin(c, &s);
    if (st != LS_OK) {
        return st;
    }
    return ls_sim_continue(c, drive, cmds, n_cmds, &s, n_steps, out, res);
}

ls_status ls_sim_open_loop(const ls_sim_cfg *c, const double *seg_t, const double *seg_v, int64_t n_seg,
                           const ls_sim_out *out, ls_sim_result *res)
{
    const double tau = c->pole_pitch, kx = 2.0 * LS_SIM_PI / tau, h_max = 0.25 / c->f_pwm;
    double x = c->x0, v = c->motion == LS_SIM_HELD ? 0.0 : c->v0, i[2] = {0.0, 0.0}, t = 0.0;
    int64_t s;
    uint32_t fault = 0u;
    ls_sim_maps pm;
    ls_sim_coef pc;
    ls_sim_frozen fz;
    if (c == NULL || seg_t == NULL || seg_v == NULL || out == NULL || res == NULL || n_seg < 0) {
        return LS_ERR_NULL;
    }
    if (ls_sim_check(c) != LS_OK) {
        return LS_ERR_PARAM;
    }
    memset(res, 0, sizeof *res);
    ls_sim_coef_init(c, &pc);
    for (s = 0; s < n_seg && fault == 0u; ++s) {
        double h = seg_t[s], v_ab[2], f_start;
        if (!(LS_ISFINITE(h) && h >= 0.0) || !LS_ISFINITE(seg_v[3 * s]) || !LS_ISFINITE(seg_v[3 * s + 1]) || !LS_ISFINITE(seg_v[3 * s + 2])) {
            return LS_ERR_PARAM;
        }
        f_start = ls_sim_force_at(c, &pc, kx * x, i);
        ls_sim_record(out, s, t, x, v, i, cos(kx * x), sin(kx * x), &seg_v[3 * s], f_start, NULL, tau, kx, fault);
        ls_sim_poles_to_ab(&seg_v[3 * s], v_ab);
        {
            /* segments longer than a quarter PWM period are split, each sub-step frozen at its
             * own mid position, so long open-loop segments stay accurate while moving */
            int32_t n = h > h_max ? (int32_t)ceil(h / h_max) : 1, q;
            double hs = h / (double)n;
            for (q = 0; q < n && fault == 0u; ++q) {
                double fa, fb;
                if (c->sat.on) { /* the saturated plant: frozen at the sub-step's mid angle */
                    ls_sim_sat_frame sf;
                    ls_sim_sat_point sp;
                    ls_sim_sat_frame_at(c, kx * (x + 0.5 * hs * v), &sf);
                    ls_sim_sat_at(c, &sf, i, &sp);
                    fa = sp.force;
                    if (!ls_sim_sat_step(c, &sf, v_ab, hs, -0.5 * kx * v * hs, kx * v, i, &sp)) {
                        fault |= LS_SIM_FAULT_DIVERGED;
                        break;
                    }
                    fb = sp.force;
                    ls_sim_mechanics(c, &pc, t + (double)q * hs, hs, 0.5 * (fa + fb), &x, &v);
                    continue;
                }
                ls_sim_maps_at(c, &pc, kx * (x + 0.5 * hs * v), &pm);
                if (!ls_sim_freeze(c, &pm, kx * v, &fz)) {
                    fault |= LS_SIM_FAULT_DIVERGED;
                    break;
                }
                fa = ls_sim_force_of(&pc, &pm, i);
                ls_sim_propagate(&fz, v_ab, hs, i);
                fb = ls_sim_force_of(&pc, &pm, i);
                ls_sim_mechanics(c, &pc, t + (double)q * hs, hs, 0.5 * (fa + fb), &x, &v);
            }
        }
        t += h;
        if (!plant_ok(c, i, x, v)) {
            fault |= LS_SIM_FAULT_DIVERGED;
            break;
        }
    }
    {
        double last[3] = {NAN, NAN, NAN};
        if (LS_ISFINITE(x) && LS_ISFINITE(i[0]) && LS_ISFINITE(i[1])) {
            ls_sim_record(out, s, t, x, v, i, cos(kx * x), sin(kx * x), last, ls_sim_force_at(c, &pc, kx * x, i), NULL,
                          tau, kx, fault);
        } else {
            ls_sim_record(out, s, t, x, v, i, 1.0, 0.0, last, NAN, NULL, tau, kx, fault);
        }
    }
    res->steps_done = s;
    res->n_rec = s + 1;
    res->fault = fault;
    res->x_end = x;
    res->v_end = v;
    return LS_OK;
}
