/* Trajectory: duration, peak speed and end position against the closed form (trapezoidal and
 * triangular), limits respected, and a 2 m move on the long-travel position type; a step
 * (ls_traj_jump) the same profile under v_step and a_step, or a jump with a_step 0; the refused
 * configurations. */
#include <math.h>

#include "linsense/ls_traj.h"
#include "ls_test.h"
#include "ls_test_plant.h"

#define PI 3.14159265358979323846
#define TAU 0.056

static double to_m(ls_pos p)
{
    return tp_pos_m(p, TAU);
}

static ls_pos from_m(double x)
{
    return tp_pos_of_m(x, TAU);
}

/* float keeps the profile within a fraction of a micrometre over metres of travel */
#define POS_TOL (sizeof(LS_REAL) == 4 ? 0.5e-6 : 1e-9)

/* A move (step false: ls_traj_move under v_max, a_max) or a step (ls_traj_jump under the
 * v_step, a_step given as v_max, a_max here; the move's own limits then are others, 3 and 30). */
static void run_kind(double dist, double v_max, double a_max, ls_pos start, bool step)
{
    ls_traj_cfg cfg;
    ls_traj t;
    ls_pos x = {0, LS_R(0.0)}, target;
    LS_REAL v = LS_R(-1.0), a = LS_R(-1.0); /* (set by every ls_traj_step) */
    double T_expected, v_peak, t_end = -1, x0 = to_m(start), vmax_seen = 0, prev = x0, dx_max = 0;
    long k;
    cfg.v_max = step ? LS_R(3.0) : (LS_REAL)v_max;
    cfg.a_max = step ? LS_R(30.0) : (LS_REAL)a_max;
    cfg.v_step = step ? (LS_REAL)v_max : LS_R(0.0);
    cfg.a_step = step ? (LS_REAL)a_max : LS_R(0.0);
    cfg.a_lpf = LS_R(0.0);
    cfg.pole_pitch = (LS_REAL)TAU;
    cfg.fs = LS_R(16000.0);
    LS_CHECK(ls_traj_init(&t, &cfg) == LS_OK);
    ls_traj_reset(&t, start);
    target = from_m(x0 + dist);
    if (step) {
        ls_traj_jump(&t, target);
    } else {
        ls_traj_move(&t, target);
    }
    if (fabs(dist) >= v_max * v_max / a_max) {
        T_expected = fabs(dist) / v_max + v_max / a_max;
        v_peak = v_max;
    } else {
        T_expected = 2 * sqrt(fabs(dist) / a_max);
        v_peak = a_max * T_expected / 2;
    }
    for (k = 0; k < (long)(16000.0 * (T_expected + 1.0)); ++k) {
        ls_traj_step(&t, &x, &v, &a);
        if (fabs((double)v) > vmax_seen) vmax_seen = fabs((double)v);
        if (fabs((double)a) > a_max * (1 + 1e-6)) LS_CHECK(0);
        if (fabs(to_m(x) - prev) > dx_max) dx_max = fabs(to_m(x) - prev);
        prev = to_m(x);
        if (!t.active && t_end < 0) t_end = (double)k / 16000.0;
    }
    LS_CHECK_NEAR(t.t_total, T_expected, 1e-5 * T_expected + 1e-6);
    LS_CHECK_NEAR(t_end, T_expected, 2.0 / 16000.0);
    LS_CHECK_NEAR(vmax_seen, v_peak, 1e-3 * v_peak);
    LS_CHECK(dx_max <= v_peak / 16000.0 * 1.001 + POS_TOL); /* no jump anywhere along the move */
    LS_CHECK_NEAR(to_m(x) - x0, dist, 1e-9 + 1e-12 * fabs(x0)); /* ends exactly on target */
    LS_CHECK_NEAR(to_m(t.target), x0 + dist, POS_TOL);
    LS_CHECK(v == 0 && a == 0);
}

static void run(double dist, double v_max, double a_max, ls_pos start)
{
    run_kind(dist, v_max, a_max, start, false);
    run_kind(dist, v_max, a_max, start, true);
}

/* a_step 0: a step jumps the reference (no profile), whatever v_step */
static void jump(void)
{
    ls_traj_cfg cfg = {0};
    ls_traj t;
    ls_pos x, target = from_m(0.042);
    LS_REAL v, a;
    cfg.v_max = LS_R(0.2); cfg.a_max = LS_R(1.0); cfg.v_step = LS_R(0.25); cfg.a_step = LS_R(0.0);
    cfg.pole_pitch = (LS_REAL)TAU; cfg.fs = LS_R(16000.0);
    LS_CHECK(ls_traj_init(&t, &cfg) == LS_OK);
    ls_traj_reset(&t, from_m(0.0));
    ls_traj_jump(&t, target);
    ls_traj_step(&t, &x, &v, &a);
    LS_CHECK(!t.active && v == 0 && a == 0);
    LS_CHECK_NEAR(to_m(x), 0.042, POS_TOL);
}

/* a_lpf: the acceleration output low-passed (no step larger than 2 pi a_lpf Ts of the profile's
 * change, back to 0 after the move); position and speed as without the filter */
static void smooth(void)
{
    ls_traj_cfg cfg = {0};
    ls_traj t, u;
    ls_pos x, y;
    LS_REAL v, w, a, b, a_prev = LS_R(0.0);
    const double k = 2.0 * PI * 300.0 / 16000.0;
    double da_max = 0.0;
    long n;
    cfg.v_max = LS_R(0.25); cfg.a_max = LS_R(4.0); cfg.pole_pitch = (LS_REAL)TAU; cfg.fs = LS_R(16000.0);
    LS_CHECK(ls_traj_init(&u, &cfg) == LS_OK); /* unfiltered */
    cfg.a_lpf = LS_R(300.0);
    LS_CHECK(ls_traj_init(&t, &cfg) == LS_OK);
    ls_traj_reset(&t, from_m(0.0));
    ls_traj_reset(&u, from_m(0.0));
    ls_traj_move(&t, from_m(0.003)); /* triangular: +a_max, then -a_max */
    ls_traj_move(&u, from_m(0.003));
    for (n = 0; n < 16000; ++n) {
        ls_traj_step(&t, &x, &v, &a);
        ls_traj_step(&u, &y, &w, &b);
        LS_CHECK(x.period == y.period && x.theta == y.theta && v == w);
        if (fabs((double)(a - a_prev)) > da_max) da_max = fabs((double)(a - a_prev));
        a_prev = a;
    }
    LS_CHECK(da_max <= k * 8.0 * 1.0001 && da_max > 0.5 * k * 4.0); /* (the largest: -a_max - a_max) */
    LS_CHECK(fabs((double)a) < 1e-6); /* back to 0 after the move */
}

static void refused(LS_REAL v_max, LS_REAL a_max, LS_REAL v_step, LS_REAL a_step)
{
    ls_traj_cfg cfg = {0};
    ls_traj t;
    cfg.v_max = v_max; cfg.a_max = a_max; cfg.v_step = v_step; cfg.a_step = a_step;
    cfg.pole_pitch = (LS_REAL)TAU; cfg.fs = LS_R(16000.0);
    LS_CHECK(ls_traj_init(&t, &cfg) == LS_ERR_PARAM);
}

int main(void)
{
    ls_pos zero = {0, LS_R(0.0)};
    ls_pos far = {-20, LS_R(1.0)}; /* 1.1 m from the origin */
    run(0.006, 0.2, 1.0, zero);    /* 6 mm: triangular (shorter than v^2/a = 40 mm) */
    run(0.1, 0.2, 1.0, zero);      /* 100 mm: trapezoidal */
    run(-0.05, 0.2, 1.0, far);     /* backwards, far from the origin */
    run(2.0, 0.5, 2.0, far);       /* a 2 m move */
    jump();
    refused(LS_R(0.0), LS_R(1.0), LS_R(0.0), LS_R(0.0));     /* no speed */
    refused(LS_R(0.2), LS_R(1.0), LS_R(0.0), LS_R(4.0));     /* a step's acceleration, no speed */
    refused(LS_R(0.2), LS_R(1.0), LS_R(0.25), LS_R(-1.0));   /* negative step acceleration */
    refused(LS_R(0.2), LS_R(1.0), LS_R(-0.25), LS_R(0.0));   /* negative step speed */
    refused(LS_R(0.2), LS_R(1.0), LS_R(0.25), (LS_REAL)NAN); /* non-finite */
    smooth();
    {
        ls_traj_cfg cfg = {0};
        ls_traj t;
        cfg.v_max = LS_R(0.2); cfg.a_max = LS_R(1.0); cfg.pole_pitch = (LS_REAL)TAU; cfg.fs = LS_R(16000.0);
        cfg.a_lpf = LS_R(-1.0);
        LS_CHECK(ls_traj_init(&t, &cfg) == LS_ERR_PARAM);
        cfg.a_lpf = (LS_REAL)NAN;
        LS_CHECK(ls_traj_init(&t, &cfg) == LS_ERR_PARAM);
        cfg.a_lpf = LS_R(17000.0); /* beyond fs */
        LS_CHECK(ls_traj_init(&t, &cfg) == LS_ERR_PARAM);
    }
    return ls_test_report("test_traj");
}
