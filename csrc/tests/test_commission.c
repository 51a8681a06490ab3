/* LS_MODE_COMMISSION (ls_drive_commission.c): the end-effect table learned without a sensor.
 *  - ls_drive_set_mode refuses it without the EMF estimate, the table, the work, a demodulator
 *    table over the one learned, or with a rate k_int ts >= 1;
 *  - around the compact test plant (ecce2010, no dead time), back and forth at 1 m/s, a table
 *    started at half the true one (and one at zero points on the reversals' HF estimate) is learned
 *    to within 0.3 deg of the resistance-aware model table, every point seen both ways. */
#include <math.h>
#include <string.h>

#include "linsense/ls_drive.h"
#include "ls_lut_ecce2010_r.h"
#include "ls_test.h"
#include "ls_test_plant.h"

#define DEG (TP_PI / 180.0)
#define N 36u

static float g_table[N];
static float g_learn[4u * N];
static ls_lut g_lut, g_true;

/* The drive of the whole speed range (cfg.emf_on) on the test plant: the paper's pulsating
 * injection, no dead time, moves at 1 m/s and 10 m/s^2; its demodulator reading g_table. */
static void setup(ls_drive *d, ls_drive_cfg *cfg)
{
    ls_lut_cfg lt = {g_table, N};
    ls_lut_cfg lr = {ls_lut_ecce2010_r, LS_LUT_ECCE2010_R_LEN};
    LS_CHECK(ls_lut_init(&g_true, &lr) == LS_OK);
    LS_CHECK(ls_lut_init(&g_lut, &lt) == LS_OK);
    ls_drive_default_cfg(cfg);
    cfg->mod.dtc = false;
    cfg->mod.dead_time = LS_R(0.0);
    cfg->inject.quad = LS_R(0.0);
    cfg->emf_on = true;
    cfg->demod.comp = &g_lut;
    cfg->traj.v_max = LS_R(1.0);
    cfg->traj.a_max = LS_R(10.0);
    cfg->pos.v_max = LS_R(1.2);
    cfg->traj.v_step = LS_R(1.2);
    cfg->cal.points = N;
    cfg->cal.table = g_table;
    cfg->cal.learn = g_learn;
    cfg->cal.k_int = LS_R(400.0);
    cfg->cal.t_hold = LS_R(0.03);
    cfg->cal.slope = LS_R(1.0); /* (the pulsating injection's) */
    cfg->cal.t_settle = LS_R(0.02);
    LS_CHECK(ls_drive_init(d, cfg) == LS_OK);
}

static void test_refusals(void)
{
    ls_drive d;
    ls_drive_cfg cfg, bad;
    static float other[N];
    ls_lut_cfg lo = {other, N};
    ls_lut lut_other;
    setup(&d, &cfg);
    LS_CHECK(ls_lut_init(&lut_other, &lo) == LS_OK);
    LS_CHECK(ls_drive_set_mode(&d, LS_MODE_COMMISSION) == LS_OK);
    bad = cfg; bad.emf_on = false;
    LS_CHECK(ls_drive_init(&d, &bad) == LS_OK && ls_drive_set_mode(&d, LS_MODE_COMMISSION) == LS_ERR_PARAM);
    bad = cfg; bad.cal.learn = NULL;
    LS_CHECK(ls_drive_init(&d, &bad) == LS_OK && ls_drive_set_mode(&d, LS_MODE_COMMISSION) == LS_ERR_PARAM);
    bad = cfg; bad.cal.table = NULL;
    LS_CHECK(ls_drive_init(&d, &bad) == LS_OK && ls_drive_set_mode(&d, LS_MODE_COMMISSION) == LS_ERR_PARAM);
    bad = cfg; bad.demod.comp = NULL;
    LS_CHECK(ls_drive_init(&d, &bad) == LS_OK && ls_drive_set_mode(&d, LS_MODE_COMMISSION) == LS_ERR_PARAM);
    bad = cfg; bad.demod.comp = &lut_other; /* the demodulator reads another table */
    LS_CHECK(ls_drive_init(&d, &bad) == LS_OK && ls_drive_set_mode(&d, LS_MODE_COMMISSION) == LS_ERR_PARAM);
    bad = cfg; bad.cal.points = N - 1u; /* not the demodulator's table's length */
    LS_CHECK(ls_drive_init(&d, &bad) == LS_OK && ls_drive_set_mode(&d, LS_MODE_COMMISSION) == LS_ERR_PARAM);
    bad = cfg; bad.cal.k_int = bad.fs; /* k_int ts = 1: the estimates would overshoot */
    LS_CHECK(ls_drive_init(&d, &bad) == LS_OK && ls_drive_set_mode(&d, LS_MODE_COMMISSION) == LS_ERR_PARAM);
    bad = cfg; bad.cal.slope = LS_R(0.0);
    LS_CHECK(ls_drive_init(&d, &bad) == LS_OK && ls_drive_set_mode(&d, LS_MODE_COMMISSION) == LS_ERR_PARAM);
    bad = cfg; bad.cal.slope = LS_DRIVE_CAL_SLOPE_MAX * LS_R(1.01);
    LS_CHECK(ls_drive_init(&d, &bad) == LS_OK && ls_drive_set_mode(&d, LS_MODE_COMMISSION) == LS_ERR_PARAM);
    bad = cfg; bad.cal.slope = (LS_REAL)NAN;
    LS_CHECK(ls_drive_init(&d, &bad) == LS_OK && ls_drive_set_mode(&d, LS_MODE_COMMISSION) == LS_ERR_PARAM);
    /* a cruise that never leaves the band: nothing to learn */
    bad = cfg; bad.traj.v_max = cfg.fuse.v_hi;
    LS_CHECK(ls_drive_init(&d, &bad) == LS_OK && ls_drive_set_mode(&d, LS_MODE_COMMISSION) == LS_ERR_PARAM);
    LS_CHECK(d.mode == LS_MODE_OFF);
}

/* Back and forth between x0 and x0 + stroke until cal_done or t_max; returns the time taken. */
static double commission(ls_drive *d, tp_plant *p, double x0, double stroke, double t_max, ls_cmd *c)
{
    long k, n = (long)(t_max * p->fs);
    int leg = 0;
    ls_meas m;
    LS_CHECK(ls_drive_set_position(d, tp_pos_of_m(p->x, p->tau)) == LS_OK);
    LS_CHECK(ls_drive_set_mode(d, LS_MODE_COMMISSION) == LS_OK);
    memset(c, 0, sizeof *c);
    for (k = 0; k < n && !c->cal_done && c->fault == 0; ++k) {
        if (k > (long)(0.1 * p->fs) && !d->traj.active) { /* (after 0.1 s of HF lock) */
            LS_CHECK(ls_drive_move_to(d, tp_pos_of_m(x0 + (leg % 2 == 0 ? stroke : 0.0), p->tau)) == LS_OK);
            leg++;
        }
        tp_measure(p, &m);
        ls_drive_step(d, &m, c);
        tp_advance(p, c);
    }
    return (double)k / p->fs;
}

static double worst_deg(void)
{
    unsigned i;
    double worst = 0.0;
    for (i = 0; i < N; ++i) {
        double e = (double)g_table[i] - (double)ls_lut_step(&g_true, (LS_REAL)(2.0 * TP_PI * i / N));
        worst = fmax(worst, fabs(e));
    }
    return worst / DEG;
}

static void test_learning(double start_share)
{
    ls_drive d;
    ls_drive_cfg cfg;
    tp_plant p;
    ls_cmd c;
    unsigned i;
    double t, before, after, t_min = 1e9;
    for (i = 0; i < N; ++i) {
        g_table[i] = (float)(start_share * (double)ls_lut_ecce2010_r[i * (LS_LUT_ECCE2010_R_LEN / N)]);
    }
    setup(&d, &cfg);
    before = worst_deg();
    tp_init(&p, 0.0);
    t = commission(&d, &p, 0.0, 0.3, 12.0, &c);
    after = worst_deg();
    for (i = 0; i < 2u * N; ++i) {
        t_min = fmin(t_min, (double)g_learn[2u * N + i]);
    }
    printf("  commissioning from %.0f %% of the table: %s after %.2f s, fault 0x%x, worst %.3f -> %.3f deg, "
           "least time per point and direction %.3f s\n", 100.0 * start_share, c.cal_done ? "done" : "NOT done",
           t, (unsigned)c.fault, before, after, t_min);
    LS_CHECK(c.fault == 0);
    LS_CHECK(c.cal_done && c.cal_index == N);
    LS_CHECK(t_min >= (double)cfg.cal.t_hold);
    LS_CHECK(after < 0.1); /* (measured 0.02-0.04: the test plant has no dead time) */
    LS_CHECK(start_share == 1.0 || after < 0.5 * before); /* (it learned: not the start left as it was) */
}

int main(void)
{
    test_refusals();
    test_learning(0.5);
    test_learning(0.0);
    return ls_test_report("test_commission");
}
