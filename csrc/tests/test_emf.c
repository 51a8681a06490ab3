/* The extended-EMF position error (ls_emf): on the exact steady state of a salient motor at constant
 * speed with a known estimation error (both signs, both directions, several speeds, L_q/L_d 1.1 and
 * 1.5, with and without d current) the error is recovered within the period model's bound; the
 * trust bound falls with speed and meets ls_emf_omega_min's speed; a step of the estimate's error
 * converges as the first-order low-pass; init refuses each bad field. */
#include <math.h>

#include "linsense/ls_emf.h"
#include "linsense/ls_math.h"
#include "ls_test.h"

#define PI 3.14159265358979323846
#define FS 16000.0
#define R_S 9.0
#define L_D 3.5e-3
#define PSI 0.119 /* Wb: ecce2010's 20 N/A at 56 mm */

static ls_emf_cfg base_cfg(double l_q)
{
    ls_emf_cfg c;
    c.fs = (LS_REAL)FS;
    c.r_s = (LS_REAL)R_S;
    c.l_d = (LS_REAL)L_D;
    c.l_q = (LS_REAL)l_q;
    c.f_lpf = (LS_REAL)200.0;
    c.omega_max = (LS_REAL)2000.0;
    c.err_r = (LS_REAL)0.1;
    c.err_l = (LS_REAL)0.1;
    c.u_err = (LS_REAL)0.5;
    c.i_noise = (LS_REAL)0.005;
    c.psi_pm = 0; /* balanced: no compensation */
    c.pm_shift = 0;
    c.neg_re = 0;
    c.neg_im = 0;
    c.harm_order[0] = c.harm_order[1] = 0u; /* no harmonics */
    c.harm_re[0] = c.harm_re[1] = 0;
    c.harm_im[0] = c.harm_im[1] = 0;
    return c;
}

/* The plant's exact steady state: rotor-frame current (i_d, i_q) constant, angle omega t + th0. The
 * mean voltage over [t0, t0 + T] is v_dq e^{j theta_mid} sin(w T/2) / (w T/2) (exact), and the
 * samples i_ab(t_k) = e^{j theta(t_k)} i_dq. The estimate leads by err (theta_est = theta + err). */
typedef struct {
    double omega, th0, i_d, i_q, l_q, err;
} plant;

static void sample(const plant *p, long k, LS_REAL v[2], LS_REAL i[2], LS_REAL *c, LS_REAL *s)
{
    const double T = 1.0 / FS, th = p->omega * T * (double)k + p->th0, thm = th - 0.5 * p->omega * T;
    const double x = 0.5 * p->omega * T, sinc = x == 0.0 ? 1.0 : sin(x) / x;
    const double vd = R_S * p->i_d - p->omega * p->l_q * p->i_q;
    const double vq = R_S * p->i_q + p->omega * L_D * p->i_d + p->omega * PSI;
    v[0] = (LS_REAL)(sinc * (cos(thm) * vd - sin(thm) * vq));
    v[1] = (LS_REAL)(sinc * (sin(thm) * vd + cos(thm) * vq));
    i[0] = (LS_REAL)(cos(th) * p->i_d - sin(th) * p->i_q);
    i[1] = (LS_REAL)(sin(th) * p->i_d + cos(th) * p->i_q);
    *c = (LS_REAL)cos(th + p->err);
    *s = (LS_REAL)sin(th + p->err);
}

static void run(ls_emf *e, const plant *p, long k0, long n)
{
    long k;
    LS_REAL v[2], i[2], c, s;
    for (k = k0; k < k0 + n; ++k) {
        sample(p, k, v, i, &c, &s);
        ls_emf_step(e, v, i, c, s, (LS_REAL)p->omega, (LS_REAL)1.0);
    }
}

/* The period model's error (trapezoidal mean current, difference for the derivative): relative
 * (w T)^2 / 12 of the impedance drop |R + j w L_q| |i| against the EMF |E_ex|, doubled, and the
 * float arithmetic's floor. */
static double tol_of(const plant *p)
{
    const double wt = p->omega / FS, im = sqrt(p->i_d * p->i_d + p->i_q * p->i_q);
    const double ex = fabs(p->omega * (PSI + (L_D - p->l_q) * p->i_d));
    const double floor_ = sizeof(LS_REAL) == 4 ? 3e-4 : 1e-9;
    return wt * wt / 6.0 * (R_S + fabs(p->omega) * p->l_q) * im / ex + floor_;
}

static void test_steady_state(void)
{
    static const double ratio[2] = {1.1, 1.5};
    static const double speeds[4] = {-600.0, -60.0, 60.0, 1500.0}; /* rad/s electrical */
    static const double errs[3] = {-0.3, 0.02, 0.4};                /* rad */
    static const double id[2] = {0.0, -1.0};
    int a, b, d, f;
    double worst = 0.0;
    for (a = 0; a < 2; ++a) {
        for (b = 0; b < 4; ++b) {
            for (d = 0; d < 3; ++d) {
                for (f = 0; f < 2; ++f) {
                    ls_emf_cfg cfg = base_cfg(L_D * ratio[a]);
                    ls_emf e;
                    plant p;
                    p.omega = speeds[b];
                    p.th0 = 1.0 + 0.3 * d;
                    p.i_d = id[f];
                    p.i_q = 2.0 * (b % 2 == 0 ? 1.0 : -1.0);
                    p.l_q = L_D * ratio[a];
                    p.err = errs[d];
                    LS_CHECK(ls_emf_init(&e, &cfg) == LS_OK);
                    run(&e, &p, 0, 1600); /* 0.1 s: 125 time constants */
                    LS_CHECK_NEAR(e.eps, -p.err, tol_of(&p));
                    worst = fmax(worst, fabs(e.eps + p.err));
                    /* the magnitude is the extended EMF's */
                    LS_CHECK_NEAR(e.mag, fabs(p.omega * (PSI + (L_D - p.l_q) * p.i_d)), 1e-3 * fabs(p.omega * PSI));
                }
            }
        }
    }
    printf("steady state: worst |eps - true| %.3g rad\n", worst);
}

/* The magnets' imbalance (docs/theory.md section 10): phase k links g_k PSI cos(theta - 2 pi k/3 +
 * delta_k); the plant's EMF is each phase's period mean, Clarke-transformed as the drive does
 * (amplitude-invariant; the zero sequence drops out). The block configured from the sequences
 * P = (1/3) sum c_k, N = (1/3) sum c_k a^k (c_k = g_k e^{j delta_k}, a = e^{j 2 pi/3}) recovers the
 * error within the balanced tolerance plus the second-order |n| |err| over a whole electrical period;
 * unconfigured it shows the 2 theta ripple (through its low-pass) and the offset arg P; the
 * compensation's sign flipped doubles the ripple. */
typedef struct {
    double g[3], delta[3];
} pm_imb;

/* the imbalance's EMF less the balanced one, period mean ending at sample k (alpha-beta) */
static void imb_extra(const plant *p, const pm_imb *m, long k, double out[2])
{
    const double T = 1.0 / FS, th = p->omega * T * (double)k + p->th0, thm = th - 0.5 * p->omega * T;
    const double x = 0.5 * p->omega * T, sinc = x == 0.0 ? 1.0 : sin(x) / x;
    double e[3];
    int j;
    for (j = 0; j < 3; ++j) {
        const double u = thm - 2.0 * PI * j / 3.0;
        /* d/dt [g psi cos(u + delta)] - the balanced phase's, the period's mean */
        e[j] = -p->omega * PSI * sinc * (m->g[j] * sin(u + m->delta[j]) - sin(u));
    }
    out[0] = (2.0 / 3.0) * (e[0] - 0.5 * (e[1] + e[2]));
    out[1] = (e[1] - e[2]) / sqrt(3.0);
}

static void imb_cfg(const pm_imb *m, ls_emf_cfg *c, double *n_mag, double *arg_p)
{
    double pr = 0, pi_ = 0, nr = 0, ni = 0, p2, qr, qi;
    int j;
    for (j = 0; j < 3; ++j) {
        const double a = 2.0 * PI * j / 3.0;
        pr += m->g[j] * cos(m->delta[j]) / 3.0;
        pi_ += m->g[j] * sin(m->delta[j]) / 3.0;
        nr += m->g[j] * cos(m->delta[j] + a) / 3.0;
        ni += m->g[j] * sin(m->delta[j] + a) / 3.0;
    }
    /* n = conj(N) / P = conj(N) conj(P) / |P|^2 */
    p2 = pr * pr + pi_ * pi_;
    qr = (nr * pr - ni * pi_) / p2;
    qi = -(nr * pi_ + ni * pr) / p2;
    c->psi_pm = (LS_REAL)(PSI * sqrt(p2));
    c->pm_shift = (LS_REAL)atan2(pi_, pr);
    c->neg_re = (LS_REAL)qr;
    c->neg_im = (LS_REAL)qi;
    *n_mag = sqrt(qr * qr + qi * qi);
    *arg_p = atan2(pi_, pr);
}

/* eps over the last electrical period after settling: its mean and peak-to-peak, and the largest
 * |eps + err| */
/* The block over one period of the steady state after 3200 steps, with the extra EMF extra(p, arg,
 * k, out) added to the plant's voltage (the magnets' imbalance, their harmonics): the error's mean,
 * p-p and worst |eps + err| over the period. */
typedef void (*extra_emf)(const plant *p, const void *arg, long k, double out[2]);

static void run_extra(ls_emf *e, const plant *p, extra_emf extra, const void *arg, double *mean, double *pp,
                      double *worst)
{
    const long n_per = (long)ceil(2.0 * PI / fabs(p->omega) * FS), n0 = 3200;
    long k;
    double lo = 1e9, hi = -1e9, sum = 0.0;
    *worst = 0.0;
    for (k = 0; k < n0 + n_per; ++k) {
        LS_REAL v[2], i[2], c, s;
        double x[2];
        sample(p, k, v, i, &c, &s);
        extra(p, arg, k, x);
        v[0] = (LS_REAL)((double)v[0] + x[0]);
        v[1] = (LS_REAL)((double)v[1] + x[1]);
        ls_emf_step(e, v, i, c, s, (LS_REAL)p->omega, (LS_REAL)1.0);
        if (k >= n0) {
            lo = fmin(lo, (double)e->eps);
            hi = fmax(hi, (double)e->eps);
            sum += (double)e->eps;
            *worst = fmax(*worst, fabs((double)e->eps + p->err));
        }
    }
    *mean = sum / (double)n_per;
    *pp = hi - lo;
}

static void imb_extra_any(const plant *p, const void *m, long k, double out[2])
{
    imb_extra(p, (const pm_imb *)m, k, out);
}

static void run_imb(ls_emf *e, const plant *p, const pm_imb *m, double *mean, double *pp, double *worst)
{
    run_extra(e, p, imb_extra_any, m, mean, pp, worst);
}

static void test_imbalance(void)
{
    static const pm_imb cases[3] = {{{1.0, 0.96, 1.0}, {0.0, 0.0, 0.0}},
                                    {{1.0, 1.0, 1.0}, {0.0, 1.5 * PI / 180.0, 0.0}},
                                    {{0.92, 1.0, 0.97}, {-1.0 * PI / 180.0, 0.0, 2.0 * PI / 180.0}}};
    static const double speeds[3] = {-700.0, 300.0, 1500.0};
    static const double errs[3] = {0.0, 0.01, -0.3};
    int a, b, d;
    double worst_on = 0.0;
    for (a = 0; a < 3; ++a) {
        for (b = 0; b < 3; ++b) {
            for (d = 0; d < 3; ++d) {
                ls_emf_cfg cfg = base_cfg(1.3 * L_D), flip;
                ls_emf e;
                plant p;
                double n_mag, arg_p, mean, pp, worst, h2, x;
                p.omega = speeds[b];
                p.th0 = 0.7;
                p.i_d = 0.0;
                p.i_q = 2.0 * (p.omega > 0 ? 1.0 : -1.0);
                p.l_q = 1.3 * L_D;
                p.err = errs[d];
                imb_cfg(&cases[a], &cfg, &n_mag, &arg_p);
                /* compensated: the balanced tolerance and the second-order term (the negative
                 * sequence predicted at an angle off by err: |n| 2 sin(|err| / 2)) */
                LS_CHECK(ls_emf_init(&e, &cfg) == LS_OK);
                run_imb(&e, &p, &cases[a], &mean, &pp, &worst);
                LS_CHECK(worst <= tol_of(&p) + n_mag * fabs(p.err));
                if (p.err == 0.0) {
                    worst_on = fmax(worst_on, worst);
                }
                /* not compensated: the offset arg P and the ripple 2 |n| through the low-pass at 2 w */
                {
                    ls_emf_cfg off = base_cfg(1.3 * L_D);
                    LS_CHECK(ls_emf_init(&e, &off) == LS_OK);
                }
                run_imb(&e, &p, &cases[a], &mean, &pp, &worst);
                x = 2.0 * fabs(p.omega) / FS;
                h2 = (double)e.alpha / sqrt(1.0 - 2.0 * (1.0 - (double)e.alpha) * cos(x) +
                                            (1.0 - (double)e.alpha) * (1.0 - (double)e.alpha));
                LS_CHECK(pp > 0.8 * 2.0 * n_mag * h2 && pp < 1.2 * 2.0 * n_mag * h2);
                LS_CHECK_NEAR(mean, -p.err + arg_p, 0.1 * n_mag + tol_of(&p) + n_mag * fabs(p.err));
                /* the compensation's sign flipped (a mutation): the ripple doubles */
                flip = cfg;
                flip.neg_re = -cfg.neg_re;
                flip.neg_im = -cfg.neg_im;
                LS_CHECK(ls_emf_init(&e, &flip) == LS_OK);
                run_imb(&e, &p, &cases[a], &mean, &pp, &worst);
                LS_CHECK(n_mag < 1e-3 || pp > 1.6 * 2.0 * n_mag * h2);
                /* the shift's sign flipped: the offset 2 arg P */
                flip = cfg;
                flip.pm_shift = -cfg.pm_shift;
                LS_CHECK(ls_emf_init(&e, &flip) == LS_OK);
                run_imb(&e, &p, &cases[a], &mean, &pp, &worst);
                LS_CHECK(fabs(arg_p) < 1e-3 ||
                         fabs(mean + p.err - 2.0 * arg_p) < 0.1 * fabs(arg_p) + n_mag * fabs(p.err));
            }
        }
    }
    printf("imbalance compensated, no estimation error: worst |eps - true| %.3g rad\n", worst_on);
}

/* The trust bound: falls as the speed rises; at ls_emf_omega_min's speed for 3 deg it is 3 deg. */
static void test_low_speed(void)
{
    ls_emf_cfg cfg = base_cfg(1.3 * L_D);
    ls_emf e;
    plant p;
    double w, prev = 10.0, eps_max = 3.0 * PI / 180.0, w_min;
    LS_CHECK(ls_emf_init(&e, &cfg) == LS_OK);
    w_min = (double)ls_emf_omega_min(&e, (LS_REAL)2.0, (LS_REAL)PSI, (LS_REAL)eps_max, (LS_REAL)1.0);
    LS_CHECK(w_min > 10.0 && w_min < 1000.0);
    for (w = 2.0; w < 1000.0; w *= 1.5) {
        p.omega = w;
        p.th0 = 0.5;
        p.i_d = 0.0;
        p.i_q = 2.0;
        p.l_q = 1.3 * L_D;
        p.err = 0.01;
        ls_emf_reset(&e);
        run(&e, &p, 0, 1600);
        LS_CHECK(e.bound <= prev);
        LS_CHECK(e.bound > 0.0);
        prev = e.bound;
        LS_CHECK((w < w_min) == (e.bound > eps_max * (1.0 + 1e-3)) || fabs(w / w_min - 1.0) < 1e-2);
    }
    /* no error at all: no bound; an EMF below the along-current error or not finite: no trust */
    {
        ls_emf_cfg z = cfg;
        ls_emf ez;
        z.err_r = z.err_l = z.u_err = z.i_noise = 0;
        LS_CHECK(ls_emf_init(&ez, &z) == LS_OK);
        LS_CHECK_NEAR(ls_emf_bound(&ez, 10, 2, 1, 100, 1), 0.0, 0.0);
    }
    LS_CHECK_NEAR(ls_emf_bound(&e, (LS_REAL)0.5, 2, 0, 100, 1), 0.5 * PI, 1e-6);
    LS_CHECK_NEAR(ls_emf_bound(&e, (LS_REAL)NAN, 2, 0, 100, 1), 0.5 * PI, 1e-6);
    /* a current across the EMF turns the along-current errors into angle */
    LS_CHECK(ls_emf_bound(&e, 20, 0, 2, 100, 1) > 2.0 * ls_emf_bound(&e, 20, 2, 0, 100, 1));
    /* at w_min exactly: bound = eps_max */
    p.omega = w_min;
    ls_emf_reset(&e);
    run(&e, &p, 0, 1600);
    LS_CHECK_NEAR(e.bound, eps_max, 1e-3 * eps_max);
    /* at standstill: no trust */
    p.omega = 0.0;
    ls_emf_reset(&e);
    run(&e, &p, 0, 1600);
    LS_CHECK_NEAR(e.bound, 0.5 * PI, 1e-6);
    /* no speed reaches the bound when the inductance's uncertainty alone exceeds it */
    cfg.err_l = (LS_REAL)0.9;
    LS_CHECK(ls_emf_init(&e, &cfg) == LS_OK);
    LS_CHECK(ls_emf_omega_min(&e, (LS_REAL)20.0, (LS_REAL)PSI, (LS_REAL)eps_max, (LS_REAL)1.0) == LS_REAL_MAX);
    LS_CHECK(ls_emf_omega_min(&e, (LS_REAL)2.0, (LS_REAL)-1.0, (LS_REAL)eps_max, (LS_REAL)1.0) == LS_REAL_MAX);
}

/* A step of the estimate's error converges as the low-pass: the filtered vector is the old one
 * weighted (1 - alpha)^n and the new one 1 - (1 - alpha)^n. */
static void test_step(void)
{
    ls_emf_cfg cfg = base_cfg(1.5 * L_D);
    ls_emf e;
    plant p;
    long n;
    const double dth = 0.2;
    double a;
    p.omega = 400.0;
    p.th0 = 0.0;
    p.i_d = 0.0;
    p.i_q = 1.0;
    p.l_q = 1.5 * L_D;
    p.err = 0.0;
    LS_CHECK(ls_emf_init(&e, &cfg) == LS_OK);
    a = (double)e.alpha;
    LS_CHECK_NEAR(a, 1.0 - exp(-2.0 * PI * 200.0 / FS), 1e-5);
    run(&e, &p, 0, 1600);
    LS_CHECK_NEAR(e.eps, 0.0, 3e-4);
    p.err = dth;
    for (n = 1; n <= 160; ++n) {
        double wn, xd, xq;
        run(&e, &p, 1600 + n - 1, 1);
        wn = 1.0 - pow(1.0 - a, (double)n);
        /* old (0, 1) and new (sin err, cos err), the eps of their blend */
        xd = wn * sin(dth);
        xq = (1.0 - wn) + wn * cos(dth);
        if (n == 13 || n == 80 || n == 160) {
            LS_CHECK_NEAR(e.eps, -atan2(xd, xq), 5e-4);
        }
    }
    /* one time constant (1 / (2 pi f_lpf) = 12.7 periods) reaches 1 - 1/e of the step */
    LS_CHECK(fabs(e.eps + dth) < 1e-3);
}

/* Non-finite inputs leave the filters alone; the next step re-primes. */
static void test_nonfinite(void)
{
    ls_emf_cfg cfg = base_cfg(1.2 * L_D);
    ls_emf e;
    plant p;
    LS_REAL v[2] = {(LS_REAL)NAN, 0}, i[2] = {0, 0};
    double before;
    p.omega = 300.0;
    p.th0 = 0.2;
    p.i_d = 0.0;
    p.i_q = 1.0;
    p.l_q = 1.2 * L_D;
    p.err = 0.05;
    LS_CHECK(ls_emf_init(&e, &cfg) == LS_OK);
    run(&e, &p, 0, 1600);
    before = (double)e.eps;
    LS_CHECK_NEAR(ls_emf_step(&e, v, i, 1, 0, (LS_REAL)300.0, 1), before, 0.0);
    LS_CHECK(!e.primed);
    run(&e, &p, 1700, 200);
    LS_CHECK_NEAR(e.eps, -0.05, 3e-4);
}

/* Hostile inputs (a fuzz of the step alone: the block is not in ls_drive, whose fuzzer does not
 * reach it yet): random values over +-1e30, NaN and infinities in every input, 200000 steps under
 * the sanitizers; eps stays finite in [-pi, pi], the bound in [0, pi/2], mag finite or the filters
 * held (a finite huge input may overflow mag to inf: then the bound is pi/2). */
static unsigned long lcg_state = 12345u;
static double lcg(void)
{
    lcg_state = (lcg_state * 1103515245u + 12345u) & 0x7fffffffu;
    return (double)lcg_state / 2147483648.0;
}
static LS_REAL hostile(void)
{
    const double u = lcg();
    if (u < 0.02) {
        return (LS_REAL)NAN;
    }
    if (u < 0.04) {
        return (LS_REAL)(u < 0.03 ? INFINITY : -INFINITY);
    }
    if (u < 0.2) {
        return (LS_REAL)((lcg() - 0.5) * 2e30);
    }
    return (LS_REAL)((lcg() - 0.5) * 200.0);
}
static void test_hostile(int imbalanced)
{
    ls_emf_cfg cfg = base_cfg(1.3 * L_D);
    ls_emf e;
    long k, bad = 0;
    if (imbalanced) { /* the compensation's path too */
        cfg.psi_pm = (LS_REAL)PSI;
        cfg.pm_shift = (LS_REAL)0.05;
        cfg.neg_re = (LS_REAL)0.3;
        cfg.neg_im = (LS_REAL)-0.2;
    }
    LS_CHECK(ls_emf_init(&e, &cfg) == LS_OK);
    for (k = 0; k < 200000; ++k) {
        LS_REAL v[2], i[2];
        v[0] = hostile();
        v[1] = hostile();
        i[0] = hostile();
        i[1] = hostile();
        ls_emf_step(&e, v, i, hostile(), hostile(), hostile(), hostile());
        if (!(e.eps >= -PI - 1e-6 && e.eps <= PI + 1e-6) || !(e.bound >= 0.0 && e.bound <= 0.5 * PI + 1e-6)) {
            if (bad++ < 3) {
                printf("hostile step %ld: eps %g, bound %g, mag %g\n", k, (double)e.eps, (double)e.bound,
                       (double)e.mag);
            }
        }
        if (k % 1000 == 999) {
            ls_emf_reset(&e); /* (a filter driven to inf stays there: the caller resets) */
        }
    }
    LS_CHECK(bad == 0);
    if (bad != 0) {
        printf("hostile: %ld steps out of range\n", bad);
    }
}

static void test_refusals(void)
{
    ls_emf e;
    ls_emf_cfg c = base_cfg(1.2 * L_D);
    LS_CHECK(ls_emf_init(NULL, &c) == LS_ERR_NULL);
    LS_CHECK(ls_emf_init(&e, NULL) == LS_ERR_NULL);
#define REFUSE(field, value)                                                                    \
    do {                                                                                        \
        c = base_cfg(1.2 * L_D);                                                                \
        c.field = (LS_REAL)(value);                                                             \
        LS_CHECK(ls_emf_init(&e, &c) == LS_ERR_PARAM);                                          \
    } while (0)
    REFUSE(fs, 0.0);
    REFUSE(fs, NAN);
    REFUSE(r_s, -1.0);
    REFUSE(r_s, INFINITY);
    REFUSE(l_d, 0.0);
    REFUSE(l_q, -1e-3);
    REFUSE(l_q, NAN);
    REFUSE(f_lpf, 0.0);
    REFUSE(f_lpf, 0.051 * FS);
    REFUSE(omega_max, 0.0);
    REFUSE(omega_max, 0.26 * FS);
    REFUSE(err_r, -0.1);
    REFUSE(err_r, 0.95);
    REFUSE(err_l, 0.95);
    REFUSE(err_l, NAN);
    REFUSE(u_err, -0.1);
    REFUSE(i_noise, -1e-3);
    REFUSE(i_noise, INFINITY);
    REFUSE(psi_pm, -0.1);
    REFUSE(psi_pm, NAN);
    REFUSE(pm_shift, 0.53);
    REFUSE(pm_shift, -INFINITY);
    REFUSE(neg_re, 0.5);
    REFUSE(neg_im, -0.5);
    REFUSE(neg_re, NAN);
    /* a ratio without a flux to scale it */
    c = base_cfg(1.2 * L_D);
    c.neg_im = (LS_REAL)0.01;
    LS_CHECK(ls_emf_init(&e, &c) == LS_ERR_PARAM);
    c.psi_pm = (LS_REAL)PSI;
    LS_CHECK(ls_emf_init(&e, &c) == LS_OK);
    c.neg_re = (LS_REAL)0.35;
    c.neg_im = (LS_REAL)0.35; /* |n| = 0.495 */
    LS_CHECK(ls_emf_init(&e, &c) == LS_OK);
    c.neg_re = (LS_REAL)0.36; /* |n| = 0.502 */
    LS_CHECK(ls_emf_init(&e, &c) == LS_ERR_PARAM);
#undef REFUSE
    c = base_cfg(1.2 * L_D);
    c.f_lpf = (LS_REAL)(0.05 * FS);
    c.omega_max = (LS_REAL)(0.25 * FS);
    c.r_s = 0;
    c.err_r = c.err_l = c.u_err = c.i_noise = 0;
    c.pm_shift = LS_EMF_PM_SHIFT_MAX;
    c.psi_pm = (LS_REAL)PSI;
    LS_CHECK(ls_emf_init(&e, &c) == LS_OK); /* the limits themselves are allowed */
}

/* ls_atan2 (ls_math.h) against double atan2 around the circle, at several radii, and its edges. */
static void test_atan2(void)
{
    int k;
    double worst = 0.0;
    for (k = 0; k < 100000; ++k) {
        const double a = -PI + 2.0 * PI * (k + 0.5) / 100000.0, r = k % 3 == 0 ? 1e-3 : (k % 3 == 1 ? 1.0 : 1e4);
        const LS_REAL y = (LS_REAL)(r * sin(a)), x = (LS_REAL)(r * cos(a));
        worst = fmax(worst, fabs((double)ls_atan2(y, x) - atan2((double)y, (double)x)));
    }
    printf("ls_atan2: worst error %.3g rad\n", worst);
    LS_CHECK(worst <= 4e-7); /* (a float's step at pi is 2.4e-7) */
    LS_CHECK_NEAR(ls_atan2(0, 0), 0.0, 0.0);
    LS_CHECK_NEAR(ls_atan2(0, -1), PI, 3e-7);
    LS_CHECK_NEAR(ls_atan2(-1, 0), -0.5 * PI, 3e-7);
    LS_CHECK_NEAR(ls_atan2((LS_REAL)INFINITY, 1), 0.5 * PI, 3e-7);
    LS_CHECK(ls_atan2((LS_REAL)NAN, 1) != ls_atan2((LS_REAL)NAN, 1));
}

/* The magnets' flux harmonics: each phase links psi a_h cos(n_h u + phi_h) more, u = theta - 2 pi j /
 * 3; the block with the slots filled (c = psi a e^{j s phi}, s = +1 for n mod 3 = 1, -1 for 2)
 * takes their EMF out; without, the estimate ripples at 6 theta by about sum n a. */
typedef struct {
    unsigned n[2];
    double a[2], phi[2];
} pm_harm;

static void harm_extra(const plant *p, const pm_harm *h, long k, double out[2])
{
    const double T = 1.0 / FS, th = p->omega * T * (double)k + p->th0, thm = th - 0.5 * p->omega * T;
    double e[3] = {0.0, 0.0, 0.0};
    int j, q;
    for (j = 0; j < 3; ++j) {
        const double u = thm - 2.0 * PI * j / 3.0;
        for (q = 0; q < 2; ++q) {
            const double x = 0.5 * p->omega * T * h->n[q], sinc = x == 0.0 ? 1.0 : sin(x) / x;
            /* the period's mean of d/dt [psi a cos(n u + phi)] */
            e[j] += -p->omega * PSI * h->a[q] * h->n[q] * sinc * sin(h->n[q] * u + h->phi[q]);
        }
    }
    out[0] = (2.0 / 3.0) * (e[0] - 0.5 * (e[1] + e[2]));
    out[1] = (e[1] - e[2]) / sqrt(3.0);
}

static void harm_extra_any(const plant *p, const void *h, long k, double out[2])
{
    harm_extra(p, (const pm_harm *)h, k, out);
}

static void run_harm(ls_emf *e, const plant *p, const pm_harm *h, double *pp, double *worst)
{
    double mean;
    run_extra(e, p, harm_extra_any, h, &mean, pp, worst);
}

static void test_harmonics(void)
{
    static const pm_harm cases[2] = {{{5u, 7u}, {0.02, 0.01}, {0.3, -0.5}}, {{7u, 11u}, {0.015, 0.004}, {1.0, 2.0}}};
    static const double speeds[3] = {-700.0, 300.0, 1200.0};
    int a, b;
    for (a = 0; a < 2; ++a) {
        for (b = 0; b < 3; ++b) {
            const pm_harm *h = &cases[a];
            ls_emf_cfg cfg = base_cfg(1.3 * L_D), bad;
            ls_emf e;
            plant p;
            double pp_on, worst_on, pp_off, worst_off, pp_bad, worst_bad, sum_na = 0.0, resid = 0.0;
            int q;
            p.omega = speeds[b];
            p.th0 = 0.7;
            p.i_d = 0.0;
            p.i_q = 2.0 * (p.omega > 0 ? 1.0 : -1.0);
            p.l_q = 1.3 * L_D;
            p.err = 0.0;
            cfg.psi_pm = (LS_REAL)PSI;
            for (q = 0; q < 2; ++q) {
                const double sg = h->n[q] % 3u == 1u ? 1.0 : -1.0;
                const double x = 0.5 * fabs(p.omega) / FS * h->n[q];
                cfg.harm_order[q] = h->n[q];
                cfg.harm_re[q] = (LS_REAL)(PSI * h->a[q] * cos(sg * h->phi[q]));
                cfg.harm_im[q] = (LS_REAL)(PSI * h->a[q] * sin(sg * h->phi[q]));
                sum_na += h->n[q] * h->a[q];
                resid += h->n[q] * h->a[q] * (1.0 - sin(x) / x); /* (the block takes the middle's value) */
            }
            LS_CHECK(ls_emf_init(&e, &cfg) == LS_OK);
            run_harm(&e, &p, h, &pp_on, &worst_on);
            LS_CHECK(worst_on <= tol_of(&p) + 1.2 * resid);
            {
                ls_emf_cfg off = base_cfg(1.3 * L_D);
                LS_CHECK(ls_emf_init(&e, &off) == LS_OK);
            }
            run_harm(&e, &p, h, &pp_off, &worst_off);
            LS_CHECK(pp_off > 5.0 * pp_on && worst_off > 20.0 * worst_on && worst_off < sum_na);
            /* mutations: the coefficient's sign, or the sequence (the conjugate phase) */
            bad = cfg;
            bad.harm_re[0] = -cfg.harm_re[0];
            bad.harm_im[0] = -cfg.harm_im[0];
            LS_CHECK(ls_emf_init(&e, &bad) == LS_OK);
            run_harm(&e, &p, h, &pp_bad, &worst_bad);
            LS_CHECK(worst_bad > 3.0 * worst_on && worst_bad > 0.5 * worst_off);
            bad = cfg;
            bad.harm_im[0] = -cfg.harm_im[0];
            bad.harm_im[1] = -cfg.harm_im[1];
            LS_CHECK(ls_emf_init(&e, &bad) == LS_OK);
            run_harm(&e, &p, h, &pp_bad, &worst_bad);
            LS_CHECK(worst_bad > 3.0 * worst_on);
            if (b == 2) {
                printf("harmonics (%u, %u) at %g rad/s: worst %.2e rad compensated, %.2e without\n", h->n[0], h->n[1],
                       p.omega, worst_on, worst_off);
            }
        }
    }
    /* refusals: a triplen or order 1, beyond the largest order, a coefficient without an order or
     * beyond LS_EMF_HARM_MAX psi_pm, a non-finite one */
    {
        ls_emf e;
        ls_emf_cfg c = base_cfg(1.3 * L_D);
        c.psi_pm = (LS_REAL)PSI;
        c.harm_order[0] = 3u;
        c.harm_re[0] = (LS_REAL)(0.01 * PSI);
        LS_CHECK(ls_emf_init(&e, &c) == LS_ERR_PARAM);
        c.harm_order[0] = 1u;
        LS_CHECK(ls_emf_init(&e, &c) == LS_ERR_PARAM);
        c.harm_order[0] = LS_EMF_HARM_ORDER_MAX + 1u;
        LS_CHECK(ls_emf_init(&e, &c) == LS_ERR_PARAM);
        c.harm_order[0] = 0u;
        LS_CHECK(ls_emf_init(&e, &c) == LS_ERR_PARAM);
        c.harm_order[0] = 5u;
        LS_CHECK(ls_emf_init(&e, &c) == LS_OK);
        c.harm_re[0] = (LS_REAL)(0.3 * PSI);
        LS_CHECK(ls_emf_init(&e, &c) == LS_ERR_PARAM);
        c.harm_re[0] = (LS_REAL)NAN;
        LS_CHECK(ls_emf_init(&e, &c) == LS_ERR_PARAM);
    }
}

/* ls_emf_update and ls_emf_angle: the filters every period and the angle only on some (as ls_drive
 * below the hand-over band) give, on the periods the angle is asked for, ls_emf_step_eps's eps and
 * mag bit for bit; in between eps and mag stay as the last angle left them; a speed reversal's
 * direction is the angle's omega. */
static void test_split(void)
{
    ls_emf_cfg cfg = base_cfg(1.5 * L_D);
    ls_emf a, b, f;
    plant p;
    long k;
    int bad = 0;
    cfg.pm_shift = LS_R(0.05);
    cfg.neg_re = LS_R(0.02);
    cfg.psi_pm = (LS_REAL)PSI;
    p.omega = 300.0;
    p.th0 = 0.3;
    p.i_d = 0.2;
    p.i_q = 1.0;
    p.l_q = 1.5 * L_D;
    p.err = 0.05;
    LS_CHECK(ls_emf_init(&a, &cfg) == LS_OK);
    LS_CHECK(ls_emf_init(&b, &cfg) == LS_OK);
    LS_CHECK(ls_emf_init(&f, &cfg) == LS_OK);
    for (k = 0; k < 2000; ++k) {
        LS_REAL v[2], i[2], c, s, ea, eb;
        const bool want = (k / 50) % 3 != 1; /* (50 periods of every 150 without the angle) */
        if (k == 1000) {
            p.omega = -p.omega; /* (the other direction: the angle's sign) */
        }
        sample(&p, k, v, i, &c, &s);
        ea = ls_emf_step_eps(&a, v, i, c, s, (LS_REAL)p.omega, LS_R(1.1));
        if (ls_emf_update(&b, v, i, c, s, (LS_REAL)p.omega, LS_R(1.1)) && want) {
            (void)ls_emf_angle(&b, (LS_REAL)p.omega);
        }
        eb = b.eps;
        /* (the unguarded update: the same filters on finite inputs) */
        (void)ls_emf_update_finite(&f, v, i, c, s, (LS_REAL)p.omega, LS_R(1.1));
        bad += f.e_d != b.e_d || f.e_q != b.e_q || f.i_d != b.i_d || f.i_q != b.i_q || f.primed != b.primed;
        bad += a.e_d != b.e_d || a.e_q != b.e_q || a.i_d != b.i_d || a.i_q != b.i_q;
        if (want) {
            bad += ea != eb || a.mag != b.mag || a.eps != b.eps;
        }
    }
    LS_CHECK(bad == 0);
    LS_CHECK(a.eps != LS_R(0.0)); /* (the comparison saw an angle) */
    /* the first step of a reset block only stores its sample: no angle to ask for */
    ls_emf_reset(&b);
    {
        LS_REAL v[2] = {LS_R(1.0), LS_R(0.0)}, i[2] = {LS_R(0.5), LS_R(0.0)};
        LS_CHECK(!ls_emf_update(&b, v, i, LS_R(1.0), LS_R(0.0), LS_R(100.0), LS_R(1.0)));
        LS_CHECK(ls_emf_update(&b, v, i, LS_R(1.0), LS_R(0.0), LS_R(100.0), LS_R(1.0)));
        i[0] = (LS_REAL)NAN;
        LS_CHECK(!ls_emf_update(&b, v, i, LS_R(1.0), LS_R(0.0), LS_R(100.0), LS_R(1.0)));
    }
}

int main(void)
{
    test_atan2();
    test_steady_state();
    test_imbalance();
    test_harmonics();
    test_low_speed();
    test_step();
    test_split();
    test_nonfinite();
    test_hostile(0);
    test_hostile(1);
    test_refusals();
    return ls_test_report("test_emf");
}
