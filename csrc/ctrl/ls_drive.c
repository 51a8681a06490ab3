/* The drive's API (see linsense/ls_drive.h): defaults, init, reset, modes, setters, and
 * ls_drive_step, which runs the step of the mode and injection shape from the step table below;
 * the steps live in a file per mode (ls_drive_internal.h lists them). */
#include <math.h>
#include <string.h>

#include "ls_drive_defaults.h"
#include "ls_drive_internal.h"

/* --------------------------------------------------------------------------- defaults */
void ls_drive_default_cfg(ls_drive_cfg *c)
{
    /* the design for the ecce2010 reference motor on the default drive: ls_drive_defaults.h, generated
     * by linsense.tune.defaults (docs/tuning.md); psi_pm = K_f tau / (3 pi) */
    const LS_REAL fs = LS_DEF_FS;
    const LS_REAL l_d = LS_DEF_L_D, l_q = LS_DEF_L_Q;
    const LS_REAL tau = LS_DEF_TAU, kf = LS_DEF_KF, mass = LS_DEF_MASS, r_s = LS_DEF_R_S;
    memset(c, 0, sizeof *c);
    c->lib_version = LS_VERSION;
    c->fs = fs;
    c->pole_pitch = tau;
    c->force_constant = kf;
    c->i_max = LS_DEF_I_MAX;
    c->delay_comp = LS_R(1.5);
    c->hf_delay = LS_DEF_HF_DELAY;
    c->enc_counts = 56000; /* 1 um per count */
    c->enc_v_max = LS_R(5.0); /* twice the over-speed limit below (250 rad/s: 2.2 m/s) */
    c->inject_sensored = true; /* the HF current dithers the dead time: no hunting (docs/simulator.md) */
    c->inject.amplitude = LS_DEF_INJ_AMPLITUDE;
    c->inject.freq = LS_DEF_INJ_FREQ;
    c->inject.fs = fs;
    c->inject.ramp_rate = LS_DEF_INJ_RAMP_RATE;
    c->inject.quad = LS_DEF_INJ_QUAD; /* elliptical: robust to the dead time (docs/theory.md) */
    c->bpf.type = LS_BIQUAD_BANDPASS;
    c->bpf.f0 = LS_DEF_INJ_FREQ;
    c->bpf.q = LS_R(2.0);
    c->bpf.fs = fs;
    c->sep.type = LS_BIQUAD_NOTCH;
    c->sep.f0 = LS_DEF_INJ_FREQ;
    c->sep.q = LS_R(2.0);
    c->sep.fs = fs;
    c->demod.method = LS_DEMOD_PRODUCT;
    c->demod.f_lpf = LS_DEF_DEMOD_LPF;
    c->demod.f_notch = LS_DEF_DEMOD_NOTCH; /* 2 f_inj: the products' ripple */
    c->demod.fs = fs;
    c->demod.gain = LS_DEF_DEMOD_GAIN;
    c->demod.comp = NULL;
    c->demod.gain_table = NULL;
    c->demod.comp_r = NULL;
    c->demod.gain_r = NULL;
    c->demod.min_level = LS_R(0.005);
    c->obs.type = LS_DEF_OBSERVER_MECH > 0 ? LS_OBS_MECH : LS_OBS_PLL;
    c->load_ff = LS_DEF_OBSERVER_MECH > 0; /* the mechanical observer's load estimate fed forward */
    c->obs.fs = fs;
    c->obs.pole_pitch = tau;
    c->obs.mass = mass;
    c->obs.omega_max = LS_R(300.0);
    c->obs.force_max = kf * c->i_max; /* the load the drive can hold */
    ls_observer_gains(&c->obs, LS_DEF_OBSERVER_BW); /* the design's rule (linsense.tune.design) */
    c->enc_obs = c->obs;
    c->enc_obs.type = LS_OBS_PLL;
    ls_observer_gains(&c->enc_obs, LS_R(200.0));
    c->current.kp = LS_DEF_CURRENT_KP;
    c->current.ki = LS_DEF_CURRENT_KI;
    c->current.l_d = l_d;
    c->current.l_q = l_q;
    c->current.psi_pm = kf * tau / (LS_R(3.0) * LS_PI);
    c->current.decouple = true;
    c->current.fs = fs;
    c->pos.type = LS_POSCTRL_P;
    c->pos.kp_x = LS_DEF_KP_X;
    c->pos.kd_x = LS_R(0.0);
    c->pos.v_max = LS_DEF_V_CAP;
    c->pos.mass = mass;
    c->pos.force_max = kf * c->i_max;
    c->pos.speed.kp = LS_DEF_SPEED_KP;
    c->pos.speed.ki = LS_DEF_SPEED_KI;
    c->pos.speed.out_min = -c->pos.force_max;
    c->pos.speed.out_max = c->pos.force_max;
    c->pos.speed.fs = fs;
    c->traj.v_max = LS_DEF_TRAJ_V_MAX;
    c->traj.a_max = LS_DEF_TRAJ_A_MAX;
    c->traj.v_step = LS_DEF_V_CAP;
    c->traj.a_step = LS_DEF_TRAJ_A_STEP;
    c->traj.a_lpf = LS_DEF_DEMOD_LPF;
    c->traj.pole_pitch = tau;
    c->traj.fs = fs;
    c->mod.f_pwm = fs;
    c->mod.dead_time = LS_DEF_DEAD_TIME;
    c->mod.dtc = true;
    c->mod.i_band = LS_R(0.05); /* A: a trade-off under dead time, see docs/simulator.md */
    c->mod.dtc_lead = LS_R(1.5);
    c->hf_dtres = true;
    c->dtres.fs = fs;
    c->dtres.r_s = r_s;
    c->dtres.l_d = l_d;
    c->dtres.l_q = l_q;
    c->dtres.forward = true;
    c->dtres.adapt = true;
    c->dtres.adapt_r = true;
    c->dtres.l_ea = LS_DEF_L_EA;
    c->dtres.l_eb = LS_DEF_L_EB;
    c->emf_on = LS_DEF_EMF_ON > 0; /* (the default speed cap stays below the band: off) */
    c->emf.fs = fs;
    c->emf.r_s = r_s;
    c->emf.l_d = l_d;
    c->emf.l_q = l_q;
    c->emf.f_lpf = LS_DEF_EMF_LPF;
    c->emf.omega_max = c->obs.omega_max;
    c->emf.err_r = LS_DEF_EMF_ERR_R;
    c->emf.err_l = LS_DEF_EMF_ERR_L;
    c->emf.u_err = LS_DEF_EMF_U_ERR;
    c->emf.i_noise = LS_DEF_EMF_I_NOISE;
    c->fuse.fs = fs;
    c->fuse.pole_pitch = tau;
    c->fuse.v_lo = LS_DEF_HAND_V_LO;
    c->fuse.v_hi = LS_DEF_HAND_V_HI;
    c->fuse.v_on = LS_DEF_INJ_V_ON;
    c->fuse.v_off = LS_DEF_INJ_V_OFF;
    c->fuse.t_settle = LS_DEF_HAND_T_SETTLE;
    c->prot.i_max = LS_R(6.0);
    c->prot.v_dc_min = LS_DEF_V_DC_MIN;
    c->prot.v_dc_max = LS_DEF_V_DC_MAX;
    c->prot.err_max = LS_R(0.6);
    c->prot.err_time = LS_R(0.05);
    c->prot.omega_max = LS_R(250.0);
    c->prot.fs = fs;
    c->cal.points = 56u;
    c->cal.table = NULL;
    c->cal.k_int = LS_R(60.0);
    c->cal.t_settle = LS_R(0.15);
    c->cal.t_hold = LS_R(0.1);
    c->cal.tol = LS_R(0.0005);
    c->cal.t_max = LS_R(3.0);
    c->cal.period = 0;
    c->cal.dither_amp = LS_DEF_DITHER_AMP;
    c->cal.dither_freq = LS_DEF_DITHER_FREQ; /* not a submultiple of the injection (50 Hz would be) */
    c->cal.slope = LS_R(1.0); /* the pulsating injection's (linsense designs the elliptical one's) */
    /* start-up (ls_startup.h): the design of linsense.tune.startup for ecce2010 with the FEA's
     * 1.31 %/A of a thin back iron and this drive, 10 mA rms of current noise and a 12-bit ADC: 2.8 A
     * at the end of a 7-period pulse, pairs for a decision 6 sigma clear (docs/tuning.md); the lock's
     * time is the library's own (a 40 Hz observer's) */
    c->startup.fs = fs;
    c->startup.t_lock = LS_R(0.07);
    c->startup.err_lock = LS_DEF_STARTUP_ERR_LOCK;
    c->startup.t_quiet = LS_DEF_STARTUP_T_QUIET; /* the injection's 10 ms ramp (12 V at 1200 V/s), and 2 ms */
    c->startup.v_pulse = LS_DEF_STARTUP_V_PULSE;
    c->startup.t_pulse = LS_DEF_STARTUP_T_PULSE;
    c->startup.t_rest = LS_DEF_STARTUP_T_REST;
    c->startup.pairs = (uint32_t)LS_DEF_STARTUP_PAIRS;
    c->startup.i_min = LS_DEF_STARTUP_I_MIN;
    c->startup.t_settle = LS_DEF_STARTUP_T_SETTLE;
    c->startup.lock_gain = LS_DEF_STARTUP_LOCK_GAIN;
}

/* --------------------------------------------------------------------------- init */
static bool pos_finite(LS_REAL x)
{
    return LS_ISFINITE(x) && x > LS_R(0.0);
}

/* The first step count n with n ts >= t (strict: n ts > t), as the float product decides it, for
 * a finite t >= 0, below 2^24 steps (17 min at 16 kHz; beyond, t / ts to the float's resolution);
 * UINT32_MAX where t / ts is beyond 4e9 (a time no calibration reaches). */
static uint32_t steps_of(LS_REAL t, LS_REAL ts, bool strict)
{
    const LS_REAL x = t / ts;
    uint32_t n;
    if (!(x < LS_R(4.0e9))) {
        return UINT32_MAX;
    }
    if (x >= LS_R(16777216.0)) {
        return (uint32_t)x; /* in range: 2^24 <= x < 4e9 */
    }
    n = x > LS_R(1.0) ? (uint32_t)x - 1u : 0u; /* in range: 0 <= x < 2^24, every n exact in float */
    while (strict ? !((LS_REAL)n * ts > t) : !((LS_REAL)n * ts >= t)) {
        n++; /* at most three times: n starts one below t / ts */
    }
    return n;
}

static bool step_table_complete(void);

/* The drive's own fields (each module checks its own in its init). */
static bool drive_fields_ok(const ls_drive_cfg *cfg)
{
    return pos_finite(cfg->fs) && pos_finite(cfg->pole_pitch) && pos_finite(cfg->force_constant) &&
           pos_finite(cfg->i_max) && LS_ISFINITE(cfg->i_d_inj) && LS_FABS(cfg->i_d_inj) < cfg->i_max &&
           LS_ISFINITE(cfg->i_d_near) && LS_FABS(cfg->i_d_near) < cfg->i_max && cfg->near_in >= LS_R(0.0) &&
           cfg->near_out >= cfg->near_in && cfg->near_out < LS_PI / LS_R(6.0) &&
           LS_ISFINITE(cfg->delay_comp) && !(cfg->delay_comp < LS_R(0.0)) && LS_ISFINITE(cfg->hf_delay) &&
           !(cfg->hf_delay < LS_R(0.0)) && !(cfg->hf_delay > LS_R(0.1)) &&
           cfg->enc_counts > 0 && pos_finite(cfg->enc_v_max) && !(cfg->fs > LS_DRIVE_FS_MAX) &&
           !(cfg->i_max > LS_DRIVE_I_MAX) && !(cfg->prot.i_max > LS_DRIVE_I_MAX) &&
           !(cfg->prot.v_dc_max > LS_DRIVE_V_DC_MAX) &&
           cfg->bpf.type == (cfg->inject.shape == LS_INJ_SQUARE ? LS_BIQUAD_DIFF : LS_BIQUAD_BANDPASS) &&
           (cfg->sep.type == LS_BIQUAD_NOTCH || cfg->sep.type == LS_BIQUAD_LOWPASS) &&
           !(cfg->load_ff && (cfg->obs.type != LS_OBS_MECH || !(cfg->pos.mass > LS_R(0.0)))) &&
           cfg->ripple_order >= 0 && cfg->ripple_order <= LS_DRIVE_RIPPLE_ORDER_MAX &&
           LS_ISFINITE2(cfg->ripple_c, cfg->ripple_s) &&
           LS_FABS(cfg->ripple_c) + LS_FABS(cfg->ripple_s) <= LS_DRIVE_RIPPLE_MAX;
}

/* The modules agree with the drive and with each other: the demodulation that goes with the
 * injection's shape, one pole pitch, one sampling rate. */
static bool modules_agree(const ls_drive_cfg *cfg)
{
    /* the square wave is separated from the fundamental by a low-pass (zeros at fs/2), not a notch,
     * and has no residual model (its current change is not a band-passed current: i_d_inj keeps the
     * phase currents off zero) */
    if ((cfg->inject.shape == LS_INJ_ROTATING) != (cfg->demod.method == LS_DEMOD_ROTATING) ||
        (cfg->inject.shape == LS_INJ_SQUARE && (cfg->sep.type != LS_BIQUAD_LOWPASS || cfg->hf_dtres))) {
        return false;
    }
    /* every module counts in the drive's pole pitch (an observer's speed in m/s, the controllers'
     * speed, the trajectory's), which is bounded: a pitch of 1e38 m made the speed inf (fuzzed) */
    if (cfg->pole_pitch > LS_DRIVE_POLE_PITCH_MAX || cfg->obs.pole_pitch != cfg->pole_pitch ||
        cfg->enc_obs.pole_pitch != cfg->pole_pitch || cfg->traj.pole_pitch != cfg->pole_pitch) {
        return false;
    }
    /* the EMF estimate and its hand-over: the pulsating or elliptical injection's sensorless step
     * (ls_drive_speed.c), in the drive's pitch and rate */
    if (cfg->emf_on && (cfg->inject.shape != LS_INJ_PULSATING || cfg->emf.fs != cfg->fs ||
                        cfg->fuse.fs != cfg->fs || cfg->fuse.pole_pitch != cfg->pole_pitch)) {
        return false;
    }
    /* every module samples at the drive rate */
    return cfg->inject.fs == cfg->fs && cfg->bpf.fs == cfg->fs && cfg->sep.fs == cfg->fs &&
           cfg->demod.fs == cfg->fs && cfg->obs.fs == cfg->fs && cfg->enc_obs.fs == cfg->fs &&
           cfg->current.fs == cfg->fs && cfg->traj.fs == cfg->fs && cfg->prot.fs == cfg->fs &&
           cfg->pos.speed.fs == cfg->fs;
}

/* The calibration's fields, when it has a table to fill. */
static bool calibration_ok(const ls_cal_cfg *cal, LS_REAL fs)
{
    return cal->table == NULL ||
           !(cal->points < 4u || cal->period > LS_POS_PERIOD_MAX || cal->period < -LS_POS_PERIOD_MAX ||
             !pos_finite(cal->k_int) || !LS_ISFINITE(cal->t_settle) || cal->t_settle < LS_R(0.0) ||
             !pos_finite(cal->t_hold) || !pos_finite(cal->tol) || !pos_finite(cal->t_max) ||
             !LS_ISFINITE(cal->dither_amp) || cal->dither_amp < LS_R(0.0) ||
             (cal->dither_amp > LS_R(0.0) && (!pos_finite(cal->dither_freq) || cal->dither_freq >= LS_R(0.25) * fs)));
}

/* Each block's init (each refuses its own fields); the start-up and the residual model only when
 * configured. */
static ls_status init_blocks(ls_drive *d, const ls_drive_cfg *cfg)
{
    ls_status st = LS_OK;
    st |= ls_inject_init(&d->inj, &cfg->inject);
    st |= ls_biquad_init(&d->bpf[0], &cfg->bpf);
    st |= ls_biquad_init(&d->bpf[1], &cfg->bpf);
    st |= ls_biquad_init(&d->sep[0], &cfg->sep);
    st |= ls_biquad_init(&d->sep[1], &cfg->sep);
    st |= ls_demod_init(&d->demod, &cfg->demod);
    st |= ls_observer_init(&d->obs, &cfg->obs);
    st |= ls_observer_init(&d->enc, &cfg->enc_obs);
    st |= ls_current_init(&d->cur, &cfg->current);
    st |= ls_posctrl_init(&d->pos, &cfg->pos);
    st |= ls_traj_init(&d->traj, &cfg->traj);
    st |= ls_mod_init(&d->mod, &cfg->mod);
    if (cfg->hf_dtres) {
        st |= cfg->dtres.fs == cfg->fs ? ls_dtres_init(&d->dtres, &cfg->dtres) : LS_ERR_PARAM;
    }
    if (cfg->emf_on) {
        st |= ls_emf_init(&d->emf, &cfg->emf);
        st |= ls_fuse_init(&d->fuse, &cfg->fuse);
    }
    if (cfg->startup.pairs != 0u) { /* LS_MODE_STARTUP configured */
        st |= cfg->startup.fs == cfg->fs && cfg->startup.v_pulse <= LS_DRIVE_V_DC_MAX
                  ? ls_startup_init(&d->su, &cfg->startup)
                  : LS_ERR_PARAM;
    }
    st |= ls_protect_init(&d->prot, &cfg->prot);
    return st;
}

/* The drive's derived values (cfg copied in); false when one overflows (every input was finite). */
static bool derive(ls_drive *d, const ls_drive_cfg *cfg, LS_REAL enc_jump)
{
    d->cfg = *cfg;
    d->ts = LS_R(1.0) / cfg->fs;
    d->kx = LS_TWO_PI / cfg->pole_pitch;
    d->inv_kx = cfg->pole_pitch / LS_TWO_PI;
    d->kf = cfg->force_constant;
    d->inv_kf = LS_R(1.0) / cfg->force_constant;
    d->kf_id = cfg->current.psi_pm > LS_R(0.0) ? (cfg->current.l_d - cfg->current.l_q) / cfg->current.psi_pm
                                                : LS_R(0.0);
    d->ff_load_k = cfg->load_ff ? LS_R(1.0) / cfg->pos.mass : LS_R(0.0);
    d->integ_keep = cfg->load_ff ? LS_R(0.0) : LS_R(1.0);
    d->delay_ts = cfg->delay_comp * d->ts;
    d->enc_jump_max = enc_jump >= LS_R(1.0) ? (int64_t)(int32_t)enc_jump : 1; /* a one-count change is always plausible */
    d->enc_k = LS_TWO_PI / (LS_REAL)cfg->enc_counts;
    {
        /* the d-currents leave at least LS_DRIVE_KF_SHARE_MIN of the force constant, and the force
         * at i_max is finite with either (ls_drive_set_i_d_'s product and division, the force
         * reference's product) */
        const LS_REAL g_inj = LS_R(1.0) + d->kf_id * cfg->i_d_inj;
        const LS_REAL g_near = LS_R(1.0) + d->kf_id * cfg->i_d_near;
        return LS_ISFINITE4(d->kx, d->inv_kx, d->inv_kf, d->delay_ts) && LS_ISFINITE2(d->ff_load_k, d->kf_id) &&
               !(g_inj < LS_DRIVE_KF_SHARE_MIN) && !(g_near < LS_DRIVE_KF_SHARE_MIN) && d->inv_kx > LS_R(0.0) &&
               d->inv_kf > LS_R(0.0) &&
               LS_ISFINITE(cfg->i_max * cfg->force_constant * (g_inj > g_near ? g_inj : g_near));
    }
}

/* The calibration's step counts and dither increment, the near-axis schedule's thresholds. */
static void derive_schedules(ls_drive *d, const ls_drive_cfg *cfg)
{
    if (cfg->cal.table != NULL) {
        d->cal_n_settle = steps_of(cfg->cal.t_settle, d->ts, false);
        d->cal_n_hold = steps_of(cfg->cal.t_hold, d->ts, false);
        d->cal_n_max = steps_of(cfg->cal.t_max, d->ts, true);
    }
    if (cfg->cal.table != NULL && cfg->cal.dither_amp > LS_R(0.0)) { /* < 2^30 (dither_freq < fs / 4,
                                                                       checked with the table) */
        d->cal_inc = (uint32_t)(cfg->cal.dither_freq * d->ts * LS_R(4294967296.0));
    }
    if (cfg->near_out > LS_R(0.0)) { /* |cos(3 theta)| = |sin(3 e)|, e the distance to pi/6 + k pi/3 */
        LS_REAL c_unused;
        ls_sincos_full(LS_R(3.0) * cfg->near_in, &c_unused, &d->near_c3_in);
        ls_sincos_full(LS_R(3.0) * cfg->near_out, &c_unused, &d->near_c3_out);
    }
}

/* Checks, by group, then the blocks, the injection within the bus, the derived values (each helper
 * above is static and called once: inlined at -Os, the code no larger than one function's). */
ls_status ls_drive_init(ls_drive *d, const ls_drive_cfg *cfg)
{
    ls_pos zero = {0, LS_R(0.0)};
    LS_REAL enc_jump;
    if (d == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    memset(d, 0, sizeof *d);
    if (cfg->lib_version != LS_VERSION) {
        return LS_ERR_VERSION; /* made for another library version: its fields may mean other things */
    }
    if (!drive_fields_ok(cfg) || !modules_agree(cfg)) {
        return LS_ERR_PARAM;
    }
    /* the encoder's plausible count change per step (checked before its conversion) */
    enc_jump = cfg->enc_v_max / cfg->fs * ((LS_REAL)cfg->enc_counts / cfg->pole_pitch);
    if (!(enc_jump <= LS_DRIVE_ENC_JUMP_MAX) || !calibration_ok(&cfg->cal, cfg->fs)) {
        return LS_ERR_PARAM;
    }
    /* the fundamental gets what the injection leaves of the linear modulation range */
    if (init_blocks(d, cfg) != LS_OK || !ls_drive_inject_fits(cfg->inject.amplitude, cfg->prot.v_dc_min) ||
        !derive(d, cfg, enc_jump)) {
        memset(d, 0, sizeof *d);
        return LS_ERR_PARAM;
    }
    derive_schedules(d, cfg);
    if (!step_table_complete()) { /* (a mode or shape added without its step: never run a NULL) */
        return LS_ERR_PARAM;
    }
    d->initialised = true;
    ls_drive_reset(d, zero);
    return LS_OK;
}

/* --------------------------------------------------------------------------- the step table */
#if defined(__GNUC__)
#define LS_DRIVE_COLD __attribute__((noinline, cold)) /* out of the other modes' way */
#else
#define LS_DRIVE_COLD
#endif
static void startup_step(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd);

/* The step table: which function runs ls_drive_step, by mode (rows) and injection shape (columns).
 * The columns are cfg.inject.shape, the rotating injection split by its fundamental separation:
 *   PULSE  LS_INJ_PULSATING (pulsating, or elliptical with inject.quad > 0)
 *   ROT    LS_INJ_ROTATING with sep the notch at bpf's f0 and q (sep = 1 - bpf: no band-pass needed)
 *   ROTX   LS_INJ_ROTATING with another sep
 *   SQUARE LS_INJ_SQUARE (at fs/2)
 *   SPEED  LS_INJ_PULSATING with cfg.emf_on (the EMF estimate and the hand-over)
 *
 *   mode                      PULSE       ROT         ROTX        SQUARE      SPEED       file
 *   LS_MODE_OFF               off         off         off         off         off         ls_drive_off.c
 *   LS_MODE_SENSORED          sensored    sensored    sensored    sensored    sensored    ls_drive_sensored.c
 *   LS_MODE_SENSORLESS_LUT    sensorless  rotating    sensorless  square      speed       ls_drive_sensorless.c,
 *   LS_MODE_SENSORLESS_NOLUT  sensorless  rotating    sensorless  square      speed         _rotating.c,
 *                                                                                           _square.c, _speed.c
 *   LS_MODE_CALIBRATION       calibration calibration calibration calibration calibration ls_drive_calibration.c
 *   LS_MODE_STARTUP           startup     startup     startup     startup     startup     ls_drive_startup.c
 *   LS_MODE_COMMISSION        (off)       (off)       (off)       (off)       commission  ls_drive_commission.c
 *
 * mode_set picks the entry (d->path = row * LS_DRIVE_COLS + column) when the mode changes; while
 * LS_MODE_STARTUP runs, d->mode holds LS_MODE_OFF (d->starting set, cmd.mode reports
 * LS_MODE_STARTUP) and the entry is the start-up's row. */
enum { LS_DRIVE_PULSE = 0, LS_DRIVE_ROT = 1, LS_DRIVE_ROTX = 2, LS_DRIVE_SQUARE = 3, LS_DRIVE_SPEED = 4,
       LS_DRIVE_COLS = 5 };
#define LS_DRIVE_ROW(f) {f, f, f, f, f}
static const ls_drive_step_fn step_table[LS_MODE_COMMISSION + 1][LS_DRIVE_COLS] = {
    [LS_MODE_OFF] = LS_DRIVE_ROW(ls_drive_off_step_),
    [LS_MODE_SENSORED] = LS_DRIVE_ROW(ls_drive_sensored_step_),
    [LS_MODE_SENSORLESS_LUT] = {ls_drive_sensorless_step_, ls_drive_rotating_step_, ls_drive_sensorless_step_,
                                ls_drive_square_step_, ls_drive_speed_step_},
    [LS_MODE_SENSORLESS_NOLUT] = {ls_drive_sensorless_step_, ls_drive_rotating_step_, ls_drive_sensorless_step_,
                                  ls_drive_square_step_, ls_drive_speed_step_},
    [LS_MODE_CALIBRATION] = LS_DRIVE_ROW(ls_drive_calibration_step_),
    [LS_MODE_STARTUP] = LS_DRIVE_ROW(startup_step),
    /* (ls_drive_set_mode refuses the mode without cfg.emf_on: the other columns never run) */
    [LS_MODE_COMMISSION] = {ls_drive_off_step_, ls_drive_off_step_, ls_drive_off_step_, ls_drive_off_step_,
                            ls_drive_commission_step_},
};

/* Every mode x shape has its step (ls_drive_init refuses to run with a hole in the table). */
static bool step_table_complete(void)
{
    unsigned r, c;
    for (r = 0; r <= (unsigned)LS_MODE_COMMISSION; r++) {
        for (c = 0; c < (unsigned)LS_DRIVE_COLS; c++) {
            if (step_table[r][c] == NULL) {
                return false;
            }
        }
    }
    return true;
}

/* The table's column for the configuration. */
static unsigned step_column(const ls_drive_cfg *c)
{
    if (c->inject.shape == LS_INJ_SQUARE) {
        return LS_DRIVE_SQUARE;
    }
    if (c->inject.shape == LS_INJ_ROTATING) {
        /* (the notch at the band-pass's f0 and q is 1 - band-pass: ls_drive_rotating.c) */
        return c->sep.type == LS_BIQUAD_NOTCH && c->sep.f0 == c->bpf.f0 && c->sep.q == c->bpf.q ? LS_DRIVE_ROT
                                                                                            : LS_DRIVE_ROTX;
    }
    return c->emf_on ? LS_DRIVE_SPEED : LS_DRIVE_PULSE;
}

void ls_drive_set_i_d_(ls_drive *LS_RESTRICT d, LS_REAL i_d)
{
    if (i_d != d->i_d_ref) {
        d->i_d_ref = i_d;
        d->kf = d->cfg.force_constant * (LS_R(1.0) + d->kf_id * i_d);
        d->inv_kf = LS_R(1.0) / d->kf;
    }
}

/* The mode and what it runs (the step table's entry; LS_MODE_STARTUP's row while d->starting). */
static void mode_set(ls_drive *d, ls_mode mode)
{
    const unsigned row = d->starting ? (unsigned)LS_MODE_STARTUP : (unsigned)mode;
    d->mode = mode;
    d->hf_on = mode == LS_MODE_SENSORLESS_LUT || mode == LS_MODE_SENSORLESS_NOLUT ||
               mode == LS_MODE_CALIBRATION || mode == LS_MODE_COMMISSION ||
               (mode == LS_MODE_SENSORED && d->cfg.inject_sensored);
    d->v_hf_max = d->hf_on ? d->cfg.inject.amplitude : LS_R(0.0);
    ls_drive_set_i_d_(d, d->hf_on ? d->cfg.i_d_inj : LS_R(0.0));
    d->path = (uint8_t)(row * LS_DRIVE_COLS + step_column(&d->cfg));
}

/* The residual model starts again (keep_r: its measured resistance scale kept, ls_dtres_restart;
 * else ls_dtres_reset, k_r = 1), and what follows that scale with it (ls_drive_follow_r_). */
static void dtres_reset(ls_drive *d, bool keep_r)
{
    if (keep_r) {
        ls_dtres_restart(&d->dtres);
    } else {
        ls_dtres_reset(&d->dtres);
    }
    ls_drive_follow_r_(d);
}

void ls_drive_reset(ls_drive *d, ls_pos p)
{
    if (!d->initialised) {
        return;
    }
    ls_inject_reset(&d->inj);
    ls_biquad_reset(&d->bpf[0]);
    ls_biquad_reset(&d->bpf[1]);
    ls_biquad_reset(&d->sep[0]);
    ls_biquad_reset(&d->sep[1]);
    ls_demod_reset(&d->demod);
    ls_observer_reset(&d->obs, p);
    ls_observer_reset(&d->enc, p);
    ls_current_reset(&d->cur);
    ls_posctrl_reset(&d->pos);
    ls_traj_reset(&d->traj, p);
    ls_mod_reset(&d->mod);
    dtres_reset(d, false);
    ls_protect_reset(&d->prot);
    if (d->cfg.emf_on) {
        ls_emf_reset(&d->emf);
        ls_fuse_reset(&d->fuse);
    }
    d->starting = false;
    mode_set(d, LS_MODE_OFF);
    ls_startup_reset(&d->su);
    d->align = false;
    d->pending = false;
    d->f_ref = LS_R(0.0);
    d->cal_phase = LS_CAL_DONE;
    d->cal_index = 0u;
    d->cal_timer = 0u;
    ls_drive_cal_window_reset_(d);
    d->psi_cal = LS_R(0.0);
    ls_drive_cal_cs_(d);
    d->cal_acc = 0u;
    d->cal_amp = LS_R(0.0);
}

ls_status ls_drive_set_mode(ls_drive *d, ls_mode mode)
{
    if (d == NULL || !d->initialised) {
        return LS_ERR_NULL;
    }
    switch (mode) {
    case LS_MODE_OFF:
    case LS_MODE_SENSORED:
    case LS_MODE_SENSORLESS_NOLUT:
        break;
    case LS_MODE_SENSORLESS_LUT:
        if (d->cfg.demod.comp == NULL) {
            return LS_ERR_PARAM;
        }
        break;
    case LS_MODE_STARTUP: /* the injection's envelope must rise and fall within t_settle and t_quiet */
        if (d->cfg.demod.comp == NULL || d->cfg.startup.pairs == 0u || !(d->cfg.inject.amplitude > LS_R(0.0)) ||
            !(d->cfg.startup.t_quiet * d->cfg.inject.ramp_rate >= d->cfg.inject.amplitude) ||
            !(d->cfg.startup.t_settle * d->cfg.inject.ramp_rate >= d->cfg.inject.amplitude)) {
            return LS_ERR_PARAM;
        }
        break;
    case LS_MODE_CALIBRATION:
        if (d->cfg.cal.table == NULL) {
            return LS_ERR_PARAM;
        }
        d->cal_phase = LS_CAL_MOVE;
        d->cal_amp = LS_R(0.0);
        d->cal_index = 0u;
        d->cal_timer = 0u;
        ls_drive_cal_window_reset_(d);
        d->psi_cal = LS_R(0.0);
        ls_drive_cal_cs_(d);
        break;
    case LS_MODE_COMMISSION: /* the EMF estimate, the work, the demodulator reading the table learned, a
                                stable rate (k_int 2 ts < 1: it learns every other step) */
        if (!d->cfg.emf_on || d->cfg.cal.table == NULL || d->cfg.cal.learn == NULL || d->cfg.demod.comp == NULL ||
            d->cfg.demod.comp->table != d->cfg.cal.table || d->cfg.demod.comp->len != d->cfg.cal.points ||
            !(d->cfg.cal.k_int * d->ts < LS_R(0.5)) || !(d->cfg.cal.slope > LS_R(0.0)) ||
            !(d->cfg.cal.slope <= LS_DRIVE_CAL_SLOPE_MAX) ||
            !(LS_DRIVE_LEARN_CRUISE * d->cfg.traj.v_max > d->cfg.fuse.v_hi)) { /* (a cruise above the
                                                                                   band: else none) */
            return LS_ERR_PARAM;
        }
        d->learn_w = LS_DRIVE_LEARN_CRUISE * d->cfg.traj.v_max * d->kx;
        d->learn_inv_s = LS_R(1.0) / d->cfg.cal.slope;
        d->learn_kd = d->cfg.hf_delay / d->cfg.demod.gain; /* (|gain| >= 1 / LS_DEMOD_GAIN_MAX: finite) */
        d->cal_timer = 0u;
        d->learn_turn = 0u;
        ls_drive_learn_reset_(d);
        break;
    default:
        return LS_ERR_PARAM;
    }
    /* the table in sensorless_lut, and for the HF estimate beside the encoder in sensored mode
     * (inject_sensored) when there is one; not without LUT, nor while calibrating it */
    ls_demod_set_comp(&d->demod, mode == LS_MODE_SENSORLESS_LUT || mode == LS_MODE_SENSORED ||
                                     mode == LS_MODE_STARTUP || mode == LS_MODE_COMMISSION);
    /* the modulator's history and the residual model start again (the outputs may have been off) */
    ls_mod_reset(&d->mod);
    dtres_reset(d, true);
    if (d->cfg.emf_on) { /* (the EMF's filters and the hand-over start again: the injection on) */
        ls_emf_reset(&d->emf);
        ls_fuse_reset(&d->fuse);
    }
    d->w_ref = LS_R(0.0); /* (its back-EMF: the sensorless steps' trajectory sets it) */
    /* LS_MODE_STARTUP runs with mode OFF and starting set (the step table's start-up row); it
     * enters LS_MODE_SENSORLESS_LUT, aligned, when it is done */
    d->starting = mode == LS_MODE_STARTUP;
    mode_set(d, d->starting ? LS_MODE_OFF : mode);
    if (d->starting) {
        d->hf_on = true;
        d->v_hf_max = d->cfg.inject.amplitude;
        ls_startup_reset(&d->su);
        ls_current_reset(&d->cur);
    }
    d->align = true;
    if (mode == LS_MODE_SENSORED && !d->hf_on) { /* (its step runs the injection: off at once, not
                                                    ramped down, the voltage limit leaves it no room) */
        ls_inject_reset(&d->inj);
    }
    ls_inject_enable(&d->inj, d->hf_on);
    return LS_OK;
}

ls_status ls_drive_set_position(ls_drive *d, ls_pos p)
{
    if (d == NULL || !d->initialised) {
        return LS_ERR_NULL;
    }
    if (!ls_pos_check(&p)) {
        return LS_ERR_PARAM;
    }
    ls_observer_reset(&d->obs, p);
    ls_traj_reset(&d->traj, p);
    ls_posctrl_reset(&d->pos);
    return LS_OK;
}

ls_status ls_drive_set_load(ls_drive *d, LS_REAL f_load)
{
    if (d == NULL || !d->initialised) {
        return LS_ERR_NULL;
    }
    if (!LS_ISFINITE(f_load)) {
        return LS_ERR_PARAM;
    }
    if (d->cfg.pos.type == LS_POSCTRL_P) { /* (the encoder modes'; load_ff: the sensorless modes hold it at 0) */
        d->pos.speed.integ = ls_clamp(f_load, d->cfg.pos.speed.out_min, d->cfg.pos.speed.out_max);
    }
    if (d->cfg.obs.type == LS_OBS_MECH) {
        d->obs.f_load = ls_clamp(f_load, -d->cfg.obs.force_max, d->cfg.obs.force_max);
    }
    if (d->cfg.enc_obs.type == LS_OBS_MECH) {
        d->enc.f_load = ls_clamp(f_load, -d->cfg.enc_obs.force_max, d->cfg.enc_obs.force_max);
    }
    d->f_ref = ls_clamp(f_load, -d->cfg.pos.force_max, d->cfg.pos.force_max);
    return LS_OK;
}

static ls_status command(ls_drive *d, ls_pos target, bool move)
{
    if (d == NULL || !d->initialised) {
        return LS_ERR_NULL;
    }
    if (!ls_pos_check(&target)) { /* refused: never a saturated or wrapped target */
        return LS_ERR_PARAM;
    }
    if (d->mode == LS_MODE_CALIBRATION) {
        return LS_OK;
    }
    if (d->align) { /* keep it until the reference is aligned at the next step */
        d->pending = true;
        d->pending_move = move;
        d->pending_target = target;
    } else if (move) {
        ls_traj_move(&d->traj, target);
    } else {
        ls_traj_jump(&d->traj, target);
    }
    return LS_OK;
}

ls_status ls_drive_move_to(ls_drive *d, ls_pos target)
{
    return command(d, target, true);
}

ls_status ls_drive_step_to(ls_drive *d, ls_pos target)
{
    return command(d, target, false);
}

/* --------------------------------------------------------------------------- step */
/* LS_MODE_STARTUP: the step's opening, one step of the sequence (ls_drive_startup.c), then its
 * end: a failure turns the outputs off, the end enters LS_MODE_SENSORLESS_LUT with the reference
 * aligned at the estimate from the next step on (no jump). */
static LS_DRIVE_COLD void startup_step(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas,
                                       ls_cmd *LS_RESTRICT cmd)
{
    ls_drive_io io;
    ls_startup_phase ph;
    if (!ls_drive_open_(d, meas, cmd, &io)) {
        return;
    }
    ph = ls_drive_startup_run_(d, meas, cmd, &io);
    if (ph == LS_SU_FAILED) {
        if (d->prot.fault == LS_FAULT_NONE) {
            ls_protect_trip(&d->prot, LS_FAULT_OBSERVER);
        }
        ls_drive_disable_report_(d, cmd, d->prot.fault);
    } else if (ph == LS_SU_DONE) {
        d->starting = false;
        mode_set(d, LS_MODE_SENSORLESS_LUT);
        d->align = true;
    }
}

void ls_drive_step(ls_drive *d, const ls_meas *meas, ls_cmd *cmd)
{
    if (cmd == NULL) {
        return;
    }
    if (d == NULL || meas == NULL || !d->initialised) {
        memset(cmd, 0, sizeof *cmd);
        cmd->fault = LS_FAULT_CONFIG;
        return;
    }
    /* the step of the mode and injection shape: the step table above */
    step_table[d->path / LS_DRIVE_COLS][d->path % LS_DRIVE_COLS](d, meas, cmd);
}
