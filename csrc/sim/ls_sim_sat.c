/* linsense simulator, the saturated plant (ls_sim_sat, ls_sim.h; docs/simulator.md, "Saturation"):
 * co-energy, flux linkage and force at a point, the currents from the flux by Newton's method, and one
 * RK4 interval on the flux. Double precision. */
#include "ls_sim_internal.h"

/* The saturated plant (ls_sim_sat, ls_sim.h): its position-dependent values frozen at one angle th
 * (once per PWM period or open-loop sub-step); within the period the angle th + dth enters to first
 * order, lambda(i, th + dth) = lambda(i, th) + dth d lambda/d theta (the error, dth^2 d2 lambda/d
 * theta2 with |dth| <= omega h/2, is ~1e-9 Wb at 0.2 m/s), like the linear plant's mid-period
 * freeze. */
LS_SIM_INTERNAL void ls_sim_sat_frame_at(const ls_sim_cfg *c, const ls_sim_coef *q, double theta,
                                         ls_sim_sat_frame *f)
{
    const ls_sim_sat *s = &c->sat;
    const double c1 = cos(theta), s1 = sin(theta);
    double ck = 1.0, sk = 0.0;
    int32_t k, p, e;
    f->th = theta;
    f->c = c1;
    f->s = s1;
    f->kf = 1.5 * 2.0 * LS_SIM_PI / c->pole_pitch;
    for (p = 0; p < LS_SIM_SAT_POW; ++p) {
        for (e = 0; e < 3; ++e) {
            f->v[p][e] = 0.0;
            f->dv[p][e] = 0.0;
        }
    }
    for (k = 0; k < s->n_order; ++k) {
        double cn = ck * c1 - sk * s1;
        for (p = 0; p < s->n_pow; ++p) {
            for (e = 0; e < 3; ++e) {
                const double a = s->dq_cos[p][e][k], b = s->dq_sin[p][e][k];
                f->v[p][e] += a * ck + b * sk;
                f->dv[p][e] += (double)k * (b * ck - a * sk);
            }
        }
        sk = sk * c1 + ck * s1;
        ck = cn;
    }
    ls_sim_pm_flux(c, q, theta, c1, s1, f->lpm, f->dlpm);
}

/* The d-axis saturation S(i_d) (A^2), S' = K (A) and S'' = k (-) (ls_sim.h). In u = (i_m + i_d)/a,
 * a = i_sat_d: k = g/(1 + u^2), K = g a (atan u - atan u0), S = g a^2 [u (atan u - atan u0) -
 * ln((1 + u^2)/(1 + u0^2))/2], g = 1 + u0^2 (so k(0) = 1), written with atan and log1p of the
 * differences so that a small i_d keeps its digits. */
static void sat_d(const ls_sim_sat *s, double id, double *S, double *K, double *k)
{
    double a, u0, u, g, dat;
    if (!(s->i_sat_d > 0.0)) {
        *S = 0.5 * id * id;
        *K = id;
        *k = 1.0;
        return;
    }
    a = s->i_sat_d;
    u0 = s->i_m / a;
    u = (s->i_m + id) / a;
    g = 1.0 + u0 * u0;
    dat = 1.0 + u * u0 > 0.0 ? atan((u - u0) / (1.0 + u * u0)) : atan(u) - atan(u0);
    *k = g / (1.0 + u * u);
    *K = g * a * dat;
    *S = g * a * a * (u * dat - 0.5 * log1p((u - u0) * (u + u0) / g));
}

/* the saturated plant at alpha-beta currents i and the frame's angle */
LS_SIM_INTERNAL void ls_sim_sat_at(const ls_sim_cfg *c, const ls_sim_sat_frame *f, const double i[2],
                                   ls_sim_sat_point *pt)
{
    const ls_sim_sat *s = &c->sat;
    const double cs = f->c, sn = f->s;
    const double id = cs * i[0] + sn * i[1], iq = -sn * i[0] + cs * i[1];
    double pw[LS_SIM_SAT_POW + 2];
    double a = 0.0, a1 = 0.0, a2 = 0.0, at = 0.0, a1t = 0.0;
    double b = 0.0, b1 = 0.0, bi = 0.0, bt = 0.0, bit = 0.0;
    double cc = 0.0, c1 = 0.0, c2 = 0.0, c1t = 0.0, c2t = 0.0;
    double S, K, kd, ld, lq, hdd, hdq, hqq, gd, gq, wt, ea, eb;
    int32_t p;
    pw[0] = 1.0;
    for (p = 1; p < LS_SIM_SAT_POW + 2; ++p) {
        pw[p] = pw[p - 1] * iq;
    }
    for (p = 0; p < s->n_pow; ++p) {
        const double A = f->v[p][0], dA = f->dv[p][0], B = f->v[p][1], dB = f->dv[p][1];
        const double C = f->v[p][2], dC = f->dv[p][2], q1 = 1.0 / (double)(p + 1), q2 = q1 / (double)(p + 2);
        a += A * pw[p];
        at += dA * pw[p];
        if (p >= 1) {
            a1 += (double)p * A * pw[p - 1];
            a1t += (double)p * dA * pw[p - 1];
            b1 += (double)p * B * pw[p - 1];
        }
        if (p >= 2) {
            a2 += (double)(p * (p - 1)) * A * pw[p - 2];
        }
        b += B * pw[p];
        bt += dB * pw[p];
        bi += B * pw[p + 1] * q1;
        bit += dB * pw[p + 1] * q1;
        cc += C * pw[p];
        c1 += C * pw[p + 1] * q1;
        c1t += dC * pw[p + 1] * q1;
        c2 += C * pw[p + 2] * q2;
        c2t += dC * pw[p + 2] * q2;
    }
    sat_d(s, id, &S, &K, &kd);
    /* dq flux (without the PM), incremental inductances, d lambda_dq/d theta at constant i_dq */
    ld = a * K + bi;
    lq = a1 * S + id * b + c1;
    hdd = a * kd;
    hdq = a1 * K + b;
    hqq = a2 * S + id * b1 + cc;
    /* at constant alpha-beta currents i_dq turns: d i_dq/d theta = (i_q, -i_d) */
    gd = at * K + bit + hdd * iq - hdq * id;
    gq = a1t * S + id * bt + c1t + hdq * iq - hqq * id;
    wt = at * S + id * bit + c2t + ld * iq - lq * id;
    /* to alpha-beta: lambda_ab = R lambda_dq, d/d theta = R (J lambda_dq + g), L = R H R' */
    ea = gd - lq;
    eb = gq + ld;
    pt->lam[0] = cs * ld - sn * lq + f->lpm[0];
    pt->lam[1] = sn * ld + cs * lq + f->lpm[1];
    pt->dlam[0] = cs * ea - sn * eb + f->dlpm[0];
    pt->dlam[1] = sn * ea + cs * eb + f->dlpm[1];
    pt->l[0] = cs * cs * hdd - 2.0 * cs * sn * hdq + sn * sn * hqq;
    pt->l[1] = sn * sn * hdd + 2.0 * cs * sn * hdq + cs * cs * hqq;
    pt->l[2] = cs * sn * (hdd - hqq) + (cs * cs - sn * sn) * hdq;
    pt->force = f->kf * (wt + i[0] * f->dlpm[0] + i[1] * f->dlpm[1]);
}

/* The currents i whose flux at th + dth is lam_t, by Newton's method from i (d lambda/d i as the
 * Jacobian; dth's share of it, ~1e-3 of it, only slows the convergence). pt: on entry the
 * evaluation at i (or within 1e-10 A of it), which makes the first step without evaluating; on
 * return the last evaluation. False when the inductance is not positive definite or Newton does
 * not converge. */
static bool sat_solve(const ls_sim_cfg *c, const ls_sim_sat_frame *f, double dth, const double lam_t[2],
                      double i[2], ls_sim_sat_point *pt)
{
    int it;
    for (it = 0; it < 20; ++it) {
        double r0, r1, det, d0, d1;
        if (it > 0) {
            ls_sim_sat_at(c, f, i, pt);
        }
        r0 = lam_t[0] - pt->lam[0] - dth * pt->dlam[0];
        r1 = lam_t[1] - pt->lam[1] - dth * pt->dlam[1];
        det = pt->l[0] * pt->l[1] - pt->l[2] * pt->l[2];
        if (!(det > 0.0 && pt->l[0] > 0.0)) {
            return false;
        }
        d0 = (pt->l[1] * r0 - pt->l[2] * r1) / det;
        d1 = (pt->l[0] * r1 - pt->l[2] * r0) / det;
        i[0] += d0;
        i[1] += d1;
        /* after a step this small the error left is below 1e-15 A (quadratic convergence) */
        if (fabs(d0) + fabs(d1) <= 1e-10) {
            return true;
        }
    }
    return false;
}

/* One interval h with constant alpha-beta voltage v: d lambda/dt = v - R i(lambda, theta), theta =
 * th + dth0 + omega t, by the classical RK4 on the flux (sub-steps keep h R / L below 0.2, so the
 * local error matches the linear plant's 4th-order propagator), the currents from the flux by
 * sat_solve. pt: the plant at the end. False: the plant left its valid range (diverged). */
LS_SIM_INTERNAL bool ls_sim_sat_step(const ls_sim_cfg *c, const ls_sim_sat_frame *f, const double v[2], double h,
                                     double dth0, double omega, double i[2], ls_sim_sat_point *pt)
{
    double l0[2], lt[2], k1[2], k2[2], k3[2], k4[2], ii[2], hs, tr, det;
    int32_t n, j;
    bool ok = true;
    ls_sim_sat_at(c, f, i, pt);
    tr = pt->l[0] + pt->l[1];
    det = pt->l[0] * pt->l[1] - pt->l[2] * pt->l[2];
    if (!(det > 0.0 && pt->l[0] > 0.0)) {
        return false;
    }
    /* smallest eigenvalue >= det / tr: RK4 sub-steps of at most 0.2 of the fastest L/R time
     * constant; beyond 1000 of them (a time constant below h / 5000: not a motor this plant can
     * integrate) the step is refused, which the caller reports as diverged, instead of being
     * integrated with too few sub-steps */
    hs = h * c->r_s * tr / det;
    if (!(hs <= 200.0)) {
        return false;
    }
    n = hs > 0.2 ? (int32_t)ceil(hs / 0.2) : 1;
    hs = h / (double)n;
    for (j = 0; j < n && ok; ++j) {
        const double d0 = dth0 + omega * hs * (double)j, dm = d0 + 0.5 * omega * hs, d1 = d0 + omega * hs;
        if (j > 0) {
            ls_sim_sat_at(c, f, i, pt);
        }
        l0[0] = pt->lam[0] + d0 * pt->dlam[0];
        l0[1] = pt->lam[1] + d0 * pt->dlam[1];
        k1[0] = v[0] - c->r_s * i[0];
        k1[1] = v[1] - c->r_s * i[1];
        ii[0] = i[0];
        ii[1] = i[1];
        lt[0] = l0[0] + 0.5 * hs * k1[0];
        lt[1] = l0[1] + 0.5 * hs * k1[1];
        ok = ok && sat_solve(c, f, dm, lt, ii, pt);
        k2[0] = v[0] - c->r_s * ii[0];
        k2[1] = v[1] - c->r_s * ii[1];
        lt[0] = l0[0] + 0.5 * hs * k2[0];
        lt[1] = l0[1] + 0.5 * hs * k2[1];
        ok = ok && sat_solve(c, f, dm, lt, ii, pt);
        k3[0] = v[0] - c->r_s * ii[0];
        k3[1] = v[1] - c->r_s * ii[1];
        lt[0] = l0[0] + hs * k3[0];
        lt[1] = l0[1] + hs * k3[1];
        ok = ok && sat_solve(c, f, d1, lt, ii, pt);
        k4[0] = v[0] - c->r_s * ii[0];
        k4[1] = v[1] - c->r_s * ii[1];
        lt[0] = l0[0] + hs * (1.0 / 6.0) * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]);
        lt[1] = l0[1] + hs * (1.0 / 6.0) * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]);
        ok = ok && sat_solve(c, f, d1, lt, ii, pt);
        i[0] = ii[0];
        i[1] = ii[1];
    }
    return ok;
}

void ls_sim_sat_eval(const ls_sim_cfg *cfg, double theta, const double i_ab[2], double lam[2], double l_inc[3],
                     double dlam[2], double *force)
{
    ls_sim_sat_frame f;
    ls_sim_sat_point pt;
    ls_sim_coef q;
    ls_sim_coef_init(cfg, &q);
    ls_sim_sat_frame_at(cfg, &q, theta, &f);
    ls_sim_sat_at(cfg, &f, i_ab, &pt);
    memcpy(lam, pt.lam, sizeof pt.lam);
    memcpy(l_inc, pt.l, sizeof pt.l);
    memcpy(dlam, pt.dlam, sizeof pt.dlam);
    *force = pt.force;
}

