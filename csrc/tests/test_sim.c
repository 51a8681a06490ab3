/* The simulator core under the sanitizers: a closed-loop sensorless run on the ecce2010 plant
 * (alpha-beta Fourier coefficients obtained here by a DFT of the closed-form L_ab of the test
 * plant), the open-loop path, the travel-limit fault and configuration refusals, the end effect
 * on the magnets' flux (per-phase PM flux). The physics
 * (accuracy against a 3x3 ABC reference, agreement with the Python model) is tested in Python:
 * tests/test_sim_accuracy.py, tests/test_sim_plant.py. */
#include <math.h>
#include <string.h>

#include "ls_sim.h"
#include "ls_lut_ecce2010_q.h" /* the table of the default (elliptical) injection */
#include "ls_test.h"
#include "ls_test_plant.h"

static void make_cfg(ls_sim_cfg *c, ls_sim_fidelity fid)
{
    tp_plant p;
    const int n = 16;
    int k, e, m;
    memset(c, 0, sizeof *c);
    tp_init(&p, 0.0);
    c->n_order = 3;
    for (m = 0; m < n; ++m) { /* DFT of L_ab(theta) over one period, orders 0..2 */
        double th = 2 * TP_PI * m / n, L[2][2], ent[3];
        tp_L_ab(&p, th, L);
        ent[0] = L[0][0]; ent[1] = L[1][1]; ent[2] = L[0][1];
        for (e = 0; e < 3; ++e) {
            for (k = 0; k < 3; ++k) {
                double w = (k == 0 ? 1.0 : 2.0) / n;
                c->lab_cos[e][k] += w * ent[e] * cos(k * th);
                c->lab_sin[e][k] += w * ent[e] * sin(k * th);
            }
        }
    }
    c->r_s = p.R; c->pole_pitch = p.tau; c->psi_pm = tp_psi_pm(&p); c->mass = p.mass;
    c->x_min = -0.5; c->x_max = 0.5; c->fidelity = fid; c->v_dc = 72.0; c->f_pwm = 16000.0;
    c->dead_time = 0.8e-6; c->i_gain[0] = c->i_gain[1] = c->i_gain[2] = 1.0; c->enc_counts = 56000;
    c->seed = 3; c->i_noise = 0.002; c->adc_bits = 12; c->adc_range = 10.0;
    c->motion = LS_SIM_FREE; c->decimate = 4; c->i_abort = 20.0;
}

static void closed_loop(ls_sim_fidelity fid)
{
    static double t[6000], x[6000], xe[6000], te[6000], i3[18000], fo[6000];
    static uint32_t fa[6000];
    ls_sim_cfg c;
    ls_sim_out o;
    ls_sim_cmd cmd = {0.05, 0.003, 1};
    ls_sim_result r;
    ls_lut_cfg lc = {ls_lut_ecce2010_q, LS_LUT_ECCE2010_Q_LEN};
    ls_lut lut;
    ls_drive_cfg dc;
    ls_drive d;
    ls_pos p0 = {0, LS_R(0.0)};
    int64_t k;
    double worst = 0.0;
    make_cfg(&c, fid);
    LS_CHECK(ls_sim_check(&c) == LS_OK);
    memset(&o, 0, sizeof o);
    o.t = t; o.x = x; o.x_est = xe; o.theta_err = te; o.i_abc = i3; o.force = fo; o.fault = fa;
    LS_CHECK(ls_lut_init(&lut, &lc) == LS_OK);
    ls_drive_default_cfg(&dc);
    dc.demod.comp = &lut;
    LS_CHECK(ls_drive_init(&d, &dc) == LS_OK);
    ls_drive_set_position(&d, p0);
    LS_CHECK(ls_drive_set_mode(&d, LS_MODE_SENSORLESS_LUT) == LS_OK);
    LS_CHECK(ls_sim_run(&c, &d, &cmd, 1, 24000, &o, &r) == LS_OK); /* 1.5 s, 3 mm move */
    LS_CHECK(r.fault == 0u && r.steps_done == 24000 && r.n_rec == 6000);
    for (k = 400; k < r.n_rec; ++k) {
        if (fabs(te[k]) > worst) worst = fabs(te[k]);
    }
    printf("  %s: 3 mm sensorless move, final %.3f mm, max estimation error %.2f deg\n",
           fid == LS_SIM_SWITCHING ? "switching" : "average", r.x_end * 1e3, worst * 180 / TP_PI);
    LS_CHECK_NEAR(r.x_end, 0.003, 3.0 / 360.0 * 0.056); /* the paper: < 3 deg at steady state */
    LS_CHECK(worst < 10.0 * TP_PI / 180); /* the paper: ~9 deg in transients */
    LS_CHECK_NEAR(t[1], 4.0 / 16000.0, 1e-12);
    /* stopped from outside: the run ends at its next poll, the fault says why */
    {
        volatile int32_t stop = 1;
        o.stop = &stop;
        LS_CHECK(ls_sim_run(&c, &d, &cmd, 1, 24000, &o, &r) == LS_OK);
        LS_CHECK(r.steps_done == 0 && (r.fault & LS_SIM_FAULT_STOPPED) != 0u);
        stop = 0;
        LS_CHECK(ls_sim_run(&c, &d, &cmd, 1, 2 * LS_SIM_STOP_POLL, &o, &r) == LS_OK);
        LS_CHECK(r.steps_done == 2 * LS_SIM_STOP_POLL && (r.fault & LS_SIM_FAULT_STOPPED) == 0u);
        o.stop = NULL;
    }
}

/* ls_sim_begin/ls_sim_continue: a run in chunks (each a multiple of decimate but the last) writes bit
 * for bit the samples of one ls_sim_run; block statistics equal min/max/mean of a decimate = 1 run
 * over the same periods; a chunk that would continue a block is refused */
#define CH_STEPS 9001 /* not a multiple of the block: the last block is short */
#define CH_DEC 8
#define CH_REC (CH_STEPS / CH_DEC + 2)
/* a sensorless drive with the LUT at position 0 */
static void sensorless_drive(ls_drive *d, const ls_drive_cfg *dc)
{
    ls_pos p0 = {0, LS_R(0.0)};
    LS_CHECK(ls_drive_init(d, dc) == LS_OK);
    ls_drive_set_position(d, p0);
    LS_CHECK(ls_drive_set_mode(d, LS_MODE_SENSORLESS_LUT) == LS_OK);
}

static void chunks_and_blocks(ls_sim_fidelity fid)
{
    static double t1[CH_STEPS + 2], x1[CH_STEPS + 2], te1[CH_STEPS + 2], i1[3 * (CH_STEPS + 2)];
    static double tA[CH_REC], xA[CH_REC], xloA[CH_REC], xhiA[CH_REC], xmA[CH_REC], eloA[CH_REC], ehiA[CH_REC],
        emA[CH_REC], iloA[3 * CH_REC], ihiA[3 * CH_REC];
    static double tB[CH_REC], xB[CH_REC], xloB[CH_REC], xhiB[CH_REC], xmB[CH_REC], eloB[CH_REC], ehiB[CH_REC],
        emB[CH_REC], iloB[3 * CH_REC], ihiB[3 * CH_REC];
    static double buf[11][CH_REC], ibuf[2][3 * CH_REC];
    ls_sim_cfg c;
    ls_sim_out o1, oA, oB;
    ls_sim_cmd cmd = {0.05, 0.003, 1};
    ls_sim_result r1, rA, rB;
    ls_sim_state st;
    ls_lut_cfg lc = {ls_lut_ecce2010_q, LS_LUT_ECCE2010_Q_LEN};
    ls_lut lut;
    ls_drive_cfg dc;
    ls_drive d;
    int64_t k, n, done, chunk = 3 * CH_DEC * 50, rec = 0;
    int j, bad_blk = 0, bad_chunk = 0;
    make_cfg(&c, fid);
    c.seed = 11;
    ls_lut_init(&lut, &lc);
    ls_drive_default_cfg(&dc);
    dc.demod.comp = &lut;
    /* the reference: every period */
    c.decimate = 1;
    memset(&o1, 0, sizeof o1);
    o1.t = t1; o1.x = x1; o1.theta_err = te1; o1.i_abc = i1;
    sensorless_drive(&d, &dc);
    LS_CHECK(ls_sim_run(&c, &d, &cmd, 1, CH_STEPS, &o1, &r1) == LS_OK);
    LS_CHECK(r1.fault == 0u && r1.n_rec == CH_STEPS);
    /* one run with blocks */
    c.decimate = CH_DEC;
    memset(&oA, 0, sizeof oA);
    oA.t = tA; oA.x = xA; oA.x_min = xloA; oA.x_max = xhiA; oA.x_mean = xmA;
    oA.err_min = eloA; oA.err_max = ehiA; oA.err_mean = emA; oA.i_abc_min = iloA; oA.i_abc_max = ihiA;
    sensorless_drive(&d, &dc);
    LS_CHECK(ls_sim_run(&c, &d, &cmd, 1, CH_STEPS, &oA, &rA) == LS_OK);
    LS_CHECK(rA.n_rec == (CH_STEPS + CH_DEC - 1) / CH_DEC);
    for (k = 0; k < rA.n_rec; ++k) { /* against the decimate = 1 run over the same periods */
        int64_t a = k * CH_DEC, b = a + CH_DEC < CH_STEPS ? a + CH_DEC : CH_STEPS, m;
        double lo = x1[a], hi = x1[a], sum = 0.0, elo = te1[a], ehi = te1[a], esum = 0.0;
        for (m = a; m < b; ++m) {
            lo = fmin(lo, x1[m]); hi = fmax(hi, x1[m]); sum += x1[m];
            elo = fmin(elo, te1[m]); ehi = fmax(ehi, te1[m]); esum += te1[m];
            for (j = 0; j < 3; ++j) {
                if (i1[3 * m + j] < iloA[3 * k + j] || i1[3 * m + j] > ihiA[3 * k + j]) bad_blk++;
            }
        }
        if (xA[k] != x1[a] || tA[k] != t1[a] || xloA[k] != lo || xhiA[k] != hi || eloA[k] != elo || ehiA[k] != ehi ||
            fabs(xmA[k] - sum / (double)(b - a)) > 1e-15 || fabs(emA[k] - esum / (double)(b - a)) > 1e-15) {
            bad_blk++;
        }
    }
    LS_CHECK(bad_blk == 0);
    /* the same run in chunks of 1200 periods into one reused buffer */
    memset(&oB, 0, sizeof oB);
    oB.t = buf[0]; oB.x = buf[1]; oB.x_min = buf[2]; oB.x_max = buf[3]; oB.x_mean = buf[4];
    oB.err_min = buf[5]; oB.err_max = buf[6]; oB.err_mean = buf[7]; oB.i_abc_min = ibuf[0]; oB.i_abc_max = ibuf[1];
    sensorless_drive(&d, &dc);
    LS_CHECK(ls_sim_begin(&c, &st) == LS_OK);
    for (done = 0; done < CH_STEPS; done += n) {
        n = CH_STEPS - done < chunk ? CH_STEPS - done : chunk;
        LS_CHECK(ls_sim_continue(&c, &d, &cmd, 1, &st, n, &oB, &rB) == LS_OK);
        LS_CHECK(rB.steps_done == done + n);
        for (k = 0; k < rB.n_rec; ++k, ++rec) {
            tB[rec] = buf[0][k]; xB[rec] = buf[1][k]; xloB[rec] = buf[2][k]; xhiB[rec] = buf[3][k];
            xmB[rec] = buf[4][k]; eloB[rec] = buf[5][k]; ehiB[rec] = buf[6][k]; emB[rec] = buf[7][k];
            for (j = 0; j < 3; ++j) {
                iloB[3 * rec + j] = ibuf[0][3 * k + j];
                ihiB[3 * rec + j] = ibuf[1][3 * k + j];
            }
        }
    }
    LS_CHECK(rec == rA.n_rec && st.n_rec == rec && rB.x_end == rA.x_end && rB.v_end == rA.v_end);
    for (k = 0; k < rec; ++k) {
        if (memcmp(&tA[k], &tB[k], 8) || memcmp(&xA[k], &xB[k], 8) || memcmp(&xloA[k], &xloB[k], 8) ||
            memcmp(&xhiA[k], &xhiB[k], 8) || memcmp(&xmA[k], &xmB[k], 8) || memcmp(&eloA[k], &eloB[k], 8) ||
            memcmp(&ehiA[k], &ehiB[k], 8) || memcmp(&emA[k], &emB[k], 8) ||
            memcmp(&iloA[3 * k], &iloB[3 * k], 24) || memcmp(&ihiA[3 * k], &ihiB[3 * k], 24)) {
            bad_chunk++;
        }
    }
    LS_CHECK(bad_chunk == 0);
    /* a chunk that would continue a block begun in the previous one: refused */
    LS_CHECK(ls_sim_begin(&c, &st) == LS_OK);
    LS_CHECK(ls_sim_continue(&c, &d, &cmd, 1, &st, CH_DEC + 1, &oB, &rB) == LS_OK && rB.n_rec == 2);
    LS_CHECK(ls_sim_continue(&c, &d, &cmd, 1, &st, CH_DEC, &oB, &rB) == LS_ERR_PARAM);
    printf("  %s: chunks of %d periods == one run; blocks of %d == the decimate = 1 run\n",
           fid == LS_SIM_SWITCHING ? "switching" : "average", (int)chunk, CH_DEC);
}

static void open_loop_and_faults(void)
{
    static double t[16002], x[16002], i3[3 * 16002]; /* room for every step of the travel run */
    static uint32_t fa[16002];
    double seg_t[100], seg_v[300], bad_v[3] = {NAN, 0.0, 0.0};
    ls_sim_cfg c;
    ls_sim_out o;
    ls_sim_result r;
    ls_drive_cfg dc;
    ls_drive d;
    ls_sim_cmd far = {0.0, 0.4, 0};
    int k;
    make_cfg(&c, LS_SIM_AVERAGE);
    c.motion = LS_SIM_PRESCRIBED;
    c.v0 = 0.2;
    memset(&o, 0, sizeof o);
    o.t = t; o.x = x; o.i_abc = i3; o.fault = fa;
    for (k = 0; k < 100; ++k) {
        seg_t[k] = 1.0 / 16000.0;
        seg_v[3 * k] = 36.0 + 12.0 * cos(2 * TP_PI * 1000.0 * k / 16000.0);
        seg_v[3 * k + 1] = seg_v[3 * k + 2] = 36.0 - 6.0 * cos(2 * TP_PI * 1000.0 * k / 16000.0);
    }
    LS_CHECK(ls_sim_open_loop(&c, seg_t, seg_v, 100, &o, &r) == LS_OK);
    LS_CHECK(r.n_rec == 101 && r.fault == 0u);
    LS_CHECK_NEAR(x[100], 0.2 * 100.0 / 16000.0, 1e-12); /* prescribed speed */
    LS_CHECK(fabs(i3[300]) > 0.05 && fabs(i3[300]) < 2.0);
    LS_CHECK(ls_sim_open_loop(&c, seg_t, bad_v, 1, &o, &r) == LS_ERR_PARAM);
    /* refusals */
    c.n_order = 0;
    LS_CHECK(ls_sim_check(&c) == LS_ERR_PARAM);
    make_cfg(&c, LS_SIM_AVERAGE);
    c.x0 = 1.0; /* outside the travel */
    LS_CHECK(ls_sim_check(&c) == LS_ERR_PARAM);
    make_cfg(&c, LS_SIM_AVERAGE);
    c.lab_cos[0][0] = NAN;
    LS_CHECK(ls_sim_check(&c) == LS_ERR_PARAM);
    /* travel limit: a sensored step far beyond x_max stops the run cleanly */
    make_cfg(&c, LS_SIM_AVERAGE);
    c.x_max = 0.002;
    c.decimate = 1;
    ls_drive_default_cfg(&dc);
    LS_CHECK(ls_drive_init(&d, &dc) == LS_OK);
    LS_CHECK(ls_drive_set_mode(&d, LS_MODE_SENSORED) == LS_OK);
    LS_CHECK(ls_sim_run(&c, &d, &far, 1, 16000, &o, &r) == LS_OK);
    LS_CHECK((r.fault & LS_SIM_FAULT_TRAVEL) != 0u);
    LS_CHECK(r.steps_done < 16000 && r.n_rec == r.steps_done + 1);
    LS_CHECK(fa[r.n_rec - 1] == r.fault);
    LS_CHECK(LS_ISFINITE(x[r.n_rec - 1]) && x[r.n_rec - 1] > 0.002);
}

/* The saturated plant (ls_sim_sat) under the sanitizers: the test plant's true-dq inductances by a
 * DFT (orders 0..4) with no saturation give the linear plant's closed-loop run to within rounding
 * carried by the loop; with a d-axis saturation and a falling L_q the run still holds; bad
 * saturation blocks are refused. */
static void saturated(void)
{
    static double iA[3 * 2000], iB[3 * 2000], xA[2000], xB[2000];
    ls_sim_cfg c;
    ls_sim_out o;
    ls_sim_result r;
    ls_lut_cfg lc = {ls_lut_ecce2010_q, LS_LUT_ECCE2010_Q_LEN};
    ls_lut lut;
    ls_drive_cfg dc;
    ls_drive d;
    ls_sim_cmd cmd = {0.05, 0.003, 1};
    tp_plant p;
    const int n = 16;
    int k, e, m;
    double worst = 0.0, peak = 0.0, lam[2], li[3], dl[2], f, i0[2] = {0.3, -0.8};
    tp_init(&p, 0.0);
    make_cfg(&c, LS_SIM_SWITCHING);
    c.sat.n_order = 5;
    c.sat.n_pow = 1;
    for (m = 0; m < n; ++m) {
        double th = 2 * TP_PI * m / n, L[2][2], cs = cos(th), sn = sin(th), dq[3];
        tp_L_ab(&p, th, L);
        /* R' L R, R = [[cs, -sn], [sn, cs]] */
        dq[0] = cs * cs * L[0][0] + 2 * cs * sn * L[0][1] + sn * sn * L[1][1];
        dq[1] = -cs * sn * L[0][0] + (cs * cs - sn * sn) * L[0][1] + cs * sn * L[1][1];
        dq[2] = sn * sn * L[0][0] - 2 * cs * sn * L[0][1] + cs * cs * L[1][1];
        for (e = 0; e < 3; ++e) {
            for (k = 0; k < 5; ++k) {
                double w = (k == 0 ? 1.0 : 2.0) / n;
                c.sat.dq_cos[0][e][k] += w * dq[e] * cos(k * th);
                c.sat.dq_sin[0][e][k] += w * dq[e] * sin(k * th);
            }
        }
    }
    /* the evaluation: the linear flux L_ab i + lambda_pm and force */
    ls_sim_sat_eval(&c, 0.4, i0, lam, li, dl, &f);
    LS_CHECK_NEAR(f, ls_sim_force(&c, 0.4, i0), 1e-9);
    memset(&o, 0, sizeof o);
    LS_CHECK(ls_lut_init(&lut, &lc) == LS_OK);
    ls_drive_default_cfg(&dc);
    dc.demod.comp = &lut;
    /* the former slow loops (4 Hz speed, 10 1/s): two runs equal to rounding must not drift apart
     * through a dead-time limit cycle, which the default's 8 Hz, 20 1/s show at some positions */
    dc.pos.kp_x = 10.0;
    dc.pos.speed.kp = dc.pos.mass * 2.0 * TP_PI * 4.0;
    dc.pos.speed.ki = dc.pos.speed.kp * 2.0 * TP_PI * 4.0 / 4.0;
    o.i_abc = iA; o.x = xA;
    sensorless_drive(&d, &dc);
    LS_CHECK(ls_sim_run(&c, &d, &cmd, 1, 8000, &o, &r) == LS_OK && r.fault == 0u && r.n_rec == 2000);
    c.sat.on = 1;
    LS_CHECK(ls_sim_check(&c) == LS_OK);
    o.i_abc = iB; o.x = xB;
    sensorless_drive(&d, &dc);
    LS_CHECK(ls_sim_run(&c, &d, &cmd, 1, 8000, &o, &r) == LS_OK && r.fault == 0u && r.n_rec == 2000);
    /* to rounding over the first 0.08 s (standstill, the move's first 30 ms); afterwards a dead-time
     * edge whose phase current is within rounding of zero may be decided either way and the two runs,
     * each valid, part (float: at 0.084 s since the residual model has the back-EMF, which moves the
     * edges it predicts with the speed; double: at 0.115 s); both then end on the target */
    for (k = 0; k < 3 * 320; ++k) {
        if (fabs(iA[k] - iB[k]) > worst) worst = fabs(iA[k] - iB[k]);
        if (fabs(iA[k]) > peak) peak = fabs(iA[k]);
    }
    printf("  saturated plant without saturation vs linear, first 0.08 s of a switching closed loop: %.2e A of "
           "%.2f A; at 0.5 s %.4f and %.4f mm (target 3 mm)\n", worst, peak, xA[1999] * 1e3, xB[1999] * 1e3);
    LS_CHECK(worst < 1e-4 * peak);
    LS_CHECK(fabs(xA[1999] - 0.003) < 2e-4 && fabs(xB[1999] - 0.003) < 2e-4);
    /* saturating: 2 %/A of polarity at i_m = 34 A, L_q -5 % at 2 A */
    c.sat.i_m = 34.0;
    c.sat.i_sat_d = 75.0;
    c.sat.n_pow = 3;
    for (k = 0; k < 5; ++k) {
        c.sat.dq_cos[2][2][k] = -0.05 / 4.0 * c.sat.dq_cos[0][2][k];
        c.sat.dq_sin[2][2][k] = -0.05 / 4.0 * c.sat.dq_sin[0][2][k];
    }
    sensorless_drive(&d, &dc);
    LS_CHECK(ls_sim_run(&c, &d, &cmd, 1, 8000, &o, &r) == LS_OK && r.fault == 0u);
    LS_CHECK_NEAR(r.x_end, 0.003, 3.0 / 360.0 * 0.056);
    /* refusals */
    c.sat.n_pow = 0;
    LS_CHECK(ls_sim_check(&c) == LS_ERR_PARAM);
    c.sat.n_pow = LS_SIM_SAT_POW + 1;
    LS_CHECK(ls_sim_check(&c) == LS_ERR_PARAM);
    c.sat.n_pow = 3;
    c.sat.i_sat_d = -1.0;
    LS_CHECK(ls_sim_check(&c) == LS_ERR_PARAM);
    c.sat.i_sat_d = 75.0;
    c.sat.dq_sin[2][1][4] = NAN;
    LS_CHECK(ls_sim_check(&c) == LS_ERR_PARAM);
    c.sat.dq_sin[2][1][4] = 0.0;
    c.sat.on = 2;
    LS_CHECK(ls_sim_check(&c) == LS_ERR_PARAM);
    c.sat.on = 1;
    c.sat.n_order = LS_SIM_MAX_ORDER + 1;
    LS_CHECK(ls_sim_check(&c) == LS_ERR_PARAM);
}

/* the end effect on the magnets' flux (pm_dscale, pm_shift): the maps against the per-phase
 * fluxes written out here, the force from them, and the refusals */
static void unbalanced_pm(void)
{
    ls_sim_cfg c;
    const double ds[3] = {0.0, -0.08, 0.05}, sh[3] = {0.0, 0.05, -0.03};
    double lab[3], dlab[3], lpm[2], dlpm[2], ref[3] = {0.0, 0.0, 0.0};
    int k, j;
    make_cfg(&c, LS_SIM_AVERAGE);
    c.n_pm = 1; /* a 3rd harmonic: it cancels in a balanced set only */
    c.pm_order[0] = 3;
    c.pm_amp[0] = 0.05;
    c.pm_phase[0] = 0.4;
    for (k = 0; k < 3; ++k) {
        c.pm_dscale[k] = ds[k];
        c.pm_shift[k] = sh[k];
    }
    LS_CHECK(ls_sim_check(&c) == LS_OK);
    for (j = 0; j < 3; ++j) {
        const double th = -1.0 + 1.7 * j;
        double p[3], dp[3], a, b, da, db, i_ab[2] = {0.7, -1.3}, i3[3], f = 0.0;
        for (k = 0; k < 3; ++k) {
            const double u = th - 2.0 * TP_PI * k / 3.0 + sh[k], g = c.psi_pm * (1.0 + ds[k]);
            p[k] = g * (cos(u) + 0.05 * cos(3.0 * u + 0.4));
            dp[k] = g * (-sin(u) - 0.15 * sin(3.0 * u + 0.4));
        }
        a = (2.0 * p[0] - p[1] - p[2]) / 3.0;
        b = (p[1] - p[2]) / sqrt(3.0);
        da = (2.0 * dp[0] - dp[1] - dp[2]) / 3.0;
        db = (dp[1] - dp[2]) / sqrt(3.0);
        ls_sim_plant_eval(&c, th, lab, dlab, lpm, dlpm);
        LS_CHECK_NEAR(lpm[0], a, 1e-14);
        LS_CHECK_NEAR(lpm[1], b, 1e-14);
        LS_CHECK_NEAR(dlpm[0], da, 1e-14);
        LS_CHECK_NEAR(dlpm[1], db, 1e-14);
        ref[j] = lpm[0];
        /* the force: (2 pi / tau) (i_abc' dpsi_abc + 1/2 i_ab' dL_ab i_ab (3/2)) */
        i3[0] = i_ab[0];
        i3[1] = -0.5 * i_ab[0] + 0.5 * sqrt(3.0) * i_ab[1];
        i3[2] = -0.5 * i_ab[0] - 0.5 * sqrt(3.0) * i_ab[1];
        for (k = 0; k < 3; ++k) {
            f += i3[k] * dp[k];
        }
        f += 0.75 * (dlab[0] * i_ab[0] * i_ab[0] + dlab[1] * i_ab[1] * i_ab[1] + 2.0 * dlab[2] * i_ab[0] * i_ab[1]);
        f *= 2.0 * TP_PI / c.pole_pitch;
        LS_CHECK_NEAR(ls_sim_force(&c, th, i_ab), f, 1e-9 * fabs(f) + 1e-12);
    }
    /* balanced (all zero): the harmonic of order 3 drops out of alpha-beta */
    for (k = 0; k < 3; ++k) {
        c.pm_dscale[k] = 0.0;
        c.pm_shift[k] = 0.0;
    }
    for (j = 0; j < 3; ++j) {
        const double th = -1.0 + 1.7 * j;
        ls_sim_plant_eval(&c, th, lab, dlab, lpm, dlpm);
        LS_CHECK_NEAR(lpm[0], c.psi_pm * cos(th), 1e-15);
        LS_CHECK(fabs(lpm[0] - ref[j]) > 1e-3 * c.psi_pm);
    }
    /* refusals: a phase's flux vanishing or reversed, a non-finite shift */
    c.pm_dscale[1] = -1.0;
    LS_CHECK(ls_sim_check(&c) == LS_ERR_PARAM);
    c.pm_dscale[1] = NAN;
    LS_CHECK(ls_sim_check(&c) == LS_ERR_PARAM);
    c.pm_dscale[1] = 0.0;
    c.pm_shift[2] = INFINITY;
    LS_CHECK(ls_sim_check(&c) == LS_ERR_PARAM);
    c.pm_shift[2] = 0.0;
    LS_CHECK(ls_sim_check(&c) == LS_OK);
}

int main(void)
{
    closed_loop(LS_SIM_AVERAGE);
    closed_loop(LS_SIM_SWITCHING);
    chunks_and_blocks(LS_SIM_AVERAGE);
    chunks_and_blocks(LS_SIM_SWITCHING);
    open_loop_and_faults();
    saturated();
    unbalanced_pm();
    return ls_test_report("test_sim");
}
