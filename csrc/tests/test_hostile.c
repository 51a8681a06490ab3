/* Hostile inputs and configurations: every class the fuzzer (fuzz_drive.c) explores,
 * as deterministic cases that name the documented result:
 *  - positions: ls_pos_check refuses, ls_pos_norm_full saturates, no float-to-int overflow;
 *  - the drive's setters refuse huge, non-finite and out-of-range targets (nothing changes) and
 *    accept the range's ends, towards which the drive pushes the right way;
 *  - init refuses absurd gains (observer per-step gains, current loop, filters, demodulator, the
 *    drive's bounds on fs, currents, bus, encoder limit, calibration period);
 *  - the voltage limit cannot overflow;
 *  - encoder jumps and counts beyond the range trip LS_FAULT_ENCODER;
 *  - NaN and Inf measurements trip a fault; no non-finite value ever leaves ls_drive_step. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "linsense/ls_drive.h"
#include "ls_test.h"

#define TWO_PI_D 6.28318530717958647692
#ifdef LS_REAL_DOUBLE
#define NEXTAFTER_ nextafter
#else
#define NEXTAFTER_ nextafterf
#endif

static const float comp_tab[8] = {0.0f, 0.05f, 0.07f, 0.05f, 0.0f, -0.05f, -0.07f, -0.05f};
static ls_lut g_comp;

static void default_cfg(ls_drive_cfg *cfg)
{
    ls_lut_cfg lc = {comp_tab, 8u};
    LS_CHECK(ls_lut_init(&g_comp, &lc) == LS_OK);
    ls_drive_default_cfg(cfg);
    cfg->demod.comp = &g_comp;
}

static ls_pos mkpos(int32_t period, LS_REAL theta)
{
    ls_pos p;
    p.period = period;
    p.theta = theta;
    return p;
}

static bool pos_ok(ls_pos p)
{
    return p.theta >= LS_R(0.0) && p.theta < LS_TWO_PI && p.period <= LS_POS_PERIOD_MAX &&
           p.period >= -LS_POS_PERIOD_MAX;
}

static bool cmd_ok(const ls_cmd *c)
{
    const LS_REAL s = c->v_est + c->v_fb + c->f_load_est + c->err_sig + c->hf_level + c->psi_comp + c->i_dq[0] +
                      c->i_dq[1] + c->i_dq_ref[0] + c->i_dq_ref[1] + c->v_dq[0] + c->v_dq[1] + c->v_hf + c->psi_cal;
    int k;
    for (k = 0; k < 3; ++k) {
        if (!(c->duty[k] >= LS_R(0.0) && c->duty[k] <= LS_R(1.0))) {
            return false;
        }
    }
    return LS_ISFINITE(s) && pos_ok(c->pos_fb) && pos_ok(c->pos_est) && pos_ok(c->pos_ref) &&
           !(c->fault != 0u && c->enable);
}

static void meas_zero(ls_meas *m, int32_t enc)
{
    m->i_abc[0] = m->i_abc[1] = m->i_abc[2] = LS_R(0.0);
    m->v_dc = LS_R(72.0);
    m->enc_valid = true;
    m->enc_count = enc;
}

/* ------------------------------------------------------------------------------ positions */
static void test_pos(void)
{
    ls_pos p;
    /* refused by ls_pos_check: non-finite theta, period beyond the range, a huge theta */
    p = mkpos(0, (LS_REAL)NAN);
    LS_CHECK(!ls_pos_check(&p));
    p = mkpos(0, (LS_REAL)INFINITY);
    LS_CHECK(!ls_pos_check(&p));
    p = mkpos(INT32_MAX, LS_R(0.0));
    LS_CHECK(!ls_pos_check(&p) && p.period == INT32_MAX); /* unchanged when refused */
    p = mkpos(0, LS_R(1e30));
    LS_CHECK(!ls_pos_check(&p));
    p = mkpos(LS_POS_PERIOD_MAX, LS_R(7.0)); /* one period beyond the end once normalised */
    LS_CHECK(!ls_pos_check(&p));
    /* accepted, normalised: the range's end, a negative angle */
    p = mkpos(LS_POS_PERIOD_MAX, LS_R(1.0));
    LS_CHECK(ls_pos_check(&p) && p.period == LS_POS_PERIOD_MAX);
    p = mkpos(0, LS_R(-1.0));
    LS_CHECK(ls_pos_check(&p) && p.period == -1 && p.theta > LS_R(5.0) && p.theta < LS_TWO_PI);
    /* ls_pos_norm_full saturates at the end in the direction of the position */
    p = mkpos(0, LS_R(1e30));
    LS_CHECK(ls_pos_norm_full(&p) && p.period == LS_POS_PERIOD_MAX && p.theta == LS_R(0.0));
    p = mkpos(0, -LS_R(1e30));
    LS_CHECK(ls_pos_norm_full(&p) && p.period == -LS_POS_PERIOD_MAX && p.theta == LS_R(0.0));
    p = mkpos(INT32_MIN, LS_R(3e38));
    LS_CHECK(ls_pos_norm_full(&p) && p.period == -LS_POS_PERIOD_MAX);
    p = mkpos(-LS_POS_PERIOD_MAX, LS_R(-0.1));
    LS_CHECK(ls_pos_norm_full(&p) && p.period == -LS_POS_PERIOD_MAX && p.theta == LS_R(0.0));
    /* a large theta within the range: normalised exactly into [0, 2 pi) */
    p = ls_pos_norm(mkpos(5, LS_R(1.0e8)));
    LS_CHECK(pos_ok(p) && fabs((double)p.period - (5.0 + floor(1.0e8 / TWO_PI_D))) <= 2.0);
    /* the hot path's add across the end saturates there instead of overflowing */
    p = ls_pos_add(mkpos(LS_POS_PERIOD_MAX, LS_R(6.0)), LS_R(1.0));
    LS_CHECK(p.period == LS_POS_PERIOD_MAX && p.theta == LS_R(0.0));
    /* the per-step slow path's shortcuts across one end of the period (ls_pos_norm_wide) give
     * ls_pos_norm_full's result bit for bit, at and around their bounds and the range's ends */
    {
        static const int32_t periods[] = {0, 7, -7, LS_POS_PERIOD_MAX - 1, -LS_POS_PERIOD_MAX + 1,
                                          LS_POS_PERIOD_MAX, -LS_POS_PERIOD_MAX};
        const LS_REAL base[] = {LS_TWO_PI, LS_R(1.5) * LS_TWO_PI, -LS_PI, LS_R(0.0), LS_R(-1e-30), LS_R(3.0)};
        size_t i, j;
        int k;
        for (i = 0; i < sizeof periods / sizeof periods[0]; ++i) {
            for (j = 0; j < sizeof base / sizeof base[0]; ++j) {
                LS_REAL th = base[j];
                for (k = 0; k < 3; ++k) {
                    ls_pos full = mkpos(periods[i], th), wide = ls_pos_norm_wide(full);
                    (void)ls_pos_norm_full(&full);
                    LS_CHECK(wide.period == full.period && memcmp(&wide.theta, &full.theta, sizeof th) == 0);
                    full = mkpos(periods[i], -th);
                    wide = ls_pos_norm_wide(full);
                    (void)ls_pos_norm_full(&full);
                    LS_CHECK(wide.period == full.period && memcmp(&wide.theta, &full.theta, sizeof th) == 0);
                    th = k == 0 ? NEXTAFTER_(th, LS_R(-100.0)) : NEXTAFTER_(base[j], LS_R(100.0));
                }
            }
        }
    }
    /* the difference of the range's ends does not overflow */
    LS_CHECK_NEAR(ls_pos_diff(mkpos(LS_POS_PERIOD_MAX, 0), mkpos(-LS_POS_PERIOD_MAX, 0)),
                  2.0 * LS_POS_PERIOD_MAX * TWO_PI_D, 1e3);
}

static void test_lut_huge_angle(void)
{
    ls_lut l;
    ls_lut_cfg lc = {comp_tab, 8u};
    LS_CHECK(ls_lut_init(&l, &lc) == LS_OK);
    LS_CHECK(ls_lut_step(&l, LS_R(1e30)) == (LS_REAL)comp_tab[0]);
    LS_CHECK(ls_lut_step(&l, -LS_R(3e38)) == (LS_REAL)comp_tab[0]);
    LS_CHECK(ls_lut_step(&l, (LS_REAL)NAN) == LS_R(0.0));
    LS_CHECK_NEAR(ls_lut_step(&l, LS_TWO_PI * LS_R(3.0) + LS_TWO_PI / LS_R(8.0)), comp_tab[1], 1e-4);
    LS_CHECK_NEAR(ls_lut_step(&l, -LS_R(1e-30)), comp_tab[0], 1e-6);
}

/* A move across the whole range lasts longer than the step counter counts (2^32 steps): it ends
 * where 2^31 steps take it, in its direction, instead of wrapping back to its start. */
static void test_traj_long_move(void)
{
    ls_traj t;
    ls_traj_cfg tc;
    ls_pos x;
    LS_REAL v, a;
    int sgn, k;
    tc.v_max = LS_R(0.2);
    tc.a_max = LS_R(1.0);
    tc.v_step = LS_R(0.0);
    tc.a_step = LS_R(0.0);
    tc.a_lpf = LS_R(0.0);
    tc.pole_pitch = LS_R(0.056);
    tc.fs = LS_R(16000.0);
    for (sgn = -1; sgn <= 1; sgn += 2) {
        LS_CHECK(ls_traj_init(&t, &tc) == LS_OK);
        ls_traj_move(&t, mkpos(sgn * LS_POS_PERIOD_MAX, LS_R(0.0)));
        LS_CHECK(t.active && (double)t.t_total * 16000.0 <= 2147483648.0 * 1.0001);
        LS_CHECK(pos_ok(t.target) && sgn * t.target.period > 100000 && sgn * t.target.period < LS_POS_PERIOD_MAX);
        for (k = 0; k < 2000; ++k) {
            ls_traj_step(&t, &x, &v, &a);
        }
        LS_CHECK((LS_REAL)sgn * v > LS_R(0.0) && sgn * x.period >= 0);
    }
    /* a move within the limit is not shortened */
    LS_CHECK(ls_traj_init(&t, &tc) == LS_OK);
    ls_traj_move(&t, mkpos(1000, LS_R(0.0)));
    LS_CHECK(t.target.period == 1000 && t.target.theta == LS_R(0.0));
}

/* ------------------------------------------------------------------------------ setters */
static void test_setters_refuse(void)
{
    ls_drive_cfg cfg;
    ls_drive d;
    ls_cmd c;
    ls_meas m;
    int k;
    default_cfg(&cfg);
    LS_CHECK(ls_drive_init(&d, &cfg) == LS_OK);
    LS_CHECK(ls_drive_set_position(NULL, mkpos(0, LS_R(0.0))) == LS_ERR_NULL);
    LS_CHECK(ls_drive_set_position(&d, mkpos(3, LS_R(1.0))) == LS_OK);
    LS_CHECK(ls_drive_set_position(&d, mkpos(0, (LS_REAL)NAN)) == LS_ERR_PARAM);
    LS_CHECK(ls_drive_set_position(&d, mkpos(0, LS_R(1e30))) == LS_ERR_PARAM);
    LS_CHECK(d.obs.pos.period == 3 && d.obs.pos.theta == LS_R(1.0)); /* unchanged by the refusals */
    LS_CHECK(ls_drive_set_load(&d, (LS_REAL)INFINITY) == LS_ERR_PARAM);
    LS_CHECK(ls_drive_set_load(&d, LS_R(1e30)) == LS_OK && d.f_ref == cfg.pos.force_max);
    LS_CHECK(ls_drive_set_mode(&d, LS_MODE_SENSORLESS_LUT) == LS_OK);
    meas_zero(&m, 0);
    ls_drive_step(&d, &m, &c);
    LS_CHECK(ls_drive_move_to(&d, mkpos(0, LS_R(1e30))) == LS_ERR_PARAM);
    LS_CHECK(ls_drive_step_to(&d, mkpos(INT32_MAX, LS_R(0.0))) == LS_ERR_PARAM);
    LS_CHECK(ls_drive_step_to(&d, mkpos(INT32_MIN, LS_R(0.5))) == LS_ERR_PARAM);
    LS_CHECK(ls_drive_move_to(&d, mkpos(0, -(LS_REAL)INFINITY)) == LS_ERR_PARAM);
    for (k = 0; k < 10; ++k) {
        ls_drive_step(&d, &m, &c);
    }
    LS_CHECK(!d.traj.active && c.pos_ref.period == 3 && c.pos_ref.theta == LS_R(1.0)); /* no move at all */
    LS_CHECK(cmd_ok(&c));
}

/* The range's ends are accepted and the drive pushes towards them, never the wrong way (the
 * simulator once drove 205 mm the wrong way to a target of 1e300 mm). */
static void test_setters_ends(void)
{
    ls_drive_cfg cfg;
    ls_drive d;
    ls_cmd c;
    ls_meas m;
    int sgn, k, profiled;
    for (profiled = 0; profiled <= 1; ++profiled) { /* a step that jumps (a_step 0), one that moves */
        for (sgn = -1; sgn <= 1; sgn += 2) {
            default_cfg(&cfg);
            cfg.inject_sensored = false;
            if (!profiled) {
                cfg.traj.a_step = LS_R(0.0);
            }
            LS_CHECK(ls_drive_init(&d, &cfg) == LS_OK);
            LS_CHECK(ls_drive_set_mode(&d, LS_MODE_SENSORED) == LS_OK);
            meas_zero(&m, 0);
            ls_drive_step(&d, &m, &c);
            LS_CHECK(ls_drive_step_to(&d, mkpos(sgn * LS_POS_PERIOD_MAX, LS_R(0.0))) == LS_OK);
            for (k = 0; k < 20; ++k) {
                ls_drive_step(&d, &m, &c);
            }
            LS_CHECK(c.enable && cmd_ok(&c));
            if (profiled) { /* on its way in the target's direction (as far as LS_TRAJ_STEPS_MAX go) */
                LS_CHECK(d.traj.active && (LS_REAL)sgn * ls_pos_diff(c.pos_ref, mkpos(0, LS_R(0.0))) > LS_R(0.0));
                LS_CHECK((LS_REAL)sgn * ls_pos_diff(d.traj.target, mkpos(0, LS_R(0.0))) > LS_R(1.0e6));
            } else {
                LS_CHECK(c.pos_ref.period == sgn * LS_POS_PERIOD_MAX);
            }
            LS_CHECK((LS_REAL)sgn * c.i_dq_ref[1] > LS_R(0.0)); /* force towards the target */
        }
    }
}

/* ------------------------------------------------------------------------------ init bounds */
typedef void (*cfg_edit)(ls_drive_cfg *c);
static void e_obs_k1_huge(ls_drive_cfg *c) { c->obs.k1 = LS_R(1e30); }
static void e_obs_k1_step(ls_drive_cfg *c) { c->obs.k1 = LS_R(1.01) * c->fs; }
static void e_obs_k2_huge(ls_drive_cfg *c) { c->enc_obs.k2 = LS_R(1e30); }
static void e_obs_k3_mech(ls_drive_cfg *c)
{
    c->obs.type = LS_OBS_MECH;
    ls_observer_gains(&c->obs, LS_R(40.0));
    c->obs.k3 = LS_R(1.01) * c->fs * c->fs * c->fs;
}
static void e_obs_omega(ls_drive_cfg *c) { c->obs.omega_max = LS_R(1e30); }
static void e_obs_mass(ls_drive_cfg *c)
{
    c->obs.type = LS_OBS_MECH;
    ls_observer_gains(&c->obs, LS_R(40.0));
    c->obs.mass = LS_R(1e-38);
}
static void e_cur_kp(ls_drive_cfg *c) { c->current.kp = LS_R(1e30); }
static void e_cur_kp_edge(ls_drive_cfg *c) { c->current.kp = LS_R(2.0) * LS_CURRENT_KP_MAX; }
static void e_cur_ki(ls_drive_cfg *c) { c->current.ki = LS_R(1e12); }
static void e_cur_l(ls_drive_cfg *c) { c->current.l_q = LS_R(1e3); }
static void e_demod_gain(ls_drive_cfg *c) { c->demod.gain = LS_R(-1e5); }
static void e_q_tiny(ls_drive_cfg *c) { c->bpf.q = LS_R(1e-30); }
static void e_q_huge(ls_drive_cfg *c) { c->sep.q = LS_R(1e4); }
static void e_fs(ls_drive_cfg *c)
{
    const LS_REAL fs = LS_R(2.0) * LS_DRIVE_FS_MAX;
    c->fs = c->inject.fs = c->bpf.fs = c->sep.fs = c->demod.fs = c->obs.fs = c->enc_obs.fs = fs;
    c->current.fs = c->traj.fs = c->prot.fs = c->pos.speed.fs = c->dtres.fs = c->mod.f_pwm = fs;
}
/* the smallest denormal: the residual model's response overflows (found by the fuzzer) */
#ifdef LS_REAL_DOUBLE
static void e_dtres_l(ls_drive_cfg *c) { c->dtres.l_q = 4.9406564584124654e-324; }
#else
static void e_dtres_l(ls_drive_cfg *c) { c->dtres.l_q = 1.40129846e-45f; }
#endif
static void e_vdc(ls_drive_cfg *c) { c->prot.v_dc_max = LS_R(1e6); }
static void e_imax(ls_drive_cfg *c) { c->i_max = LS_R(1e6); }
static void e_pitch(ls_drive_cfg *c) { c->pole_pitch = LS_R(1e-38); }
/* a huge pitch, the same in every module: a speed in m/s was inf (found by the fuzzer: v_fb) */
static void e_pitch_huge(ls_drive_cfg *c)
{
    c->pole_pitch = c->obs.pole_pitch = c->enc_obs.pole_pitch = c->traj.pole_pitch = LS_R(1e30);
}
/* the observer counting in another pitch than the drive: its speed is not the controllers' */
static void e_pitch_obs(ls_drive_cfg *c) { c->obs.pole_pitch = LS_R(2.0) * c->pole_pitch; }
static void e_kf(ls_drive_cfg *c) { c->force_constant = (LS_REAL)NAN; }
static void e_enc_v0(ls_drive_cfg *c) { c->enc_v_max = LS_R(0.0); }
static void e_enc_vnan(ls_drive_cfg *c) { c->enc_v_max = (LS_REAL)NAN; }
static void e_enc_vhuge(ls_drive_cfg *c) { c->enc_v_max = LS_R(1e30); }
static void e_cal_period(ls_drive_cfg *c)
{
    static float tab[8];
    c->cal.table = tab;
    c->cal.points = 8u;
    c->cal.period = LS_POS_PERIOD_MAX + 1;
}

static void test_init_refuses(void)
{
    static const cfg_edit edits[] = {e_obs_k1_huge, e_obs_k1_step, e_obs_k2_huge, e_obs_k3_mech, e_obs_omega,
                                     e_obs_mass,    e_cur_kp,      e_cur_kp_edge, e_cur_ki,      e_cur_l,
                                     e_demod_gain,  e_q_tiny,      e_q_huge,      e_fs,          e_vdc,
                                     e_imax,        e_pitch,       e_pitch_huge,  e_pitch_obs,   e_kf,
                                     e_enc_v0,      e_enc_vnan,
                                     e_enc_vhuge,   e_cal_period,  e_dtres_l};
    size_t k;
    ls_drive_cfg cfg;
    ls_drive d;
    ls_cmd c;
    ls_meas m;
    meas_zero(&m, 0);
    for (k = 0; k < sizeof edits / sizeof edits[0]; ++k) {
        default_cfg(&cfg);
        edits[k](&cfg);
        if (ls_drive_init(&d, &cfg) != LS_ERR_PARAM) {
            printf("FAIL: edit %u accepted\n", (unsigned)k);
            ++ls_test_failed;
            continue;
        }
        ++ls_test_passed;
        ls_drive_step(&d, &m, &c); /* a refused drive does not run */
        LS_CHECK(!c.enable && c.fault == LS_FAULT_CONFIG);
    }
    /* just within the bounds: accepted */
    default_cfg(&cfg);
    cfg.obs.k1 = LS_R(0.99) * cfg.fs;
    cfg.current.kp = LS_CURRENT_KP_MAX;
    cfg.enc_v_max = LS_R(1e-6); /* less than a count per step: one count stays plausible */
    LS_CHECK(ls_drive_init(&d, &cfg) == LS_OK && d.enc_jump_max == 1);
    /* calibration values are checked with a table only, and read only then: without one, a dither
     * frequency that a table would refuse leaves the drive valid and converts nothing (the
     * sanitizer's float-cast-overflow check traps the conversion it used to make) */
    default_cfg(&cfg);
    cfg.cal.table = NULL;
    cfg.cal.dither_amp = LS_R(0.4);
    cfg.cal.dither_freq = LS_R(1e12);
    LS_CHECK(ls_drive_init(&d, &cfg) == LS_OK && d.cal_inc == 0u);
    cfg.cal.dither_freq = (LS_REAL)NAN;
    LS_CHECK(ls_drive_init(&d, &cfg) == LS_OK && d.cal_inc == 0u);
}

/* ------------------------------------------------------------------------------ voltage limit */
static void test_voltage_limit(void)
{
    ls_current cur;
    ls_current_cfg cc;
    LS_REAL vd, vq;
    memset(&cc, 0, sizeof cc);
    cc.kp = LS_CURRENT_KP_MAX;
    cc.ki = LS_R(0.0);
    cc.fs = LS_R(16000.0);
    LS_CHECK(ls_current_init(&cur, &cc) == LS_OK);
    /* an error so large that ud^2 overflows: the vector still lands on the circle, direction kept
     * (the naive scale v_max / sqrt(Inf) = 0 gave zero voltage) */
    ls_current_step(&cur, LS_R(0.0), LS_R(0.0), LS_R(3e25), LS_R(-4e25), LS_R(0.0), LS_R(10.0), &vd, &vq);
    LS_CHECK_NEAR(vd, 6.0, 1e-4);
    LS_CHECK_NEAR(vq, -8.0, 1e-4);
    ls_current_reset(&cur);
    /* one so large that a component itself overflows (float): its direction */
    ls_current_step(&cur, LS_R(0.0), LS_R(0.0), LS_R(0.0), LS_R(3e37), LS_R(0.0), LS_R(10.0), &vd, &vq);
    LS_CHECK_NEAR(vd, 0.0, 1e-4);
    LS_CHECK_NEAR(vq, 10.0, 1e-4);
    vd = LS_R(3e38);
    vq = LS_R(3e38);
    ls_current_limit_wide(LS_R(10.0), &vd, &vq);
    LS_CHECK_NEAR(vd, 10.0 / sqrt(2.0), 1e-4);
    LS_CHECK_NEAR(vq, 10.0 / sqrt(2.0), 1e-4);
    vd = -(LS_REAL)FLT_MIN;
    vq = LS_R(0.0);
    ls_current_limit_wide(LS_R(1.0), &vd, &vq);
    LS_CHECK_NEAR(vd, -1.0, 1e-6);
}

/* ------------------------------------------------------------------------------ encoder */
static void encoder_drive(ls_drive *d, int32_t counts)
{
    ls_drive_cfg cfg;
    default_cfg(&cfg);
    cfg.enc_counts = counts;
    LS_CHECK(ls_drive_init(d, &cfg) == LS_OK);
    LS_CHECK(ls_drive_set_mode(d, LS_MODE_SENSORED) == LS_OK);
}

static void test_encoder(void)
{
    ls_drive d;
    ls_cmd c;
    ls_meas m;
    int k;
    /* default: 5 m/s at 16 kHz and 1 um per count is 312 counts per step */
    encoder_drive(&d, 56000);
    LS_CHECK(d.enc_jump_max == 312);
    meas_zero(&m, 1000);
    ls_drive_step(&d, &m, &c);
    m.enc_count += 312;
    ls_drive_step(&d, &m, &c);
    LS_CHECK(c.fault == 0u && c.enable);
    m.enc_count -= 313;
    ls_drive_step(&d, &m, &c);
    LS_CHECK((c.fault & LS_FAULT_ENCODER) != 0u && !c.enable && cmd_ok(&c));
    /* between the int32 extremes every step: the first jump trips */
    encoder_drive(&d, 56000);
    for (k = 0; k < 6; ++k) {
        meas_zero(&m, (k & 1) ? INT32_MIN : INT32_MAX);
        ls_drive_step(&d, &m, &c);
        LS_CHECK(cmd_ok(&c));
    }
    LS_CHECK((c.fault & LS_FAULT_ENCODER) != 0u && !c.enable);
    /* a coarse encoder (6 counts per period): a one-count change is plausible, a count beyond
     * the position range is not (INT32_MAX / 6 periods) */
    encoder_drive(&d, 6);
    LS_CHECK(d.enc_jump_max == 1);
    meas_zero(&m, 0);
    ls_drive_step(&d, &m, &c);
    m.enc_count = 1;
    ls_drive_step(&d, &m, &c);
    LS_CHECK(c.fault == 0u);
    encoder_drive(&d, 6);
    meas_zero(&m, INT32_MAX);
    ls_drive_step(&d, &m, &c);
    LS_CHECK((c.fault & LS_FAULT_ENCODER) != 0u && cmd_ok(&c));
    /* sensorless modes ignore the encoder */
    encoder_drive(&d, 56000);
    LS_CHECK(ls_drive_set_mode(&d, LS_MODE_SENSORLESS_LUT) == LS_OK);
    for (k = 0; k < 4; ++k) {
        meas_zero(&m, (k & 1) ? INT32_MIN : INT32_MAX);
        ls_drive_step(&d, &m, &c);
    }
    LS_CHECK((c.fault & LS_FAULT_ENCODER) == 0u);
}

/* ------------------------------------------------------------------------------ measurements */
static void test_nonfinite_meas(void)
{
    static const float bad[] = {NAN, INFINITY, -INFINITY, 3e38f, -3e38f};
    ls_drive d;
    ls_cmd c;
    ls_meas m;
    size_t k;
    int which;
    for (which = 0; which < 4; ++which) {
        for (k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
            encoder_drive(&d, 56000);
            meas_zero(&m, 0);
            ls_drive_step(&d, &m, &c);
            if (which < 3) {
                m.i_abc[which] = (LS_REAL)bad[k];
            } else {
                m.v_dc = (LS_REAL)bad[k];
            }
            ls_drive_step(&d, &m, &c);
            LS_CHECK(c.fault != 0u && !c.enable && cmd_ok(&c));
            LS_CHECK(((c.fault & LS_FAULT_NONFINITE) != 0u) == !LS_ISFINITE(m.i_abc[0] + m.i_abc[1] + m.i_abc[2] + m.v_dc));
        }
    }
}

/* ls_pos_norm_full as it was with libm's floor (the reference of its own floor, which takes no libm
 * call): the same position bit for bit for every theta, any magnitude and sign, every period. */
static bool norm_ref(ls_pos *p)
{
    const LS_REAL k_lim = LS_R(2.0) * (LS_REAL)LS_POS_PERIOD_MAX + LS_R(4.0);
    LS_REAL th = p->theta, k;
    int32_t n = p->period;
    int round;
    if (th >= LS_R(0.0) && th < LS_TWO_PI && n <= LS_POS_PERIOD_MAX && n >= -LS_POS_PERIOD_MAX) {
        return false;
    }
    if (!LS_ISFINITE(th)) {
        th = LS_R(0.0);
    }
    if (n > LS_POS_PERIOD_MAX || n < -LS_POS_PERIOD_MAX) {
        p->period = n > 0 ? LS_POS_PERIOD_MAX : -LS_POS_PERIOD_MAX;
        p->theta = LS_R(0.0);
        return true;
    }
    for (round = 0; round < 2 && !(th >= LS_R(0.0) && th < LS_TWO_PI); ++round) {
        k = LS_FLOOR(th / LS_TWO_PI);
        if (!(LS_FABS(k) <= k_lim)) {
            p->period = k > LS_R(0.0) ? LS_POS_PERIOD_MAX : -LS_POS_PERIOD_MAX;
            p->theta = LS_R(0.0);
            return true;
        }
        n += (int32_t)k;
        th -= k * LS_TWO_PI;
    }
    if (th >= LS_TWO_PI) {
        th -= LS_TWO_PI;
        n += 1;
    } else if (th < LS_R(0.0)) {
        th += LS_TWO_PI;
        n -= 1;
        if (!(th < LS_TWO_PI)) {
            th = LS_R(0.0);
            n += 1;
        }
    }
    if (!(th >= LS_R(0.0) && th < LS_TWO_PI)) {
        th = LS_R(0.0);
    }
    if (n > LS_POS_PERIOD_MAX || n < -LS_POS_PERIOD_MAX) {
        p->period = n > 0 ? LS_POS_PERIOD_MAX : -LS_POS_PERIOD_MAX;
        p->theta = LS_R(0.0);
        return true;
    }
    p->period = n;
    p->theta = th;
    return false;
}

static void test_pos_floor(void)
{
    static const int32_t periods[] = {0, 3, -3, LS_POS_PERIOD_MAX - 2, -LS_POS_PERIOD_MAX + 2, LS_POS_PERIOD_MAX,
                                      -LS_POS_PERIOD_MAX};
    uint32_t x = 12345u;
    long k, bad = 0;
    size_t i;
    for (k = 0; k < 200000; ++k) {
        LS_REAL th;
        x = x * 1664525u + 1013904223u;
        /* a magnitude from 1e-30 to 1e12 (log-uniform), both signs; every 7th an integer multiple of
         * 2 pi and its neighbours (the floor's steps) */
        th = (LS_REAL)(pow(10.0, -30.0 + 42.0 * (double)(x >> 8) / 16777216.0) * ((x & 1u) ? -1.0 : 1.0));
        if (k % 7 == 0) {
            th = (LS_REAL)(x % 100000u) * LS_TWO_PI * ((x & 2u) ? LS_R(-1.0) : LS_R(1.0));
            th = (x & 4u) ? (LS_REAL)nextafterf((float)th, 0.0f) : th;
        }
        for (i = 0; i < sizeof periods / sizeof periods[0]; ++i) {
            ls_pos a = mkpos(periods[i], th), b = a;
            const bool sa = ls_pos_norm_full(&a), sb = norm_ref(&b);
            bad += sa != sb || a.period != b.period || memcmp(&a.theta, &b.theta, sizeof th) != 0;
        }
    }
    LS_CHECK(bad == 0);
}

/* ls_pos_add (the trajectory's reference: ls_pos_norm_wide's short paths) is the reference
 * normalisation's result bit for bit: offsets of every magnitude from a start anywhere in its period
 * (the multiples of 2 pi and their neighbours among them: the rounding edges), at periods in the
 * range and at its ends, and non-finite offsets. */
static void test_pos_add_far(void)
{
    static const int32_t periods[] = {0, 3, -3, LS_POS_PERIOD_MAX - 2, -LS_POS_PERIOD_MAX + 2, LS_POS_PERIOD_MAX,
                                      -LS_POS_PERIOD_MAX};
    static const double odd[] = {NAN, INFINITY, -INFINITY, 0.0, -0.0, 1e30, -1e30};
    uint32_t x = 54321u;
    long k, bad = 0, far = 0;
    size_t i;
    for (k = 0; k < 200000 + (long)(sizeof odd / sizeof odd[0]); ++k) {
        LS_REAL d, th0;
        x = x * 1664525u + 1013904223u;
        th0 = (LS_REAL)((double)(x >> 8) / 16777216.0 * TWO_PI_D);
        th0 = th0 < LS_TWO_PI ? th0 : LS_R(0.0);
        x = x * 1664525u + 1013904223u;
        d = (LS_REAL)(pow(10.0, -30.0 + 42.0 * (double)(x >> 8) / 16777216.0) * ((x & 1u) ? -1.0 : 1.0));
        if (k % 5 == 0) { /* the start's complement to a multiple of 2 pi, and its neighbours */
            d = (LS_REAL)(x % 100000u) * LS_TWO_PI * ((x & 2u) ? LS_R(-1.0) : LS_R(1.0)) - th0;
            d = (x & 4u) ? (LS_REAL)nextafterf((float)d, (x & 8u) ? 1e30f : -1e30f) : d;
        }
        if (k >= 200000) {
            d = (LS_REAL)odd[k - 200000];
        }
        for (i = 0; i < sizeof periods / sizeof periods[0]; ++i) {
            const ls_pos p = mkpos(periods[i], th0);
            const ls_pos a = ls_pos_add(p, d);
            ls_pos b = p;
            b.theta += d;
            (void)norm_ref(&b);
            bad += a.period != b.period || memcmp(&a.theta, &b.theta, sizeof a.theta) != 0;
            far += a.period != p.period;
        }
    }
    LS_CHECK(bad == 0);
    LS_CHECK(far > 100000); /* (most offsets leave the period) */
}

int main(void)
{
    test_pos();
    test_pos_floor();
    test_pos_add_far();
    test_lut_huge_angle();
    test_traj_long_move();
    test_setters_refuse();
    test_setters_ends();
    test_init_refuses();
    test_voltage_limit();
    test_encoder();
    test_nonfinite_meas();
    return ls_test_report("test_hostile");
}
