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
    for (k = 0; k < 3; ++k) { /* (a phase's PM flux at least reverses no sign: scale > 0) */
        if (!(LS_ISFINITE(c->pm_dscale[k]) && c->pm_dscale[k] > -1.0) || !LS_ISFINITE(c->pm_shift[k])) {
            return LS_ERR_PARAM;
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

/* ------------------------------------------------------------------------------ the time loop
 * continue_impl runs the periods; each concern of a period is a helper below, always inlined into
 * it (LS_SIM_INLINE), so that the compiler still sees one loop: the run's state (sim_loop) and the
 * recording (sim_rec) are locals it keeps in registers, and the unity build's arithmetic (with
 * -ffp-contract=fast, fused across the inlined calls) is that of one function. */

/* the run's state between periods: ls_sim_state's running fields, in a local during a call */
typedef struct {
    double x, v;                 /* m, m/s: position and speed */
    double i[2];                 /* A, alpha-beta currents */
    double duty[3];              /* -, the duties acting this period (the controller's, one period back) */
    double x_lag, v_lag, v_lag2; /* m, m/s: x and v one period back, v two back */
    uint64_t rng;                /* -, the sensors' noise generator */
    int32_t next;                /* -, the next command */
    int32_t rec_count;           /* -, periods before the next recorded sample */
    uint32_t fault;              /* -, LS_SIM_FAULT_* and the drive's fault bits */
    angle_track ang;             /* rad, -: cos and sin of the mid-period angle */
    ls_sim_carry carry;          /* the inverter's carry into the next period */
    ls_pos est_pos;              /* -, the drive's estimate for this period's sample (the last step's) */
    LS_REAL est_v;               /* m/s, its speed */
    int32_t est_have;            /* -, 1: est_pos holds one */
} sim_loop;

/* the recording of one call: its samples and the block statistics of the one being recorded */
typedef struct {
    ls_sim_block acc; /* the open block */
    int64_t r;        /* -, samples recorded in this call */
    bool blk;         /* -, block statistics asked (some of ls_sim_out x_min ... i_abc_max) */
    bool blk_err;     /* -, their theta_err among them */
} sim_rec;

/* the call's arguments checked; the recording opened (rc) and the result set from the state */
LS_SIM_INLINE ls_status call_begin(const ls_sim_cfg *c, const ls_drive *drive, const ls_sim_cmd *cmds,
                                   int32_t n_cmds, const ls_sim_state *s, int64_t n_more, const ls_sim_out *out,
                                   ls_sim_result *res, sim_rec *rc)
{
    if (c == NULL || drive == NULL || s == NULL || out == NULL || res == NULL || (n_cmds > 0 && cmds == NULL) ||
        n_more < 0) {
        return LS_ERR_NULL;
    }
    if (ls_sim_check(c) != LS_OK) {
        return LS_ERR_PARAM;
    }
    rc->blk_err = out->err_min != NULL || out->err_max != NULL || out->err_mean != NULL;
    rc->blk = rc->blk_err || out->x_min != NULL || out->x_max != NULL || out->x_mean != NULL ||
              out->i_abc_min != NULL || out->i_abc_max != NULL;
    if (rc->blk && !s->ended && s->rec_count != 1) { /* a block begun in the previous call */
        return LS_ERR_PARAM;
    }
    memset(res, 0, sizeof *res);
    res->steps_done = s->k;
    res->fault = s->fault;
    res->x_end = s->x;
    res->v_end = s->v;
    rc->acc.r = -1;
    rc->acc.n = 0;
    rc->r = 0;
    return LS_OK;
}

/* the state in locals for the time loop (registers) */
LS_SIM_INLINE void loop_load(const ls_sim_state *s, sim_loop *L)
{
    int32_t j;
    L->x = s->x;
    L->v = s->v;
    L->i[0] = s->i[0];
    L->i[1] = s->i[1];
    L->x_lag = s->x_lag;
    L->v_lag = s->v_lag;
    L->v_lag2 = s->v_lag2;
    L->rng = s->rng;
    L->next = s->next;
    L->rec_count = s->rec_count;
    L->fault = s->fault;
    for (j = 0; j < 3; ++j) {
        L->duty[j] = s->duty[j];
        L->carry.t[j] = s->carry_t[j];
        L->carry.on[j] = s->carry_on[j];
        L->carry.excess[j] = s->carry_excess[j];
    }
    L->carry.any_excess = s->carry_any != 0;
    L->ang.th = s->ang_th;
    L->ang.c = s->ang_c;
    L->ang.s = s->ang_s;
    L->ang.left = s->ang_left;
    L->est_pos = s->est_pos;
    L->est_v = s->est_v;
    L->est_have = s->est_have;
}

/* the locals written back at the end of a call after step k, r samples recorded; the result */
LS_SIM_INLINE void loop_store(const sim_loop *L, int64_t k, int64_t r, ls_sim_state *s, ls_sim_result *res)
{
    int32_t j;
    s->k = k;
    s->n_rec += r;
    s->fault = L->fault;
    s->x = L->x;
    s->v = L->v;
    s->i[0] = L->i[0];
    s->i[1] = L->i[1];
    s->x_lag = L->x_lag;
    s->v_lag = L->v_lag;
    s->v_lag2 = L->v_lag2;
    s->rng = L->rng;
    s->next = L->next;
    s->rec_count = L->rec_count;
    for (j = 0; j < 3; ++j) {
        s->duty[j] = L->duty[j];
        s->carry_t[j] = L->carry.t[j];
        s->carry_on[j] = L->carry.on[j];
        s->carry_excess[j] = L->carry.excess[j];
    }
    s->carry_any = L->carry.any_excess ? 1 : 0;
    s->ang_th = L->ang.th;
    s->ang_c = L->ang.c;
    s->ang_s = L->ang.s;
    s->ang_left = L->ang.left;
    s->est_pos = L->est_pos;
    s->est_v = L->est_v;
    s->est_have = L->est_have;
    res->steps_done = k;
    res->n_rec = r;
    res->fault = L->fault;
    res->x_end = L->x;
    res->v_end = L->v;
}

/* the commands due at time t (s) given to the drive; next: the first not yet given */
LS_SIM_INLINE void give_commands(ls_drive *drive, const ls_sim_cmd *cmds, int32_t n_cmds, int32_t *next, double t,
                                 double tau)
{
    while (*next < n_cmds && cmds[*next].t <= t) {
        if (cmds[*next].move) {
            ls_drive_move_to(drive, ls_sim_pos_of_m(cmds[*next].x, tau));
        } else {
            ls_drive_step_to(drive, ls_sim_pos_of_m(cmds[*next].x, tau));
        }
        (*next)++;
    }
}

/* The plant frozen over this period at the mid-period angle th_mid and electrical speed om (its
 * maps pm, its system fz; on the saturated plant its frame sf, the system linearised at the
 * period-start currents: L = d lambda/d i, the EMF omega d lambda/d theta frozen); returns the
 * force at the period start. */
LS_SIM_INLINE double plant_freeze(const ls_sim_cfg *c, const ls_sim_coef *q, const bool sat, sim_loop *L,
                                  double th_mid, double om, ls_sim_maps *pm, ls_sim_frozen *fz, ls_sim_sat_frame *sf)
{
    double f_start;
    if (!sat) {
        ls_sim_maps_cs(c, q, th_mid, L->ang.c, L->ang.s, pm);
        if (!ls_sim_freeze(c, pm, om, fz)) {
            L->fault |= LS_SIM_FAULT_DIVERGED;
        }
        f_start = ls_sim_force_of(q, pm, L->i);
    } else {
        ls_sim_sat_point sp;
        ls_sim_sat_frame_at(c, q, th_mid, sf);
        ls_sim_sat_at(c, sf, L->i, &sp);
        memcpy(pm->l, sp.l, sizeof pm->l);
        pm->dl[0] = pm->dl[1] = pm->dl[2] = 0.0;
        memcpy(pm->lpm, sp.lam, sizeof pm->lpm);
        memcpy(pm->dlpm, sp.dlam, sizeof pm->dlpm);
        if (!ls_sim_freeze(c, pm, om, fz)) {
            L->fault |= LS_SIM_FAULT_DIVERGED;
        }
        f_start = sp.force;
    }
    return f_start;
}

/* the block being recorded written; the next opened at the sample (x, i) */
LS_SIM_INLINE void block_next(const ls_sim_out *out, sim_rec *rc, const ls_cmd *cmd, double x, const double i[2],
                              double tau, double kx)
{
    ls_sim_block_write(out, &rc->acc);
    ls_sim_block_open(&rc->acc, rc->r, x, rc->blk_err ? ls_sim_est_err(cmd, x, tau, kx) : 0.0, i);
}

/* The period-start state recorded every c->decimate periods (a sample at time t, its angle the
 * mid-period one's turned back by a small rotation, |dl| < 1e-2 rad, series exact to 1e-13, with
 * the duties u and the force f_start), and added to the block statistics every period. */
LS_SIM_INLINE void record_period(const ls_sim_cfg *c, const ls_sim_out *out, sim_rec *rc, sim_loop *L,
                                 const ls_cmd *cmd, double t, double x_mid, const double u[3], double f_start,
                                 double tau, double kx)
{
    if (--L->rec_count == 0) {
        const double cm = L->ang.c, sm = L->ang.s;
        double dl, cd, sd;
        L->rec_count = c->decimate;
        dl = kx * (L->x - x_mid);
        cd = 1.0 - 0.5 * dl * dl * (1.0 - dl * dl * (1.0 / 12.0));
        sd = dl * (1.0 - dl * dl * (1.0 / 6.0) * (1.0 - dl * dl * (1.0 / 20.0)));
        if (rc->blk) { /* the previous sample's block is complete; this sample opens the next */
            block_next(out, rc, cmd, L->x, L->i, tau, kx);
        }
        ls_sim_record(out, rc->r++, t, L->x, L->v, L->i, cm * cd - sm * sd, sm * cd + cm * sd, u, f_start, cmd, tau,
                      kx, L->fault);
    } else if (rc->blk) {
        ls_sim_block_add(&rc->acc, L->x, rc->blk_err ? ls_sim_est_err(cmd, L->x, tau, kx) : 0.0, L->i);
    }
}

/* The currents over one period of h with the duties u (the inverter's model, the plant frozen:
 * pm, fz, sf, om); returns the motor force's average over the period (f_start at its start). */
LS_SIM_INLINE double propagate(const ls_sim_cfg *c, const ls_sim_coef *q, const bool sat, sim_loop *L,
                               const ls_sim_maps *pm, const ls_sim_frozen *fz, const ls_sim_sat_frame *sf, double om,
                               const double u[3], double h, double f_start)
{
    double f_avg;
    bool bad = false;
    if (c->fidelity == LS_SIM_SWITCHING) {
        double f_int;
        if (sat) {
            ls_sim_period_switching_sat(c, q, fz, u, h, L->i, &f_int, &L->carry, sf, om, &bad);
        } else {
            ls_sim_period_switching(c, q, fz, pm, u, h, L->i, &f_int, &L->carry);
        }
        f_avg = f_int / h;
    } else if (sat) {
        double f_end;
        bad = !ls_sim_period_average_sat(c, q, fz, sf, om, u, h, L->i, &L->carry, &f_end);
        f_avg = 0.5 * (f_start + f_end);
    } else {
        ls_sim_period_average(c, q, fz, u, h, L->i, &L->carry);
        f_avg = 0.5 * (f_start + ls_sim_force_of(q, pm, L->i));
    }
    if (bad) {
        L->fault |= LS_SIM_FAULT_DIVERGED;
    }
    return f_avg;
}

/* the controller's duties for the next period (0.5 each, no voltage, when it disables the bridge) */
LS_SIM_INLINE void next_duties(const ls_cmd *cmd, double duty[3])
{
    if (cmd->enable) {
        duty[0] = (double)cmd->duty[0];
        duty[1] = (double)cmd->duty[1];
        duty[2] = (double)cmd->duty[2];
    } else {
        duty[0] = duty[1] = duty[2] = 0.5;
    }
}

/* The plant's state at the period end checked (finite, below the abort current, within the travel);
 * false when that adds a fault */
LS_SIM_INLINE bool plant_checked(const ls_sim_cfg *c, sim_loop *L)
{
    if (!plant_ok(c, L->i, L->x, L->v)) {
        L->fault |= LS_SIM_FAULT_DIVERGED;
    } else if (L->x < c->x_min || L->x > c->x_max) {
        L->fault |= LS_SIM_FAULT_TRAVEL;
    }
    return L->fault == 0u;
}

/* the state that tripped recorded at time t (a block of its own) */
LS_SIM_INLINE void record_trip(const ls_sim_cfg *c, const ls_sim_coef *q, const ls_sim_out *out, sim_rec *rc,
                               const sim_loop *L, const ls_cmd *cmd, double t, double tau, double kx)
{
    double nan3[3] = {NAN, NAN, NAN}, f_end = NAN;
    if (LS_ISFINITE(L->i[0]) && LS_ISFINITE(L->i[1]) && LS_ISFINITE(L->x)) {
        f_end = ls_sim_force_at(c, q, kx * L->x, L->i);
    }
    if (rc->blk) {
        block_next(out, rc, cmd, L->x, L->i, tau, kx);
    }
    ls_sim_record(out, rc->r++, t, L->x, L->v, L->i, cos(kx * L->x), sin(kx * L->x), nan3, f_end, cmd, tau, kx,
                  L->fault);
}

LS_SIM_INLINE ls_status continue_impl(const ls_sim_cfg *c, ls_drive *drive, const ls_sim_cmd *cmds, int32_t n_cmds,
                                      ls_sim_state *s, int64_t n_more, const ls_sim_out *out, ls_sim_result *res,
                                      const bool sat)
{
    const double h = 1.0 / c->f_pwm, tau = c->pole_pitch, kx = 2.0 * LS_SIM_PI / tau;
    int64_t k, k_end;
    ls_meas meas;
    ls_cmd cmd, rec;
    ls_sim_maps pm;
    ls_sim_coef q;
    ls_sim_frozen fz;
    ls_sim_sat_frame sf;
    sim_loop L;
    sim_rec rc;
    ls_status st = call_begin(c, drive, cmds, n_cmds, s, n_more, out, res, &rc);
    if (st != LS_OK || s->ended) {
        return st;
    }
    loop_load(s, &L);
    ls_sim_coef_init(c, &q);
    memset(&cmd, 0, sizeof cmd);
    k_end = s->k + n_more;
    for (k = s->k; k < k_end; ++k) {
        double t = (double)k * h, x_mid, f_start, f_avg, u[3], th_mid, om;
        if (k % LS_SIM_STOP_POLL == 0 && out->stop != NULL && *out->stop != 0) {
            L.fault |= LS_SIM_FAULT_STOPPED;
            break;
        }
        give_commands(drive, cmds, n_cmds, &L.next, t, tau);
        /* sample at the carrier peak, run the controller; its duties act next period */
        ls_sim_measure(c, &q, L.i, L.x, drive->mode == LS_MODE_SENSORED || drive->mode == LS_MODE_CALIBRATION, &L.rng,
                       &meas);
        if (!L.est_have) { /* (the run's first sample: the observer's estimate before any step) */
            L.est_pos = drive->obs.pos;
            L.est_v = ls_observer_speed(&drive->obs);
            L.est_have = 1;
        }
        ls_drive_step(drive, &meas, &cmd);
        L.fault |= cmd.fault;
        /* the sample's estimate: the one the drive held for it (the last step's cmd.pos_est, its
         * estimate for the next sample; every observer steps ahead), against the position now */
        rec = cmd;
        rec.pos_est = L.est_pos;
        rec.v_est = L.est_v;
        L.est_pos = cmd.pos_est;
        L.est_v = cmd.v_est;
        L.est_have = 1;
        u[0] = L.duty[0]; u[1] = L.duty[1]; u[2] = L.duty[2];
        /* the plant over this period with the duties computed one period earlier, frozen at the
         * mid-period position predicted from the state one period back (exact for a constant
         * acceleration; see ls_sim.h), so that this period's matrices do not wait for the last
         * period's force; cos and sin tracked from the previous period; the speed at mid-period
         * likewise (exact for a constant acceleration) */
        x_mid = k == 0 ? L.x + 0.5 * h * L.v : L.x_lag + h * (2.5 * L.v_lag - L.v_lag2);
        th_mid = kx * x_mid;
        angle_to(&L.ang, th_mid);
        om = kx * (1.5 * L.v - 0.5 * L.v_lag);
        f_start = plant_freeze(c, &q, sat, &L, th_mid, om, &pm, &fz, &sf);
        record_period(c, out, &rc, &L, &rec, t, x_mid, u, f_start, tau, kx);
        if (L.fault != 0u || cmd.cal_done) { /* a calibration run ends with the calibration */
            s->ended = 1;
            break;
        }
        f_avg = propagate(c, &q, sat, &L, &pm, &fz, &sf, om, u, h, f_start);
        L.x_lag = L.x;
        L.v_lag2 = L.v_lag;
        L.v_lag = L.v;
        ls_sim_mechanics(c, &q, t, h, f_avg, &L.x, &L.v);
        next_duties(&cmd, L.duty);
        if (!plant_checked(c, &L)) { /* record the state that tripped, then stop */
            record_trip(c, &q, out, &rc, &L, &cmd, t + h, tau, kx);
            k++;
            s->ended = 1;
            break;
        }
    }
    if (L.fault & LS_SIM_FAULT_STOPPED) {
        s->ended = 1;
    }
    if (rc.blk) {
        ls_sim_block_write(out, &rc.acc); /* complete when the call ends where a block does, or the run ends */
    }
    loop_store(&L, k, rc.r, s, res);
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
                    ls_sim_sat_frame_at(c, &pc, kx * (x + 0.5 * hs * v), &sf);
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
