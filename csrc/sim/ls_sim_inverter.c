/* linsense simulator, the 2-level inverter (ls_sim.h): one PWM period of the average or the switching
 * model on the linear or the saturated plant, with the dead time and what it carries into the next
 * period. Double precision. */
#include "ls_sim_internal.h"

/* Duty error of one leg over a period in the average model, -(dd/2) (sign i_on + sign i_off)
 * (dd = dead time / period), zero for a leg that does not switch, plus what the previous period
 * carried in, clamped so the duty stays in [0, 1] (an excess beyond 1 is carried on). With i_on,
 * i_off = i_mid -+ w the two signs add to 2 sign(i_mid), or cancel when the current crosses zero
 * between the edges (an edge current of exactly zero, a convention, counts as a crossing). */
LS_SIM_INLINE double leg_error(double d, double dd, double i_mid, double w, double e_in, double *excess, bool *any)
{
    double e = d < 1.0 ? e_in : 0.0, dn;
    if (d > 0.0 && d < 1.0) {
        e += fabs(i_mid) > fabs(w) ? -copysign(dd, i_mid) : 0.0;
    }
    dn = d + e;
    if (dn < 0.0 || dn > 1.0) { /* within the dead time of a rail: rare */
        if (dn > 1.0) {
            *excess = dn - 1.0;
            *any = true;
        }
        return (dn < 0.0 ? 0.0 : 1.0) - d;
    }
    return e;
}

/* PWM current ripple of phase j at the turn-on of its leg, relative to the straight line between
 * the period's end currents (centred PWM: at the turn-off it is the opposite): the flux of the pole
 * voltages less their period averages from the period start to t_on = (1 - d_j) T/2, pole k
 * contributing V_dc T/2 (max(0, d_k - d_j) - d_k (1 - d_j)), through the frozen L^-1 and projected
 * on phase j (the common mode does not reach a floating star). Negative: the leg's own pole is still
 * low. vh = V_dc T / 2. */
LS_SIM_INLINE double ripple_on(const ls_sim_frozen *f, const double duty[3], double vh, int j)
{
    double lam[3], la, lb, ia, ib;
    int k;
    for (k = 0; k < 3; ++k) {
        lam[k] = vh * ((duty[k] > duty[j] ? duty[k] - duty[j] : 0.0) - duty[k] * (1.0 - duty[j]));
    }
    la = (2.0 * lam[0] - lam[1] - lam[2]) * (1.0 / 3.0);
    lb = (lam[1] - lam[2]) * (1.0 / LS_SIM_SQRT3);
    ia = f->linv[0] * la + f->linv[1] * lb;
    ib = f->linv[2] * la + f->linv[3] * lb;
    return j == 0 ? ia : (j == 1 ? -0.5 * ia + 0.5 * LS_SIM_SQRT3 * ib : -0.5 * ia - 0.5 * LS_SIM_SQRT3 * ib);
}

/* Average model: one segment with the period-averaged dead-time error. Per leg, the upper switch
 * is commanded on at t_on = (1 - d)T/2 and off at t_off = (1 + d)T/2; the turn-on loses t_dead
 * when the current flows out (i > 0) and the turn-off gains t_dead when it flows in (i < 0), so the
 * duty error is exactly -(sign i(t_on) + sign i(t_off))/2 * t_dead/T, with the currents at the two
 * edges predicted linearly from the period start plus the PWM ripple there (ripple_on; the
 * switching model resolves them exactly): i_on, i_off = i_mid -+ (w - r_on). */
LS_SIM_HOT void ls_sim_period_average(const ls_sim_cfg *c, const ls_sim_coef *q, const ls_sim_frozen *f,
                                      const double duty[3], double h, double i[2], ls_sim_carry *carry)
{
    const double dd = q->d_dead, vdc = c->v_dc, i0 = i[0], i1 = i[1];
    double p[3] = {vdc * duty[0], vdc * duty[1], vdc * duty[2]}, v_ab[2], b0, b1;
    ls_sim_prop pp;
    ls_sim_prop_make(f, h, &pp);
    ls_sim_poles_to_ab(p, v_ab);
    b0 = f->linv[0] * v_ab[0] + f->linv[1] * v_ab[1] + f->be[0];
    b1 = f->linv[2] * v_ab[0] + f->linv[3] * v_ab[1] + f->be[1];
    ls_sim_prop_apply(&pp, b0, b1, i); /* without the dead time */
    if (dd > 0.0) {
        /* Per leg, the phase current mid-way between the edges (the period centre) and half
         * their distance times its slope (di/dt = M i + b at the period start), the duty error
         * e_j they cause, and its effect on the period's end current, linear in e: G = Gam L^-1
         * V_dc times the Clarke column of the leg. The Clarke rows and columns are written out,
         * not taken through ls_sim_ab_to_abc and ls_sim_poles_to_ab: built before the current is
         * known, they keep the current's dependency chain short (going through the helpers costs
         * about 4% of the simulator's time). */
        const double sq = 0.5 * LS_SIM_SQRT3, m0 = f->m[0], m1 = f->m[1], m2 = f->m[2], m3 = f->m[3];
        const double rb0 = -0.5 * m0 + sq * m2, rb1 = -0.5 * m1 + sq * m3, rbc = -0.5 * b0 + sq * b1;
        const double rc0 = -0.5 * m0 - sq * m2, rc1 = -0.5 * m1 - sq * m3, rcc = -0.5 * b0 - sq * b1;
        /* the edges of leg j are at (1 -+ d_j) h/2 */
        const double hh = 0.5 * h;
        const double g00 = vdc * (pp.gam[0] * f->linv[0] + pp.gam[1] * f->linv[2]);
        const double g01 = vdc * (pp.gam[0] * f->linv[1] + pp.gam[1] * f->linv[3]);
        const double g10 = vdc * (pp.gam[2] * f->linv[0] + pp.gam[3] * f->linv[2]);
        const double g11 = vdc * (pp.gam[2] * f->linv[1] + pp.gam[3] * f->linv[3]);
        const double sa = m0 * i0 + m1 * i1 + b0, sb = rb0 * i0 + rb1 * i1 + rbc, sc = rc0 * i0 + rc1 * i1 + rcc;
        const double ma = i0 + hh * sa, mb = -0.5 * i0 + sq * i1 + hh * sb, mc = -0.5 * i0 - sq * i1 + hh * sc;
        double in[3] = {0.0, 0.0, 0.0}, ea, eb, ec;
        if (carry->any_excess) { /* rare: what the last period carried in */
            int j;
            for (j = 0; j < 3; ++j) {
                in[j] = carry->excess[j];
                carry->excess[j] = 0.0;
            }
            carry->any_excess = false;
        }
        {
            const double vh = 0.5 * vdc * h;
            ea = leg_error(duty[0], dd, ma, hh * duty[0] * sa - ripple_on(f, duty, vh, 0), in[0], &carry->excess[0],
                           &carry->any_excess);
            eb = leg_error(duty[1], dd, mb, hh * duty[1] * sb - ripple_on(f, duty, vh, 1), in[1], &carry->excess[1],
                           &carry->any_excess);
            ec = leg_error(duty[2], dd, mc, hh * duty[2] * sc - ripple_on(f, duty, vh, 2), in[2], &carry->excess[2],
                           &carry->any_excess);
        }
        const double ka0 = g00 * (2.0 / 3.0), ka1 = g10 * (2.0 / 3.0);
        const double kb0 = g01 * (1.0 / LS_SIM_SQRT3) - g00 * (1.0 / 3.0),
                     kb1 = g11 * (1.0 / LS_SIM_SQRT3) - g10 * (1.0 / 3.0);
        const double kc0 = -g01 * (1.0 / LS_SIM_SQRT3) - g00 * (1.0 / 3.0),
                     kc1 = -g11 * (1.0 / LS_SIM_SQRT3) - g10 * (1.0 / 3.0);
        i[0] += ka0 * ea + kb0 * eb + kc0 * ec;
        i[1] += ka1 * ea + kb1 * eb + kc1 * ec;
    }
}

/* Average model on the saturated plant: the duty errors of ls_sim_period_average, predicted from the same
 * frozen linearisation (here d lambda/d i at the period start), applied as pole-voltage errors over
 * the period, which the linear plant's correction i += G e is exactly; then one ls_sim_sat_step. f_end:
 * the force at the period end. False: the plant diverged. */
LS_SIM_INTERNAL bool ls_sim_period_average_sat(const ls_sim_cfg *c, const ls_sim_coef *q, const ls_sim_frozen *f,
                                               const ls_sim_sat_frame *sf, double omega, const double duty[3],
                                               double h, double i[2], ls_sim_carry *carry, double *f_end)
{
    const double dd = q->d_dead, vdc = c->v_dc, i0 = i[0], i1 = i[1];
    double p[3] = {vdc * duty[0], vdc * duty[1], vdc * duty[2]}, v_ab[2];
    ls_sim_sat_point sp;
    bool ok;
    ls_sim_poles_to_ab(p, v_ab);
    if (dd > 0.0) {
        const double b0 = f->linv[0] * v_ab[0] + f->linv[1] * v_ab[1] + f->be[0];
        const double b1 = f->linv[2] * v_ab[0] + f->linv[3] * v_ab[1] + f->be[1];
        const double sq = 0.5 * LS_SIM_SQRT3, m0 = f->m[0], m1 = f->m[1], m2 = f->m[2], m3 = f->m[3];
        const double rb0 = -0.5 * m0 + sq * m2, rb1 = -0.5 * m1 + sq * m3, rbc = -0.5 * b0 + sq * b1;
        const double rc0 = -0.5 * m0 - sq * m2, rc1 = -0.5 * m1 - sq * m3, rcc = -0.5 * b0 - sq * b1;
        const double hh = 0.5 * h, vh = 0.5 * vdc * h;
        const double sa = m0 * i0 + m1 * i1 + b0, sb = rb0 * i0 + rb1 * i1 + rbc, sc = rc0 * i0 + rc1 * i1 + rcc;
        const double ma = i0 + hh * sa, mb = -0.5 * i0 + sq * i1 + hh * sb, mc = -0.5 * i0 - sq * i1 + hh * sc;
        double in[3] = {0.0, 0.0, 0.0}, pe[3], dv[2];
        int j;
        if (carry->any_excess) {
            for (j = 0; j < 3; ++j) {
                in[j] = carry->excess[j];
                carry->excess[j] = 0.0;
            }
            carry->any_excess = false;
        }
        pe[0] = vdc * leg_error(duty[0], dd, ma, hh * duty[0] * sa - ripple_on(f, duty, vh, 0), in[0],
                                &carry->excess[0], &carry->any_excess);
        pe[1] = vdc * leg_error(duty[1], dd, mb, hh * duty[1] * sb - ripple_on(f, duty, vh, 1), in[1],
                                &carry->excess[1], &carry->any_excess);
        pe[2] = vdc * leg_error(duty[2], dd, mc, hh * duty[2] * sc - ripple_on(f, duty, vh, 2), in[2],
                                &carry->excess[2], &carry->any_excess);
        ls_sim_poles_to_ab(pe, dv);
        v_ab[0] += dv[0];
        v_ab[1] += dv[1];
    }
    ok = ls_sim_sat_step(c, sf, v_ab, h, -0.5 * omega * h, omega, i, &sp);
    *f_end = sp.force;
    return ok;
}

/* Switching model: gate commands at (1 -+ d) T/2, turn-on edges delayed by the dead time, the
 * diode picked by the current sign at the command instant. Returns the time-weighted force
 * integral over the period through *f_int (trapezoid per segment). */
LS_SIM_INLINE void switching_impl(const ls_sim_cfg *c, const ls_sim_coef *q, const ls_sim_frozen *f,
                                  const ls_sim_maps *pm, const double duty[3], double h, double i[2], double *f_int,
                                  ls_sim_carry *carry, const ls_sim_sat_frame *sf, double omega, bool *bad)
{
    double t = 0.0, p[3], cmd_t[6], edge_t[6], v_ab[2], iabc[3], f0, f1;
    int cmd_leg[6], cmd_on[6], edge_leg[6], edge_on[6];
    int n_cmd = 0, n_edge = 0, next_cmd = 0, j, k;
    const double td = c->dead_time;
    for (j = 0; j < 3; ++j) {
        double d = duty[j];
        p[j] = d >= 1.0 ? 1.0 : 0.0;
        if (d > 0.0 && d < 1.0) {
            cmd_t[n_cmd] = 0.5 * (1.0 - d) * h; cmd_leg[n_cmd] = j; cmd_on[n_cmd] = 1; n_cmd++;
            cmd_t[n_cmd] = 0.5 * (1.0 + d) * h; cmd_leg[n_cmd] = j; cmd_on[n_cmd] = 0; n_cmd++;
        }
    }
    /* an edge carried in from the previous period: the pole keeps its level until then */
    for (j = 0; j < 3; ++j) {
        if (carry->t[j] >= 0.0 && duty[j] < 1.0) {
            p[j] = carry->on[j] ? 0.0 : 1.0;
            edge_t[n_edge] = carry->t[j]; edge_leg[n_edge] = j; edge_on[n_edge] = carry->on[j]; n_edge++;
        }
        carry->t[j] = -1.0;
    }
    /* sort the (<= 6) commands by time */
    for (j = 1; j < n_cmd; ++j) {
        for (k = j; k > 0 && cmd_t[k] < cmd_t[k - 1]; --k) {
            double tt = cmd_t[k]; int tl = cmd_leg[k], to = cmd_on[k];
            cmd_t[k] = cmd_t[k - 1]; cmd_leg[k] = cmd_leg[k - 1]; cmd_on[k] = cmd_on[k - 1];
            cmd_t[k - 1] = tt; cmd_leg[k - 1] = tl; cmd_on[k - 1] = to;
        }
    }
    if (sf != NULL) { /* the saturated plant: f0 from its own force, each segment by ls_sim_sat_step */
        ls_sim_sat_point sp;
        ls_sim_sat_at(c, sf, i, &sp);
        f0 = sp.force;
    } else {
        f0 = ls_sim_force_of(q, pm, i);
    }
    *f_int = 0.0;
    for (;;) {
        /* the next event: a gate command or a delayed edge, whichever comes first */
        double t_next = h;
        int kind = 0, which = -1;
        if (next_cmd < n_cmd && cmd_t[next_cmd] < t_next) {
            t_next = cmd_t[next_cmd]; kind = 1; which = next_cmd;
        }
        for (k = 0; k < n_edge; ++k) {
            if (edge_t[k] < t_next) {
                t_next = edge_t[k]; kind = 2; which = k;
            }
        }
        if (t_next > t) {
            double pv[3] = {p[0] * c->v_dc, p[1] * c->v_dc, p[2] * c->v_dc};
            ls_sim_poles_to_ab(pv, v_ab);
            if (sf != NULL) {
                ls_sim_sat_point sp;
                if (!ls_sim_sat_step(c, sf, v_ab, t_next - t, omega * (t - 0.5 * h), omega, i, &sp)) {
                    *bad = true;
                }
                f1 = sp.force;
            } else {
                ls_sim_propagate(f, v_ab, t_next - t, i);
                f1 = ls_sim_force_of(q, pm, i);
            }
            *f_int += 0.5 * (f0 + f1) * (t_next - t);
            f0 = f1;
            t = t_next;
        }
        if (kind == 0) {
            break;
        }
        if (kind == 1) {
            int leg = cmd_leg[which], on = cmd_on[which];
            double delay;
            /* a new command for a leg supersedes its edge still pending in the dead time (a pulse
             * shorter than the dead time never reaches the pole) */
            for (k = 0; k < n_edge; ++k) {
                if (edge_leg[k] == leg) {
                    edge_t[k] = edge_t[n_edge - 1];
                    edge_leg[k] = edge_leg[n_edge - 1];
                    edge_on[k] = edge_on[n_edge - 1];
                    n_edge--;
                    break;
                }
            }
            ls_sim_ab_to_abc(i, iabc);
            /* turn-on of the upper switch: delayed when the current flows out (lower diode
             * conducting); turn-off: delayed when it flows in (upper diode conducting) */
            delay = on ? (iabc[leg] > 0.0 ? td : 0.0) : (iabc[leg] < 0.0 ? td : 0.0);
            next_cmd++;
            if (delay <= 0.0) {
                p[leg] = on ? 1.0 : 0.0;
            } else {
                edge_t[n_edge] = t + delay; edge_leg[n_edge] = leg; edge_on[n_edge] = on; n_edge++;
            }
        } else {
            p[edge_leg[which]] = edge_on[which] ? 1.0 : 0.0;
            edge_t[which] = edge_t[n_edge - 1];
            edge_leg[which] = edge_leg[n_edge - 1];
            edge_on[which] = edge_on[n_edge - 1];
            n_edge--;
        }
    }
    /* edges still pending at the period end happen in the next one */
    for (k = 0; k < n_edge; ++k) {
        carry->t[edge_leg[k]] = edge_t[k] - h;
        carry->on[edge_leg[k]] = edge_on[k];
    }
}

/* the two instances: the linear plant's (sf = NULL folded away, the code of before) and the
 * saturated plant's (segments by ls_sim_sat_step; bad: it diverged) */
LS_SIM_INTERNAL void ls_sim_period_switching(const ls_sim_cfg *c, const ls_sim_coef *q, const ls_sim_frozen *f,
                                             const ls_sim_maps *pm, const double duty[3], double h, double i[2],
                                             double *f_int, ls_sim_carry *carry)
{
    switching_impl(c, q, f, pm, duty, h, i, f_int, carry, NULL, 0.0, NULL);
}

LS_SIM_INTERNAL void ls_sim_period_switching_sat(const ls_sim_cfg *c, const ls_sim_coef *q, const ls_sim_frozen *f,
                                                 const double duty[3], double h, double i[2], double *f_int,
                                                 ls_sim_carry *carry, const ls_sim_sat_frame *sf, double omega,
                                                 bool *bad)
{
    switching_impl(c, q, f, NULL, duty, h, i, f_int, carry, sf, omega, bad);
}

