/* linsense host-side simulator (see linsense/ls_sim.h). Double precision. */
#include <math.h>
#include <string.h>

#include "linsense/ls_sim.h"

#define SIM_PI 3.14159265358979323846
#define SQRT3 1.7320508075688772
#define GRAVITY 9.81

/* the time loop's helpers are inlined into it (GCC and Clang), so its state stays in registers */
#if defined(__GNUC__)
#define SIM_HOT static inline __attribute__((always_inline))
#else
#define SIM_HOT static inline
#endif

/* ------------------------------------------------------------------------------ plant maps */
/* Per-run constants of the plant: the L_ab series rearranged order-major for the inner loop (the
 * derivative's coefficients precomputed) and reciprocals kept out of the time loop. */
typedef struct {
    double a[LS_SIM_MAX_ORDER][3];  /* H, cos(k theta) coefficients of L_aa, L_bb, L_ab */
    double b[LS_SIM_MAX_ORDER][3];  /* H, sin(k theta) coefficients */
    double da[LS_SIM_MAX_ORDER][3]; /* H/rad, k b: cos(k theta) coefficients of dL/dtheta */
    double db[LS_SIM_MAX_ORDER][3]; /* H/rad, -k a: sin(k theta) coefficients of dL/dtheta */
    double kf;                      /* 1/m, (3/2) 2 pi/tau: the force factor of the co-energy */
    double inv_mass;                /* 1/kg */
    double d_dead;                  /* -, dead time / PWM period */
    double lsb;                     /* A, current ADC step (0: ideal) */
} plant_coef;

typedef struct {
    double l[3];    /* H, L_aa, L_bb, L_ab */
    double dl[3];   /* H/rad */
    double lpm[2];  /* Wb */
    double dlpm[2]; /* Wb/rad */
} plant_maps;

static void coef_init(const ls_sim_cfg *c, plant_coef *q)
{
    int32_t k, e;
    q->kf = 1.5 * 2.0 * SIM_PI / c->pole_pitch;
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
}

/* PM flux linkage (alpha-beta, Wb) and its theta derivative (Wb/rad) at theta (c1, s1: cos, sin) */
SIM_HOT void pm_flux(const ls_sim_cfg *c, double theta, double c1, double s1, double lpm[2], double dlpm[2])
{
    int32_t j;
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

SIM_HOT void maps_cs(const ls_sim_cfg *c, const plant_coef *q, double theta, double c1, double s1, plant_maps *m)
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
    pm_flux(c, theta, c1, s1, m->lpm, m->dlpm);
}

static void maps(const ls_sim_cfg *c, const plant_coef *q, double theta, plant_maps *m)
{
    maps_cs(c, q, theta, cos(theta), sin(theta), m);
}

void ls_sim_plant_eval(const ls_sim_cfg *cfg, double theta, double lab[3], double dlab[3], double lpm[2],
                       double dlpm[2])
{
    plant_coef q;
    plant_maps m;
    coef_init(cfg, &q);
    maps(cfg, &q, theta, &m);
    memcpy(lab, m.l, sizeof m.l);
    memcpy(dlab, m.dl, sizeof m.dl);
    memcpy(lpm, m.lpm, sizeof m.lpm);
    memcpy(dlpm, m.dlpm, sizeof m.dlpm);
}

SIM_HOT double force_of(const plant_coef *q, const plant_maps *m, const double i[2])
{
    /* i' lambda_pm' + 1/2 i' L' i, factored as i0 u0 + i1 u1 */
    const double u0 = m->dlpm[0] + 0.5 * m->dl[0] * i[0] + m->dl[2] * i[1];
    const double u1 = m->dlpm[1] + 0.5 * m->dl[1] * i[1];
    return q->kf * (i[0] * u0 + i[1] * u1);
}

/* ------------------------------------------------------------------------------ saturation */
/* The saturated plant (ls_sim_sat, ls_sim.h): its position-dependent values frozen at one angle th
 * (once per PWM period or open-loop sub-step); within the period the angle th + dth enters to first
 * order, lambda(i, th + dth) = lambda(i, th) + dth d lambda/d theta (the error, dth^2 d2 lambda/d
 * theta2 with |dth| <= omega h/2, is ~1e-9 Wb at 0.2 m/s), like the linear plant's mid-period
 * freeze. */
typedef struct {
    double th, c, s;              /* rad, -, -: the angle, its cos and sin */
    double v[LS_SIM_SAT_POW][3];  /* H/A^p, A_p, B_p, C_p at th */
    double dv[LS_SIM_SAT_POW][3]; /* H/A^p/rad, their theta derivatives */
    double lpm[2], dlpm[2];       /* Wb, Wb/rad: PM flux (alpha-beta) and its theta derivative */
    double kf;                    /* 1/m, (3/2) 2 pi/tau */
} sat_frame;

typedef struct {
    double lam[2];  /* Wb, flux linkage (alpha-beta, with the PM flux) */
    double l[3];    /* H, incremental inductance d lambda/d i: aa, bb, ab */
    double dlam[2]; /* Wb/rad, d lambda/d theta at constant alpha-beta currents */
    double force;   /* N */
} sat_point;

static void sat_frame_at(const ls_sim_cfg *c, double theta, sat_frame *f)
{
    const ls_sim_sat *s = &c->sat;
    const double c1 = cos(theta), s1 = sin(theta);
    double ck = 1.0, sk = 0.0;
    int32_t k, p, e;
    f->th = theta;
    f->c = c1;
    f->s = s1;
    f->kf = 1.5 * 2.0 * SIM_PI / c->pole_pitch;
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
    pm_flux(c, theta, c1, s1, f->lpm, f->dlpm);
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
static void sat_eval(const ls_sim_cfg *c, const sat_frame *f, const double i[2], sat_point *pt)
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
static bool sat_solve(const ls_sim_cfg *c, const sat_frame *f, double dth, const double lam_t[2], double i[2],
                      sat_point *pt)
{
    int it;
    for (it = 0; it < 20; ++it) {
        double r0, r1, det, d0, d1;
        if (it > 0) {
            sat_eval(c, f, i, pt);
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
static bool sat_step(const ls_sim_cfg *c, const sat_frame *f, const double v[2], double h, double dth0, double omega,
                     double i[2], sat_point *pt)
{
    double l0[2], lt[2], k1[2], k2[2], k3[2], k4[2], ii[2], hs, tr, det;
    int32_t n, j;
    bool ok = true;
    sat_eval(c, f, i, pt);
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
            sat_eval(c, f, i, pt);
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
    sat_frame f;
    sat_point pt;
    sat_frame_at(cfg, theta, &f);
    sat_eval(cfg, &f, i_ab, &pt);
    memcpy(lam, pt.lam, sizeof pt.lam);
    memcpy(l_inc, pt.l, sizeof pt.l);
    memcpy(dlam, pt.dlam, sizeof pt.dlam);
    *force = pt.force;
}

double ls_sim_force(const ls_sim_cfg *cfg, double theta, const double i_ab[2])
{
    plant_coef q;
    plant_maps m;
    if (cfg->sat.on) {
        double lam[2], l[3], dl[2], f;
        ls_sim_sat_eval(cfg, theta, i_ab, lam, l, dl, &f);
        return f;
    }
    coef_init(cfg, &q);
    maps(cfg, &q, theta, &m);
    return force_of(&q, &m, i_ab);
}

/* the force (N) at theta, either plant (the records outside the time loop) */
static double force_at(const ls_sim_cfg *c, const plant_coef *q, double theta, const double i[2])
{
    plant_maps m;
    if (c->sat.on) {
        sat_frame f;
        sat_point pt;
        sat_frame_at(c, theta, &f);
        sat_eval(c, &f, i, &pt);
        return pt.force;
    }
    maps(c, q, theta, &m);
    return force_of(q, &m, i);
}

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

/* ------------------------------------------------------------------------------ electrical */
/* The 2x2 system frozen over one period at the mid-period position:
 *   di/dt = M i + b,   M = -L^-1 (R I + omega L'),   b = L^-1 (v - omega lambda_pm')         */
typedef struct {
    double linv[4]; /* 1/H, L^-1 row-major */
    double m[4];    /* 1/s */
    double be[2];   /* A/s, -L^-1 omega lambda_pm' (the EMF part of b) */
} frozen;

SIM_HOT bool freeze(const ls_sim_cfg *c, const plant_maps *pm, double omega, frozen *f)
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
typedef struct {
    double phi[4]; /* -, row-major */
    double gam[4]; /* s, row-major */
} period_prop;

SIM_HOT void prop_make(const frozen *f, double h, period_prop *pp)
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
SIM_HOT void prop_apply(const period_prop *pp, double b0, double b1, double i[2])
{
    double i0 = pp->phi[0] * i[0] + pp->phi[1] * i[1] + pp->gam[0] * b0 + pp->gam[1] * b1;
    double i1 = pp->phi[2] * i[0] + pp->phi[3] * i[1] + pp->gam[2] * b0 + pp->gam[3] * b1;
    i[0] = i0;
    i[1] = i1;
}

static void propagate(const frozen *f, const double v_ab[2], double h, double i[2])
{
    period_prop pp;
    prop_make(f, h, &pp);
    prop_apply(&pp, f->linv[0] * v_ab[0] + f->linv[1] * v_ab[1] + f->be[0],
               f->linv[2] * v_ab[0] + f->linv[3] * v_ab[1] + f->be[1], i);
}

SIM_HOT void poles_to_ab(const double p[3], double v_ab[2])
{
    v_ab[0] = (2.0 * p[0] - p[1] - p[2]) * (1.0 / 3.0);
    v_ab[1] = (p[1] - p[2]) * (1.0 / SQRT3);
}

SIM_HOT void ab_to_abc(const double i[2], double abc[3])
{
    abc[0] = i[0];
    abc[1] = -0.5 * i[0] + 0.5 * SQRT3 * i[1];
    abc[2] = -0.5 * i[0] - 0.5 * SQRT3 * i[1];
}

/* ------------------------------------------------------------------------------ inverter */
/* What the dead time carries from one period into the next: a turn-off delayed past the period
 * end (only with a duty within the dead time of 1 and the current flowing in) keeps the pole high
 * into the next period. The switching model carries the pending edge, the average model the
 * excess duty. Nothing is carried into a period whose duty is 1 (the pole stays high anyway). */
typedef struct {
    double t[3];      /* s, switching: time into the next period of leg j's pending edge; < 0: none */
    int on[3];        /* -, switching: pole state that edge sets (1 high, 0 low) */
    double excess[3]; /* -, average: duty beyond 1 carried into the next period */
    bool any_excess;  /* -, average: some excess[j] != 0 */
} dead_carry;

static const dead_carry no_carry = {{-1.0, -1.0, -1.0}, {0, 0, 0}, {0.0, 0.0, 0.0}, false};

/* Duty error of one leg over a period in the average model, -(dd/2) (sign i_on + sign i_off)
 * (dd = dead time / period), zero for a leg that does not switch, plus what the previous period
 * carried in, clamped so the duty stays in [0, 1] (an excess beyond 1 is carried on). With i_on,
 * i_off = i_mid -+ w the two signs add to 2 sign(i_mid), or cancel when the current crosses zero
 * between the edges (an edge current of exactly zero, a convention, counts as a crossing). */
SIM_HOT double leg_error(double d, double dd, double i_mid, double w, double e_in, double *excess, bool *any)
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
SIM_HOT double ripple_on(const frozen *f, const double duty[3], double vh, int j)
{
    double lam[3], la, lb, ia, ib;
    int k;
    for (k = 0; k < 3; ++k) {
        lam[k] = vh * ((duty[k] > duty[j] ? duty[k] - duty[j] : 0.0) - duty[k] * (1.0 - duty[j]));
    }
    la = (2.0 * lam[0] - lam[1] - lam[2]) * (1.0 / 3.0);
    lb = (lam[1] - lam[2]) * (1.0 / SQRT3);
    ia = f->linv[0] * la + f->linv[1] * lb;
    ib = f->linv[2] * la + f->linv[3] * lb;
    return j == 0 ? ia : (j == 1 ? -0.5 * ia + 0.5 * SQRT3 * ib : -0.5 * ia - 0.5 * SQRT3 * ib);
}

/* Average model: one segment with the period-averaged dead-time error. Per leg, the upper switch
 * is commanded on at t_on = (1 - d)T/2 and off at t_off = (1 + d)T/2; the turn-on loses t_dead
 * when the current flows out (i > 0) and the turn-off gains t_dead when it flows in (i < 0), so the
 * duty error is exactly -(sign i(t_on) + sign i(t_off))/2 * t_dead/T, with the currents at the two
 * edges predicted linearly from the period start plus the PWM ripple there (ripple_on; the
 * switching model resolves them exactly): i_on, i_off = i_mid -+ (w - r_on). */
SIM_HOT void period_average(const ls_sim_cfg *c, const plant_coef *q, const frozen *f, const double duty[3],
                           double h, double i[2], dead_carry *carry)
{
    const double dd = q->d_dead, vdc = c->v_dc, i0 = i[0], i1 = i[1];
    double p[3] = {vdc * duty[0], vdc * duty[1], vdc * duty[2]}, v_ab[2], b0, b1;
    period_prop pp;
    prop_make(f, h, &pp);
    poles_to_ab(p, v_ab);
    b0 = f->linv[0] * v_ab[0] + f->linv[1] * v_ab[1] + f->be[0];
    b1 = f->linv[2] * v_ab[0] + f->linv[3] * v_ab[1] + f->be[1];
    prop_apply(&pp, b0, b1, i); /* without the dead time */
    if (dd > 0.0) {
        /* Per leg, the phase current mid-way between the edges (the period centre) and half
         * their distance times its slope (di/dt = M i + b at the period start), the duty error
         * e_j they cause, and its effect on the period's end current, linear in e: G = Gam L^-1
         * V_dc times the Clarke column of the leg. The Clarke rows and columns are written out,
         * not taken through ab_to_abc and poles_to_ab: built before the current is known, they
         * keep the current's dependency chain short (going through the helpers costs about 4%
         * of the simulator's time). */
        const double sq = 0.5 * SQRT3, m0 = f->m[0], m1 = f->m[1], m2 = f->m[2], m3 = f->m[3];
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
        const double kb0 = g01 * (1.0 / SQRT3) - g00 * (1.0 / 3.0), kb1 = g11 * (1.0 / SQRT3) - g10 * (1.0 / 3.0);
        const double kc0 = -g01 * (1.0 / SQRT3) - g00 * (1.0 / 3.0), kc1 = -g11 * (1.0 / SQRT3) - g10 * (1.0 / 3.0);
        i[0] += ka0 * ea + kb0 * eb + kc0 * ec;
        i[1] += ka1 * ea + kb1 * eb + kc1 * ec;
    }
}

/* Average model on the saturated plant: the duty errors of period_average, predicted from the same
 * frozen linearisation (here d lambda/d i at the period start), applied as pole-voltage errors over
 * the period, which the linear plant's correction i += G e is exactly; then one sat_step. f_end:
 * the force at the period end. False: the plant diverged. */
static bool period_average_sat(const ls_sim_cfg *c, const plant_coef *q, const frozen *f, const sat_frame *sf,
                               double omega, const double duty[3], double h, double i[2], dead_carry *carry,
                               double *f_end)
{
    const double dd = q->d_dead, vdc = c->v_dc, i0 = i[0], i1 = i[1];
    double p[3] = {vdc * duty[0], vdc * duty[1], vdc * duty[2]}, v_ab[2];
    sat_point sp;
    bool ok;
    poles_to_ab(p, v_ab);
    if (dd > 0.0) {
        const double b0 = f->linv[0] * v_ab[0] + f->linv[1] * v_ab[1] + f->be[0];
        const double b1 = f->linv[2] * v_ab[0] + f->linv[3] * v_ab[1] + f->be[1];
        const double sq = 0.5 * SQRT3, m0 = f->m[0], m1 = f->m[1], m2 = f->m[2], m3 = f->m[3];
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
        poles_to_ab(pe, dv);
        v_ab[0] += dv[0];
        v_ab[1] += dv[1];
    }
    ok = sat_step(c, sf, v_ab, h, -0.5 * omega * h, omega, i, &sp);
    *f_end = sp.force;
    return ok;
}

/* Switching model: gate commands at (1 -+ d) T/2, turn-on edges delayed by the dead time, the
 * diode picked by the current sign at the command instant. Returns the time-weighted force
 * integral over the period through *f_int (trapezoid per segment). */
SIM_HOT void switching_impl(const ls_sim_cfg *c, const plant_coef *q, const frozen *f, const plant_maps *pm,
                            const double duty[3], double h, double i[2], double *f_int, dead_carry *carry,
                            const sat_frame *sf, double omega, bool *bad)
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
    if (sf != NULL) { /* the saturated plant: f0 from its own force, each segment by sat_step */
        sat_point sp;
        sat_eval(c, sf, i, &sp);
        f0 = sp.force;
    } else {
        f0 = force_of(q, pm, i);
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
            poles_to_ab(pv, v_ab);
            if (sf != NULL) {
                sat_point sp;
                if (!sat_step(c, sf, v_ab, t_next - t, omega * (t - 0.5 * h), omega, i, &sp)) {
                    *bad = true;
                }
                f1 = sp.force;
            } else {
                propagate(f, v_ab, t_next - t, i);
                f1 = force_of(q, pm, i);
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
            ab_to_abc(i, iabc);
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
 * saturated plant's (segments by sat_step; bad: it diverged) */
static void period_switching(const ls_sim_cfg *c, const plant_coef *q, const frozen *f, const plant_maps *pm,
                             const double duty[3], double h, double i[2], double *f_int, dead_carry *carry)
{
    switching_impl(c, q, f, pm, duty, h, i, f_int, carry, NULL, 0.0, NULL);
}

static void period_switching_sat(const ls_sim_cfg *c, const plant_coef *q, const frozen *f, const double duty[3],
                                 double h, double i[2], double *f_int, dead_carry *carry, const sat_frame *sf,
                                 double omega, bool *bad)
{
    switching_impl(c, q, f, NULL, duty, h, i, f_int, carry, sf, omega, bad);
}

/* ------------------------------------------------------------------------------ sensors */
static uint64_t rng_next(uint64_t *s)
{
    uint64_t x = *s;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *s = x;
    return x * 2685821657736338717ull;
}

static double rng_gauss(uint64_t *s)
{
    double u1 = ((double)(rng_next(s) >> 11) + 0.5) * (1.0 / 9007199254740992.0);
    double u2 = (double)(rng_next(s) >> 11) * (1.0 / 9007199254740992.0);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * SIM_PI * u2);
}

SIM_HOT void measure(const ls_sim_cfg *c, const plant_coef *q, const double i_ab[2], double x, bool encoder,
                     uint64_t *rng, ls_meas *m)
{
    double iabc[3], u;
    int j;
    ab_to_abc(i_ab, iabc);
    for (j = 0; j < 3; ++j) {
        double y = c->i_gain[j] * iabc[j] + c->i_offset[j];
        if (c->i_noise > 0.0) {
            y += c->i_noise * rng_gauss(rng);
        }
        if (q->lsb > 0.0) {
            y = q->lsb * floor(y / q->lsb + 0.5);
            y = y > c->adc_range ? c->adc_range : (y < -c->adc_range ? -c->adc_range : y);
        }
        m->i_abc[j] = (LS_REAL)y;
    }
    m->v_dc = (LS_REAL)c->v_dc;
    m->enc_valid = true;
    m->enc_count = 0;
    if (encoder) { /* only modes that read it pay for the conversion */
        u = floor(x / c->pole_pitch * (double)c->enc_counts);
        /* a 32-bit counter: beyond its range (or a diverged plant's NaN) the count saturates, range-
         * checked before the conversion; the drive's plausibility check sees the jump */
        if (!(u >= -2147483648.0)) {
            u = -2147483648.0;
        } else if (u > 2147483647.0) {
            u = 2147483647.0;
        }
        m->enc_count = (int32_t)u;
    }
}

/* ------------------------------------------------------------------------------ mechanics */
SIM_HOT double load_force(const ls_sim_cfg *c, double t)
{
    switch (c->load) {
    case LS_SIM_LOAD_STEP:
        return t < c->load_t ? c->load_f0 : c->load_f1;
    case LS_SIM_LOAD_INCLINE:
        return c->load_f0 + c->mass * GRAVITY * sin(c->load_incline);
    case LS_SIM_LOAD_CONSTANT:
    default:
        return c->load_f0;
    }
}

/* advance x, v over h with the motor force average f_avg */
SIM_HOT void mechanics(const ls_sim_cfg *c, const plant_coef *q, double t, double h, double f_avg, double *x, double *v)
{
    double f_net, v_new;
    if (c->motion == LS_SIM_HELD) {
        *v = 0.0;
        return;
    }
    if (c->motion == LS_SIM_PRESCRIBED) {
        *x += c->v0 * h;
        *v = c->v0;
        return;
    }
    f_net = f_avg - load_force(c, t) - c->visc * *v;
    if (*v == 0.0 && fabs(f_net) <= c->coulomb) { /* stiction */
        return;
    }
    f_net -= c->coulomb * (*v > 0.0 ? 1.0 : (*v < 0.0 ? -1.0 : (f_net > 0.0 ? 1.0 : -1.0)));
    v_new = *v + f_net * q->inv_mass * h;
    if (c->coulomb > 0.0 && (*v) * v_new < 0.0) { /* friction cannot reverse the motion */
        v_new = 0.0;
    }
    *x += 0.5 * (*v + v_new) * h;
    *v = v_new;
}

/* ------------------------------------------------------------------------------ recording */
static double pos_m(ls_pos p, double tau)
{
    return ((double)p.period + (double)p.theta * (1.0 / (2.0 * SIM_PI))) * tau;
}

static ls_pos pos_of_m(double x, double tau)
{
    ls_pos p;
    double u = x / tau, f = floor(u);
    if (!(fabs(f) <= (double)LS_POS_PERIOD_MAX)) { /* beyond the drive's range (or not finite): a
                                                     * target its setters refuse (range-checked
                                                     * before the conversion) */
        p.period = LS_POS_PERIOD_MAX;
        p.theta = (LS_REAL)NAN;
        return p;
    }
    p.period = (int32_t)f;
    p.theta = (LS_REAL)((u - f) * 2.0 * SIM_PI);
    return ls_pos_norm(p);
}

static double wrap_pi(double a)
{
    return a - 2.0 * SIM_PI * floor((a + SIM_PI) * (1.0 / (2.0 * SIM_PI)));
}

/* theta_err of the drive's estimate against the true position x (rad, wrapped); one compiled copy
 * for the samples and the block statistics, so that both round alike (-ffp-contract) */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
static double est_err(const ls_cmd *cmd, double x, double tau, double kx)
{
    return wrap_pi((pos_m(cmd->pos_est, tau) - x) * kx);
}

static void record(const ls_sim_out *o, int64_t r, double t, double x, double v, const double i[2], double cth,
                   double sth, const double u[3], double force, const ls_cmd *cmd, double tau, double kx, uint32_t fault)
{
    if (o->t) o->t[r] = t;
    if (o->x) o->x[r] = x;
    if (o->v) o->v[r] = v;
    if (o->i_abc) ab_to_abc(i, &o->i_abc[3 * r]);
    if (o->i_dq) {
        o->i_dq[2 * r] = cth * i[0] + sth * i[1];
        o->i_dq[2 * r + 1] = -sth * i[0] + cth * i[1];
    }
    if (o->duty) {
        o->duty[3 * r] = u[0];
        o->duty[3 * r + 1] = u[1];
        o->duty[3 * r + 2] = u[2];
    }
    if (o->force) o->force[r] = force;
    if (cmd != NULL) {
        double x_est = pos_m(cmd->pos_est, tau);
        if (o->x_est) o->x_est[r] = x_est;
        if (o->v_est) o->v_est[r] = (double)cmd->v_est;
        if (o->x_ref) o->x_ref[r] = pos_m(cmd->pos_ref, tau);
        if (o->theta_err) o->theta_err[r] = est_err(cmd, x, tau, kx);
        if (o->err_sig) o->err_sig[r] = (double)cmd->err_sig;
    } else {
        if (o->x_est) o->x_est[r] = NAN;
        if (o->v_est) o->v_est[r] = NAN;
        if (o->x_ref) o->x_ref[r] = NAN;
        if (o->theta_err) o->theta_err[r] = NAN;
        if (o->err_sig) o->err_sig[r] = NAN;
    }
    if (o->fault) o->fault[r] = fault;
}

SIM_HOT bool plant_ok(const ls_sim_cfg *c, const double i[2], double x, double v)
{
    double iabc[3];
    ab_to_abc(i, iabc);
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

SIM_HOT void angle_to(angle_track *a, double th)
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
        s->carry_t[j] = no_carry.t[j];
        s->carry_on[j] = no_carry.on[j];
        s->carry_excess[j] = no_carry.excess[j];
    }
    s->carry_any = no_carry.any_excess ? 1 : 0;
    s->ang_th = 0.0;
    s->ang_c = 1.0;
    s->ang_s = 0.0;
    s->ang_left = 0;
    return LS_OK;
}

/* Block statistics of the samples being recorded (ls_sim_out x_min ... i_abc_max) */
typedef struct {
    int64_t r;                   /* -, local index of the sample whose block is open; < 0: none */
    int32_t n;                   /* -, periods in it so far */
    double x_lo, x_hi, x_sum;    /* m */
    double e_lo, e_hi, e_sum;    /* rad */
    double i_lo[3], i_hi[3];     /* A */
} block_acc;

static void block_open(block_acc *b, int64_t r, double x, double e, const double i[2])
{
    double iabc[3];
    int j;
    ab_to_abc(i, iabc);
    b->r = r;
    b->n = 1;
    b->x_lo = b->x_hi = b->x_sum = x;
    b->e_lo = b->e_hi = b->e_sum = e;
    for (j = 0; j < 3; ++j) {
        b->i_lo[j] = b->i_hi[j] = iabc[j];
    }
}

static void block_add(block_acc *b, double x, double e, const double i[2])
{
    double iabc[3];
    int j;
    ab_to_abc(i, iabc);
    b->n++;
    b->x_lo = x < b->x_lo ? x : b->x_lo;
    b->x_hi = x > b->x_hi ? x : b->x_hi;
    b->x_sum += x;
    b->e_lo = e < b->e_lo ? e : b->e_lo;
    b->e_hi = e > b->e_hi ? e : b->e_hi;
    b->e_sum += e;
    for (j = 0; j < 3; ++j) {
        b->i_lo[j] = iabc[j] < b->i_lo[j] ? iabc[j] : b->i_lo[j];
        b->i_hi[j] = iabc[j] > b->i_hi[j] ? iabc[j] : b->i_hi[j];
    }
}

static void block_write(const ls_sim_out *o, const block_acc *b)
{
    const int64_t r = b->r;
    int j;
    if (r < 0 || b->n == 0) {
        return;
    }
    if (o->x_min) o->x_min[r] = b->x_lo;
    if (o->x_max) o->x_max[r] = b->x_hi;
    if (o->x_mean) o->x_mean[r] = b->n == 1 ? b->x_sum : b->x_sum / (double)b->n;
    if (o->err_min) o->err_min[r] = b->e_lo;
    if (o->err_max) o->err_max[r] = b->e_hi;
    if (o->err_mean) o->err_mean[r] = b->n == 1 ? b->e_sum : b->e_sum / (double)b->n;
    for (j = 0; j < 3; ++j) {
        if (o->i_abc_min) o->i_abc_min[3 * r + j] = b->i_lo[j];
        if (o->i_abc_max) o->i_abc_max[3 * r + j] = b->i_hi[j];
    }
}

/* The time loop of ls_sim_continue, instantiated twice (sat a constant): the linear plant's copy
 * has no trace of the saturated plant (the fast path), the other runs it. */
SIM_HOT ls_status continue_impl(const ls_sim_cfg *c, ls_drive *drive, const ls_sim_cmd *cmds, int32_t n_cmds,
                                ls_sim_state *s, int64_t n_more, const ls_sim_out *out, ls_sim_result *res,
                                const bool sat)
{
    const double h = 1.0 / c->f_pwm, tau = c->pole_pitch, kx = 2.0 * SIM_PI / tau;
    double x, v, i[2], duty[3], x_lag, v_lag, v_lag2; /* m, m/s: x and v one period back, v two back */
    uint64_t rng;
    int64_t k, k_end, r = 0;
    int32_t next, rec_count, j;
    uint32_t fault;
    bool blk, blk_err;
    ls_meas meas;
    ls_cmd cmd;
    plant_maps pm;
    plant_coef q;
    angle_track ang;
    dead_carry carry;
    block_acc acc;
    frozen fz;
    sat_frame sf;
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
    coef_init(c, &q);
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
                ls_drive_move_to(drive, pos_of_m(cmds[next].x, tau));
            } else {
                ls_drive_step_to(drive, pos_of_m(cmds[next].x, tau));
            }
            next++;
        }
        /* sample at the carrier peak, run the controller; its duties act next period */
        measure(c, &q, i, x, drive->mode == LS_MODE_SENSORED || drive->mode == LS_MODE_CALIBRATION, &rng, &meas);
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
            maps_cs(c, &q, th_mid, cm, sm, &pm);
            if (!freeze(c, &pm, om, &fz)) {
                fault |= LS_SIM_FAULT_DIVERGED;
            }
            f_start = force_of(&q, &pm, i);
        } else {
            /* the saturated plant: its values at the mid-period angle, and for the inverter's
             * predictions the system linearised at the period-start currents (L = d lambda/d i,
             * the EMF omega d lambda/d theta frozen) */
            sat_point sp;
            sat_frame_at(c, th_mid, &sf);
            sat_eval(c, &sf, i, &sp);
            memcpy(pm.l, sp.l, sizeof pm.l);
            pm.dl[0] = pm.dl[1] = pm.dl[2] = 0.0;
            memcpy(pm.lpm, sp.lam, sizeof pm.lpm);
            memcpy(pm.dlpm, sp.dlam, sizeof pm.dlpm);
            if (!freeze(c, &pm, om, &fz)) {
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
                block_write(out, &acc);
                block_open(&acc, r, x, blk_err ? est_err(&cmd, x, tau, kx) : 0.0, i);
            }
            record(out, r++, t, x, v, i, cm * cd - sm * sd, sm * cd + cm * sd, u, f_start, &cmd, tau, kx, fault);
        } else if (blk) {
            block_add(&acc, x, blk_err ? est_err(&cmd, x, tau, kx) : 0.0, i);
        }
        if (fault != 0u || cmd.cal_done) { /* a calibration run ends with the calibration */
            s->ended = 1;
            break;
        }
        if (c->fidelity == LS_SIM_SWITCHING) {
            double f_int;
            if (sat) {
                period_switching_sat(c, &q, &fz, u, h, i, &f_int, &carry, &sf, om, &bad);
            } else {
                period_switching(c, &q, &fz, &pm, u, h, i, &f_int, &carry);
            }
            f_avg = f_int / h;
        } else if (sat) {
            double f_end;
            bad = !period_average_sat(c, &q, &fz, &sf, om, u, h, i, &carry, &f_end);
            f_avg = 0.5 * (f_start + f_end);
        } else {
            period_average(c, &q, &fz, u, h, i, &carry);
            f_avg = 0.5 * (f_start + force_of(&q, &pm, i));
        }
        if (bad) {
            fault |= LS_SIM_FAULT_DIVERGED;
        }
        x_lag = x;
        v_lag2 = v_lag;
        v_lag = v;
        mechanics(c, &q, t, h, f_avg, &x, &v);
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
                f_end = force_at(c, &q, kx * x, i);
            }
            if (blk) {
                block_write(out, &acc);
                block_open(&acc, r, x, blk_err ? est_err(&cmd, x, tau, kx) : 0.0, i);
            }
            record(out, r++, t + h, x, v, i, cos(kx * x), sin(kx * x), nan3, f_end, &cmd, tau, kx, fault);
            k++;
            s->ended = 1;
            break;
        }
    }
    if (fault & LS_SIM_FAULT_STOPPED) {
        s->ended = 1;
    }
    if (blk) {
        block_write(out, &acc); /* complete when the call ends where a block does, or the run ends */
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
    const double tau = c->pole_pitch, kx = 2.0 * SIM_PI / tau, h_max = 0.25 / c->f_pwm;
    double x = c->x0, v = c->motion == LS_SIM_HELD ? 0.0 : c->v0, i[2] = {0.0, 0.0}, t = 0.0;
    int64_t s;
    uint32_t fault = 0u;
    plant_maps pm;
    plant_coef pc;
    frozen fz;
    if (c == NULL || seg_t == NULL || seg_v == NULL || out == NULL || res == NULL || n_seg < 0) {
        return LS_ERR_NULL;
    }
    if (ls_sim_check(c) != LS_OK) {
        return LS_ERR_PARAM;
    }
    memset(res, 0, sizeof *res);
    coef_init(c, &pc);
    for (s = 0; s < n_seg && fault == 0u; ++s) {
        double h = seg_t[s], v_ab[2], f_start;
        if (!(LS_ISFINITE(h) && h >= 0.0) || !LS_ISFINITE(seg_v[3 * s]) || !LS_ISFINITE(seg_v[3 * s + 1]) || !LS_ISFINITE(seg_v[3 * s + 2])) {
            return LS_ERR_PARAM;
        }
        f_start = force_at(c, &pc, kx * x, i);
        record(out, s, t, x, v, i, cos(kx * x), sin(kx * x), &seg_v[3 * s], f_start, NULL, tau, kx, fault);
        poles_to_ab(&seg_v[3 * s], v_ab);
        {
            /* segments longer than a quarter PWM period are split, each sub-step frozen at its
             * own mid position, so long open-loop segments stay accurate while moving */
            int32_t n = h > h_max ? (int32_t)ceil(h / h_max) : 1, q;
            double hs = h / (double)n;
            for (q = 0; q < n && fault == 0u; ++q) {
                double fa, fb;
                if (c->sat.on) { /* the saturated plant: frozen at the sub-step's mid angle */
                    sat_frame sf;
                    sat_point sp;
                    sat_frame_at(c, kx * (x + 0.5 * hs * v), &sf);
                    sat_eval(c, &sf, i, &sp);
                    fa = sp.force;
                    if (!sat_step(c, &sf, v_ab, hs, -0.5 * kx * v * hs, kx * v, i, &sp)) {
                        fault |= LS_SIM_FAULT_DIVERGED;
                        break;
                    }
                    fb = sp.force;
                    mechanics(c, &pc, t + (double)q * hs, hs, 0.5 * (fa + fb), &x, &v);
                    continue;
                }
                maps(c, &pc, kx * (x + 0.5 * hs * v), &pm);
                if (!freeze(c, &pm, kx * v, &fz)) {
                    fault |= LS_SIM_FAULT_DIVERGED;
                    break;
                }
                fa = force_of(&pc, &pm, i);
                propagate(&fz, v_ab, hs, i);
                fb = force_of(&pc, &pm, i);
                mechanics(c, &pc, t + (double)q * hs, hs, 0.5 * (fa + fb), &x, &v);
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
            record(out, s, t, x, v, i, cos(kx * x), sin(kx * x), last, force_at(c, &pc, kx * x, i), NULL, tau, kx,
                   fault);
        } else {
            record(out, s, t, x, v, i, 1.0, 0.0, last, NAN, NULL, tau, kx, fault);
        }
    }
    res->steps_done = s;
    res->n_rec = s + 1;
    res->fault = fault;
    res->x_end = x;
    res->v_end = v;
    return LS_OK;
}
