/* Trajectory: duration, peak speed and end position against the closed form (trapezoidal and
 * triangular), limits respected, and a 2 m move on the long-travel position type. */
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

static void run(double dist, double v_max, double a_max, ls_pos start)
{
    ls_traj_cfg cfg;
    ls_traj t;
    ls_pos x = {0, LS_R(0.0)}, target;
    LS_REAL v = LS_R(-1.0), a = LS_R(-1.0); /* (set by every ls_traj_step) */
    double T_expected, v_peak, t_end = -1, x0 = to_m(start), vmax_seen = 0, prev = x0, dx_max = 0;
    long k;
    cfg.v_max = (LS_REAL)v_max; cfg.a_max = (LS_REAL)a_max; cfg.pole_pitch = (LS_REAL)TAU; cfg.fs = LS_R(16000.0);
    LS_CHECK(ls_traj_init(&t, &cfg) == LS_OK);
    ls_traj_reset(&t, start);
    target = from_m(x0 + dist);
    ls_traj_move(&t, target);
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

int main(void)
{
    ls_pos zero = {0, LS_R(0.0)};
    ls_pos far = {-20, LS_R(1.0)}; /* 1.1 m from the origin */
    run(0.006, 0.2, 1.0, zero);    /* 6 mm: triangular (shorter than v^2/a = 40 mm) */
    run(0.1, 0.2, 1.0, zero);      /* 100 mm: trapezoidal */
    run(-0.05, 0.2, 1.0, far);     /* backwards, far from the origin */
    run(2.0, 0.5, 2.0, far);       /* a 2 m move */
    {
        ls_traj_cfg cfg = {LS_R(0.0), LS_R(1.0), LS_R(0.056), LS_R(16000.0)};
        ls_traj t;
        LS_CHECK(ls_traj_init(&t, &cfg) == LS_ERR_PARAM);
    }
    return ls_test_report("test_traj");
}
