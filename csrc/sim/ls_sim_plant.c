/* linsense simulator, the linear plant (ls_sim.h): the L_ab(theta) and PM-flux maps, the force, and
 * the 2x2 electrical system frozen over a period with its 4th-order propagator. Double precision. */
#include "ls_sim_internal.h"

/* the per-run constants (ls_sim_coef) of the configuration */
LS_SIM_INTERNAL void ls_sim_coef_init(const ls_sim_cfg *c, ls_sim_coef *q)
{
    int32_t k, e;
    q->kf = 1.5 * 2.0 * LS_SIM_PI / c->pole_pitch;
    q->inv_mass = 1.0 / c->mass;
    q->d_dead = c->dead_time * c->f_pwm;
    q->lsb = c->adc_bits > 0 ? 2.0 * c->adc_range / (double)(1L << c->adc_bits) : 0.0;
    for (e = 0; e < 3; ++e) { /* n_order >= 1 after ls_sim_check; defined even before it */
        q->a[0][e] = 0.0;
        q->b[0][e] = 0.0;
        q->da[0][e] = 0.0;
        q->db[0][e] = 0.0;
    }
    for (k = 0; k < c->n_order; ++k) {
        for (e = 0; e < 3; ++e) {
            q->a[k][e] = c->lab_cos[e][k];
            q->b[k][e] = c->lab_sin[e][k];
            q->da[k][e] = (double)k * c->lab_sin[e][k];
            q->db[k][e] = -(double)k * c->lab_cos[e][k];
        }
    }
    q->pm_unbal = 0;
    for (e = 0; e < 3; ++e) {
        const double rho = c->pm_shift[e] - (double)e * (2.0 * LS_SIM_PI / 3.0);
        const double g = c->psi_pm * (1.0 + c->pm_dscale[e]);
        q->pm_unbal |= (c->pm_dscale[e] != 0.0 || c->pm_shift[e] != 0.0) ? 1 : 0;
        q->pm_rot[e][0] = g * cos(rho);
        q->pm_rot[e][1] = g * sin(rho);
        for (k = 0; k < c->n_pm && k < LS_SIM_MAX_PM; ++k) {
            const double arg = (double)c->pm_order[k] * rho + c->pm_phase[k];
            q->pm_hrot[k][e][0] = g * c->pm_amp[k] * cos(arg);
            q->pm_hrot[k][e][1] = g * c->pm_amp[k] * sin(arg);
        }
    }
}

/* the end effect on the magnets' flux (ls_sim.h, lambda_pm): each phase's PM flux and its theta
 * derivative, phase k's fundamental Re(R_k e^(j theta)) and harmonic j Re(H_jk e^(j n_j theta)) with
 * the rotations of ls_sim_coef (every harmonic, triplen ones included: they no longer cancel), then
 * the amplitude-invariant Clarke transform */
static void pm_flux_unbalanced(const ls_sim_cfg *c, const ls_sim_coef *q, double theta, double c1, double s1,
                               double lpm[2], double dlpm[2])
{
    double p[3], dp[3];
    int32_t k, j;
    for (k = 0; k < 3; ++k) {
        p[k] = q->pm_rot[k][0] * c1 - q->pm_rot[k][1] * s1;
        dp[k] = -(q->pm_rot[k][0] * s1 + q->pm_rot[k][1] * c1);
    }
    for (j = 0; j < c->n_pm; ++j) {
        const double n = (double)c->pm_order[j], cn = cos(n * theta), sn = sin(n * theta);
        for (k = 0; k < 3; ++k) {
            const double hr = q->pm_hrot[j][k][0], hi = q->pm_hrot[j][k][1];
            p[k] += hr * cn - hi * sn;
            dp[k] -= n * (hr * sn + hi * cn);
        }
    }
    ls_sim_poles_to_ab(p, lpm);
    ls_sim_poles_to_ab(dp, dlpm);
}

/* PM flux linkage (alpha-beta, Wb) and its theta derivative (Wb/rad) at theta (c1, s1: cos, sin) */
LS_SIM_HOT void ls_sim_pm_flux(const ls_sim_cfg *c, const ls_sim_coef *q, double theta, double c1, double s1,
                               double lpm[2], double dlpm[2])
{
    int32_t j;
    if (q->pm_unbal) {
        pm_flux_unbalanced(c, q, theta, c1, s1, lpm, dlpm);
        return;
    }
    lpm[0] = c->psi_pm * c1;
    lpm[1] = c->psi_pm * s1;
    dlpm[0] = -c->psi_pm * s1;
    dlpm[1] = c->psi_pm * c1;
    for (j = 0; j < c->n_pm; ++j) {
        /* phase a: psi_pm a_n cos(n th + phi); b, c shifted by -+2 pi/3 in th. Clarke of that
         * three-phase set: zero for triplen n, (cos, +sin) for n = 1 mod 3, (cos, -sin) for
         * n = 2 mod 3 */
        int32_t n = c->pm_order[j];
        double a = c->psi_pm * c->pm_amp[j], arg = (double)n * theta + c->pm_phase[j];
        double sg = (n % 3 == 1) ? 1.0 : ((n % 3 == 2) ? -1.0 : 0.0);
        if (sg == 0.0) {
            continue;
        }
        lpm[0] += a * cos(arg);
        lpm[1] += sg * a * sin(arg);
        dlpm[0] -= (double)n * a * sin(arg);
        dlpm[1] += sg * (double)n * a * cos(arg);
    }
}

LS_SIM_HOT void ls_sim_maps_cs(const ls_sim_cfg *c, const ls_sim_coef *q, double theta, double c1, double s1,
                               ls_sim_maps *m)
{
    double ck = c1, sk = s1;
    double l0 = q->a[0][0], l1 = q->a[0][1], l2 = q->a[0][2], d0 = 0.0, d1 = 0.0, d2 = 0.0;
    int32_t k;
    for (k = 1; k < c->n_order; ++k) {
        const double *a = q->a[k], *b = q->b[k], *da = q->da[k], *db = q->db[k];
        double cn = ck * c1 - sk * s1;
        l0 += a[0] * ck + b[0] * sk;
        l1 += a[1] * ck + b[1] * sk;
        l2 += a[2] * ck + b[2] * sk;
        d0 += da[0] * ck + db[0] * sk;
        d1 += da[1] * ck + db[1] * sk;
        d2 += da[2] * ck + db[2] * sk;
        sk = sk * c1 + ck * s1;
        ck = cn;
    }
    m->l[0] = l0;
    m->l[1] = l1;
    m->l[2] = l2;
    m->dl[0] = d0;
    m->dl[1] = d1;
    m->dl[2] = d2;
    ls_sim_pm_flux(c, q, theta, c1, s1, m->lpm, m->dlpm);
}

LS_SIM_INTERNAL void ls_sim_maps_at(const ls_sim_cfg *c, const ls_sim_coef *q, double theta, ls_sim_maps *m)
{
    ls_sim_maps_cs(c, q, theta, cos(theta), sin(theta), m);
}

void ls_sim_plant_eval(const ls_sim_cfg *cfg, double theta, double lab[3], double dlab[3], double lpm[2],
                       double dlpm[2])
{
    ls_sim_coef q;
    ls_sim_maps m;
    ls_sim_coef_init(cfg, &q);
    ls_sim_maps_at(cfg, &q, theta, &m);
    memcpy(lab, m.l, sizeof m.l);
    memcpy(dlab, m.dl, sizeof m.dl);
    memcpy(lpm, m.lpm, sizeof m.lpm);
    memcpy(dlpm, m.dlpm, sizeof m.dlpm);
}

LS_SIM_HOT double ls_sim_force_of(const ls_sim_coef *q, const ls_sim_maps *m, const double i[2])
{
    /* i' lambda_pm' + 1/2 i' L' i, factored as i0 u0 + i1 u1 */
    const double u0 = m->dlpm[0] + 0.5 * m->dl[0] * i[0] + m->dl[2] * i[1];
    const double u1 = m->dlpm[1] + 0.5 * m->dl[1] * i[1];
    return q->kf * (i[0] * u0 + i[1] * u1);
}

double ls_sim_force(const ls_sim_cfg *cfg, double theta, const double i_ab[2])
{
    ls_sim_coef q;
    ls_sim_maps m;
    if (cfg->sat.on) {
        double lam[2], l[3], dl[2], f;
        ls_sim_sat_eval(cfg, theta, i_ab, lam, l, dl, &f);
        return f;
    }
    ls_sim_coef_init(cfg, &q);
    ls_sim_maps_at(cfg, &q, theta, &m);
    return ls_sim_force_of(&q, &m, i_ab);
}

/* the force (N) at theta, either plant (the records outside the time loop) */
LS_SIM_INTERNAL double ls_sim_force_at(const ls_sim_cfg *c, const ls_sim_coef *q, double theta, const double i[2])
{
    ls_sim_maps m;
    if (c->sat.on) {
        ls_sim_sat_frame f;
        ls_sim_sat_point pt;
        ls_sim_sat_frame_at(c, q, theta, &f);
        ls_sim_sat_at(c, &f, i, &pt);
        return pt.force;
    }
    ls_sim_maps_at(c, q, theta, &m);
    return ls_sim_force_of(q, &m, i);
}

/* the 2x2 system of the period at the mid-period maps pm and speed omega (ls_sim_frozen) */
LS_SIM_HOT bool ls_sim_freeze(const ls_sim_cfg *c, const ls_sim_maps *pm, double omega, ls_sim_frozen *f)
{
    /* L^-1 = adj(L)/det: the products with the adjugate run alongside the division */
    const double l0 = pm->l[0], l1 = pm->l[1], l2 = pm->l[2];
    const double det = l0 * l1 - l2 * l2;
    const double a00 = c->r_s + omega * pm->dl[0], a01 = omega * pm->dl[2], a11 = c->r_s + omega * pm->dl[1];
    const double n0 = l1 * a00 - l2 * a01, n1 = l1 * a01 - l2 * a11;
    const double n2 = l0 * a01 - l2 * a00, n3 = l0 * a11 - l2 * a01;
    const double e0 = l1 * pm->dlpm[0] - l2 * pm->dlpm[1], e1 = l0 * pm->dlpm[1] - l2 * pm->dlpm[0];
    const double idet = 1.0 / det, mi = -idet, wi = -omega * idet;
    f->linv[0] = l1 * idet;
    f->linv[1] = -l2 * idet;
    f->linv[2] = f->linv[1];
    f->linv[3] = l0 * idet;
    f->m[0] = mi * n0;
    f->m[1] = mi * n1;
    f->m[2] = mi * n2;
    f->m[3] = mi * n3;
    f->be[0] = wi * e0;
    f->be[1] = wi * e1;
    return det > 0.0 && l0 > 0.0;
}

/* One interval h (at most a PWM period) of the frozen system with constant voltage v_ab,
 * i <- Phi i + Gam b, with A = h M and b = L^-1 v_ab + be:
 *   Phi = I + A + A^2/2 + A^3/6 + A^4/24,  Gam = h (I + A/2 + A^2/6 + A^3/24),
 * the 4th-order Taylor polynomial of the exact propagator (what RK4 computes for this linear
 * system; local error ~|A|^5/120, ~1e-6 per period at 16 kHz). For a 2x2 matrix,
 * A^2 = tau A - delta I (Cayley-Hamilton, tau = tr A, delta = det A), so both are alpha I + beta A
 * with scalar alpha, beta. The current enters through one matrix-vector product and the matrices
 * depend on the position only, so they are built off the current's critical path. */
LS_SIM_HOT void ls_sim_prop_make(const ls_sim_frozen *f, double h, ls_sim_prop *pp)
{
    const double a0 = h * f->m[0], a1 = h * f->m[1], a2 = h * f->m[2], a3 = h * f->m[3];
    const double tr = a0 + a3, dt = a0 * a3 - a1 * a2;
    /* A^2 = tr A - dt I, A^3 = (tr^2 - dt) A - tr dt I, A^4 = tr (tr^2 - 2 dt) A - dt (tr^2 - dt) I */
    const double t2 = tr * tr, e3 = t2 - dt;
    /* P = I + A/2 + A^2/6 + A^3/24 = p0 I + p1 A */
    const double p0 = 1.0 - dt * (1.0 / 6.0) - tr * dt * (1.0 / 24.0);
    const double p1 = 0.5 + tr * (1.0 / 6.0) + e3 * (1.0 / 24.0);
    /* Phi = I + A P = (1 - p1 dt) I + (p0 + p1 tr) A */
    const double f0 = 1.0 - p1 * dt, f1 = p0 + p1 * tr;
    pp->phi[0] = f0 + f1 * a0;
    pp->phi[1] = f1 * a1;
    pp->phi[2] = f1 * a2;
    pp->phi[3] = f0 + f1 * a3;
    pp->gam[0] = h * (p0 + p1 * a0);
    pp->gam[1] = h * p1 * a1;
    pp->gam[2] = h * p1 * a2;
    pp->gam[3] = h * (p0 + p1 * a3);
}

/* i <- Phi i + Gam b, b = L^-1 v_ab + be */
LS_SIM_HOT void ls_sim_prop_apply(const ls_sim_prop *pp, double b0, double b1, double i[2])
{
    double i0 = pp->phi[0] * i[0] + pp->phi[1] * i[1] + pp->gam[0] * b0 + pp->gam[1] * b1;
    double i1 = pp->phi[2] * i[0] + pp->phi[3] * i[1] + pp->gam[2] * b0 + pp->gam[3] * b1;
    i[0] = i0;
    i[1] = i1;
}

LS_SIM_INTERNAL void ls_sim_propagate(const ls_sim_frozen *f, const double v_ab[2], double h, double i[2])
{
    ls_sim_prop pp;
    ls_sim_prop_make(f, h, &pp);
    ls_sim_prop_apply(&pp, f->linv[0] * v_ab[0] + f->linv[1] * v_ab[1] + f->be[0],
                      f->linv[2] * v_ab[0] + f->linv[3] * v_ab[1] + f->be[1], i);
}
