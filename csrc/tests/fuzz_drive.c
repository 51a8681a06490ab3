/* libFuzzer target for ls_drive (make fuzz): the input is one drive's configuration and a sequence of
 * fixed-size records, each a setter call and a run of ls_drive_step. Every byte string is a valid,
 * deterministic run (a short input, or a short last record, reads as if padded with zeros), so
 * that a mutation anywhere is still a run and a record's effect does not depend on the bytes around
 * it. docs/firmware.md, "Fuzzing", has the format, the mutator and the measured coverage.
 *
 *   header, 8 bytes
 *     h[0]  preset (mod 8): 0 defaults (elliptical injection, product demodulator), 1 pulsating,
 *           2 heterodyne, 3 rotating injection, 4 square wave, 5 PLL observer + PD position control,
 *           6 a calibration short enough to finish (4..64 points of a few ms), 7 a short start-up
 *     h[1]  booleans toggled from the preset: dtc, hf_dtres, inject_sensored, decouple, dtres.forward,
 *           dtres.adapt, dtres.adapt_r, load_ff (bits 0..7)
 *     h[2]  bit 0..2 drop demod.comp, demod.gain_table, cal.table; bit 3 add demod.comp_r/gain_r;
 *           bit 4 toggle obs.type; bit 5 toggle pos.type; bit 6 d-axis saturation in the plant;
 *           bit 7 no start-up (startup.pairs = 0)
 *     h[3]  bits 0..5 cal.points - 1 (0: the preset's); bits 6..7 the plant's initial position
 *     h[4]  number of override records (mod 16)
 *     h[5]  the plant's load force, (int8) h[5] / 4 N
 *     h[6]  bits 0..3 the plant's current-sensor noise, 2 mA rms per unit; bits 4..5 the sample rate
 *           (16, 20, 10, 32 kHz; every module follows)
 *     h[7]  bit 0 toggle emf_on (the SPEED step with the pulsating or elliptical injection); bit 1 a
 *           hand-over band of 0.04-0.14 m/s (the default moves' 0.2 m/s cross it); bit 2 the magnets' imbalance
 *           compensated (emf.psi_pm, pm_shift, neg_re, neg_im); bit 3 LS_MODE_COMMISSION's
 *           configuration over the rest (emf_on, cal.learn, demod.comp over cal.table at cal.points
 *           when 4..64, traj.v_max 1 m/s; set_mode refuses what does not fit); bits 4..7 reserved
 *   override record, 6 bytes: field, kind, value (4 bytes, big-endian)
 *     field < N_FIELDS: an LS_REAL field of ls_drive_cfg (FIELDS) set to the value decoded by
 *     rd_real (kind & 0x10: multiplied into the preset's value instead); then the integer fields
 *     enc_counts, cal.period, startup.pairs, and obs.type/pos.type/demod.method/sep.type/
 *     inject.shape/bpf.type from kind
 *   step record, 8 bytes: op, arg, value (4 bytes, big-endian), n, meas
 *     op & 15: 0, 10..15 none; 1 ls_drive_set_mode(arg % 7); 2 set_position, 3 move_to, 4 step_to,
 *       6 ls_drive_reset (a position, rd_pos); 5 ls_drive_set_load (rd_real); 7 the held encoder
 *       count (arg & 1: set to the value, else moved by its low 16 bits); 8 for this record's steps,
 *       measurement arg % 4 (i_a, i_b, i_c, v_dc) is the value (rd_real: NaN, Inf, huge ...);
 *       9 the plant's load force (rd_real, limited to +-100 N)
 *     then n * {1, 8, 64, 256}[meas >> 4 & 3] steps of ls_drive_step (an input runs at most
 *     MAX_STEPS), with measurements from
 *       meas bit 0 clear: the plant (below: the ecce2010 motor driven by the drive's own duties, a
 *         closed loop, so moves finish, the calibration converges, the start-up decides);
 *         set: held currents (0 A) and 72 V
 *       meas bits 1..2: the encoder: 0 the plant's, 1 the held count, 2/3 the held count + / - one
 *         count per step; bit 3: the encoder not valid
 *
 * Values are hostile on purpose where a class says so: raw bit patterns, NaN, +-Inf, +-max,
 * denormals, huge and tiny numbers, or plausible ones. After every step the target aborts unless
 * every real in ls_cmd is finite, the duties are in [0, 1], every position is normalised and within
 * +-LS_POS_PERIOD_MAX periods, and the outputs are off while a fault is latched; a configuration
 * ls_drive_init refuses must refuse to run (every setter LS_ERR_NULL). AddressSanitizer and
 * UndefinedBehaviorSanitizer (-fno-sanitize-recover=all) abort on any undefined behaviour,
 * including an out-of-range float-to-int conversion.
 *
 * LLVMFuzzerCustomMutator and LLVMFuzzerCustomCrossOver work on records (insert, copy, delete,
 * repeat a run of records, lengthen a record's run of steps, change one field), so that long
 * multi-step inputs are reached in seconds; a third of the mutations are libFuzzer's own byte-level
 * ones (with csrc/tests/fuzz_drive.dict, whole records).
 */
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "linsense/ls_drive.h"

#define HDR 8u
#define OVR 6u
#define REC 8u
#define N_CAL 64u
#define MAX_STEPS 12288u

typedef struct {
    const uint8_t *p;
    size_t n;
} reader;

/* the next k bytes, zeros beyond the input's end */
static void rd_bytes(reader *r, uint8_t *out, size_t k)
{
    size_t i;
    for (i = 0u; i < k; ++i) {
        if (r->n > 0u) {
            out[i] = *r->p;
            r->p++;
            r->n--;
        } else {
            out[i] = 0u;
        }
    }
}

static uint32_t be32(const uint8_t *b)
{
    return ((uint32_t)b[0] << 24) | ((uint32_t)b[1] << 16) | ((uint32_t)b[2] << 8) | (uint32_t)b[3];
}

/* A real from a class (kind & 7) and 32 bits. */
static LS_REAL rd_real(uint8_t kind, uint32_t u)
{
    static const double special[] = {0.0,     -0.0,    1.0,     -1.0,     0.5,      1e-3,    1e-30,
                                     -1e-30,  1e6,     -1e6,    1e10,     -1e10,    1e20,    -1e20,
                                     1e30,    -1e30,   3e38,    -3e38,    1e-38,    1.4e-45, 1e300,
                                     -1e300,  16000.0, 72.0,    2147483647.0, -2147483648.0, 4.3e9,
                                     1.6777216e7, 8.0e6, 0.056, 100.0,  1e4};
    switch (kind & 7u) {
    case 0: { /* raw bits: a float, or in double the high word of a double */
#ifdef LS_REAL_DOUBLE
        const uint64_t w = (uint64_t)u << 32;
        double x;
        float xf;
        memcpy(&x, &w, sizeof x);
        memcpy(&xf, &u, sizeof xf);
        return (kind & 8u) ? x : (double)xf;
#else
        float x;
        memcpy(&x, &u, sizeof x);
        return x;
#endif
    }
    case 1: /* a special value (possibly overflowing to Inf in float) */
        return (LS_REAL)special[u % (sizeof special / sizeof special[0])];
    case 2:
        return (u & 1u) ? (LS_REAL)NAN : ((u & 2u) ? (LS_REAL)INFINITY : -(LS_REAL)INFINITY);
    case 3: /* a factor 2^(-4 .. 4) (relative overrides) */
        return (LS_REAL)exp2((double)(int16_t)(u & 0xFFFFu) / 8192.0);
    default: /* plausible: [-1, 1) times 10^(-3 .. 4) */
    {
        static const double scale[8] = {1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0, 1e3, 1e4};
        return (LS_REAL)(((double)(int16_t)(u & 0xFFFFu) / 32768.0) * scale[(u >> 16) & 7u]);
    }
    }
}

/* A position from a class (arg >> 4 & 3) and 32 bits. */
static ls_pos rd_pos(uint8_t arg, uint32_t u)
{
    ls_pos p;
    switch ((arg >> 4) & 3u) {
    case 0: /* plausible: a few periods, any angle */
        p.period = (int32_t)(int16_t)(u >> 16) / 256;
        p.theta = (LS_REAL)((double)(u & 0xFFFFu) * (2.0 * 3.14159265358979323846 / 65536.0));
        break;
    case 1: /* near the range's ends */
        p.period = ((u & 0x10000u) ? -1 : 1) * (LS_POS_PERIOD_MAX - (int32_t)((u >> 17) & 3u) + 1);
        p.theta = (LS_REAL)((double)(u & 0xFFFFu) * (7.0 / 65536.0));
        break;
    case 2: /* a hostile angle */
        p.period = 0;
        p.theta = rd_real(arg, u);
        break;
    default: /* any period */
        p.period = (int32_t)u;
        p.theta = LS_R(0.0);
        break;
    }
    return p;
}

#define FIELD(f) offsetof(ls_drive_cfg, f)
/* LS_REAL fields of ls_drive_cfg the target overrides */
static const size_t FIELDS[] = {
    FIELD(fs), FIELD(pole_pitch), FIELD(force_constant), FIELD(i_max), FIELD(delay_comp), FIELD(enc_v_max),
    FIELD(inject.amplitude), FIELD(inject.freq), FIELD(inject.ramp_rate), FIELD(inject.quad), FIELD(bpf.f0),
    FIELD(bpf.q), FIELD(sep.f0), FIELD(sep.q), FIELD(demod.f_lpf), FIELD(demod.gain), FIELD(demod.min_level),
    FIELD(demod.f_notch), FIELD(obs.k1), FIELD(obs.k2), FIELD(obs.k3), FIELD(obs.pole_pitch), FIELD(obs.mass),
    FIELD(obs.omega_max), FIELD(obs.force_max), FIELD(enc_obs.k1), FIELD(enc_obs.k2), FIELD(enc_obs.omega_max),
    FIELD(enc_obs.pole_pitch), FIELD(current.kp), FIELD(current.ki), FIELD(current.l_d), FIELD(current.l_q),
    FIELD(current.psi_pm), FIELD(pos.kp_x), FIELD(pos.kd_x), FIELD(pos.v_max), FIELD(pos.speed.kp),
    FIELD(pos.speed.ki), FIELD(pos.mass), FIELD(pos.force_max), FIELD(traj.v_max), FIELD(traj.a_max),
    FIELD(traj.v_step), FIELD(traj.a_step), FIELD(traj.a_lpf), FIELD(traj.pole_pitch), FIELD(mod.dead_time),
    FIELD(mod.i_band), FIELD(mod.dtc_lead), FIELD(dtres.r_s), FIELD(dtres.l_d), FIELD(dtres.l_q),
    FIELD(prot.i_max), FIELD(prot.v_dc_min), FIELD(prot.v_dc_max), FIELD(prot.err_max), FIELD(prot.err_time),
    FIELD(prot.omega_max), FIELD(cal.k_int), FIELD(cal.t_settle), FIELD(cal.t_hold), FIELD(cal.tol),
    FIELD(cal.t_max), FIELD(cal.dither_amp), FIELD(cal.dither_freq), FIELD(i_d_inj), FIELD(demod.ref_phase),
    FIELD(mod.l_ripple), FIELD(i_d_near), FIELD(near_in), FIELD(near_out), FIELD(hf_delay), FIELD(dtres.l_ea),
    FIELD(dtres.l_eb), FIELD(pos.speed.out_min), FIELD(pos.speed.out_max), FIELD(startup.t_lock),
    FIELD(startup.err_lock), FIELD(startup.t_quiet), FIELD(startup.v_pulse), FIELD(startup.t_pulse),
    FIELD(startup.t_rest), FIELD(startup.i_min), FIELD(startup.t_settle), FIELD(startup.lock_gain),
    FIELD(emf.r_s), FIELD(emf.l_d), FIELD(emf.l_q), FIELD(emf.f_lpf), FIELD(emf.omega_max), FIELD(emf.err_r),
    FIELD(emf.err_l), FIELD(emf.u_err), FIELD(emf.i_noise), FIELD(emf.psi_pm), FIELD(emf.pm_shift),
    FIELD(emf.neg_re), FIELD(emf.neg_im), FIELD(fuse.v_lo), FIELD(fuse.v_hi), FIELD(fuse.v_off), FIELD(fuse.v_on),
    FIELD(fuse.t_settle)};
#define N_FIELDS (sizeof FIELDS / sizeof FIELDS[0])
#define N_OVR_KINDS (N_FIELDS + 4u)

/* the sample rate is one field for the drive: every module's copy follows it */
static void set_fs(ls_drive_cfg *c, LS_REAL fs)
{
    c->fs = c->inject.fs = c->bpf.fs = c->sep.fs = c->demod.fs = c->obs.fs = c->enc_obs.fs = fs;
    c->current.fs = c->traj.fs = c->prot.fs = c->pos.speed.fs = c->dtres.fs = c->mod.f_pwm = fs;
    c->startup.fs = c->emf.fs = c->fuse.fs = fs;
}

static void preset(ls_drive_cfg *c, const uint8_t h[HDR])
{
    static const LS_REAL fs_opt[4] = {LS_R(16000.0), LS_R(20000.0), LS_R(10000.0), LS_R(32000.0)};
    const uint8_t f = h[1], t = h[2];
    if (((h[6] >> 4) & 3u) != 0u) {
        set_fs(c, fs_opt[(h[6] >> 4) & 3u]);
    }
    switch (h[0] & 7u) {
    case 1: /* pulsating */
        c->inject.quad = LS_R(0.0);
        break;
    case 2:
        c->demod.method = LS_DEMOD_HETERODYNE;
        break;
    case 3: /* rotating (csrc/tests/bench_drive.c's) */
        c->inject.shape = LS_INJ_ROTATING;
        c->inject.quad = LS_R(0.0);
        c->demod.method = LS_DEMOD_ROTATING;
        c->demod.gain = LS_R(1.0);
        c->demod.min_level = LS_R(3.8e-4);
        c->demod.ref_phase = LS_R(1.4613);
        break;
    case 4: /* square wave at fs/2 (csrc/tests/test_drive.c's) */
        c->inject.shape = LS_INJ_SQUARE;
        c->inject.quad = LS_R(0.0);
        c->inject.freq = LS_R(0.5) * c->fs;
        c->bpf.type = LS_BIQUAD_DIFF;
        c->sep.type = LS_BIQUAD_LOWPASS;
        c->sep.f0 = LS_R(2000.0);
        c->demod.f_notch = LS_R(0.0);
        c->hf_dtres = false;
        c->mod.l_ripple = LS_R(4.0e-3);
        c->i_d_inj = LS_R(0.9);
        c->i_d_near = LS_R(0.12);
        c->near_in = LS_R(0.061);
        c->near_out = LS_R(0.122);
        break;
    case 5:
        c->obs.type = LS_OBS_PLL;
        c->load_ff = false;
        c->pos.type = LS_POSCTRL_PD;
        c->pos.kp_x = LS_R(2.0e4);
        c->pos.kd_x = LS_R(200.0);
        break;
    case 6: /* a calibration that finishes within the step budget */
        c->cal.points = 4u;
        c->cal.t_settle = LS_R(0.005);
        c->cal.t_hold = LS_R(0.005);
        c->cal.tol = LS_R(0.05);
        c->cal.t_max = LS_R(0.2);
        c->traj.v_max *= LS_R(2.0);
        c->traj.a_max *= LS_R(4.0);
        break;
    case 7: /* a short start-up */
        c->startup.pairs = 2u;
        c->startup.t_lock = LS_R(0.02);
        break;
    default:
        break;
    }
    c->mod.dtc ^= (f & 1u) != 0u;
    c->hf_dtres ^= (f & 2u) != 0u;
    c->inject_sensored ^= (f & 4u) != 0u;
    c->current.decouple ^= (f & 8u) != 0u;
    c->dtres.forward ^= (f & 16u) != 0u;
    c->dtres.adapt ^= (f & 32u) != 0u;
    c->dtres.adapt_r ^= (f & 64u) != 0u;
    c->load_ff ^= (f & 128u) != 0u;
    if (t & 1u) {
        c->demod.comp = NULL;
    }
    if (t & 2u) {
        c->demod.gain_table = NULL;
    }
    if (t & 4u) {
        c->cal.table = NULL;
    }
    if ((t & 8u) == 0u) {
        c->demod.comp_r = NULL;
        c->demod.gain_r = NULL;
    }
    if (t & 16u) {
        c->obs.type = c->obs.type == LS_OBS_PLL ? LS_OBS_MECH : LS_OBS_PLL;
    }
    if (t & 32u) {
        c->pos.type = c->pos.type == LS_POSCTRL_P ? LS_POSCTRL_PD : LS_POSCTRL_P;
    }
    if (t & 128u) {
        c->startup.pairs = 0u;
    }
    if ((h[3] & 63u) != 0u) {
        c->cal.points = (uint32_t)(h[3] & 63u) + 1u;
    }
    /* the whole speed range (ls_drive_speed.c): the EMF estimate and the hand-over; a band low
     * enough for the plant's moves (0.2 m/s by default) to cross it, the magnets' imbalance
     * compensated (the values of an end phase a few per cent weak) */
    c->emf_on ^= (h[7] & 1u) != 0u;
    if (h[7] & 2u) {
        c->fuse.v_lo = LS_R(0.04);
        c->fuse.v_hi = LS_R(0.08);
        c->fuse.v_on = LS_R(0.10);
        c->fuse.v_off = LS_R(0.14);
        c->fuse.t_settle = LS_R(0.001);
    }
    if (h[7] & 4u) {
        c->emf.psi_pm = c->current.psi_pm;
        c->emf.pm_shift = LS_R(0.009);
        c->emf.neg_re = LS_R(0.013);
        c->emf.neg_im = LS_R(-0.008);
    }
}

static void override(ls_drive_cfg *c, const uint8_t o[OVR])
{
    const unsigned which = o[0] % N_OVR_KINDS;
    const uint8_t kind = o[1];
    const uint32_t u = be32(o + 2);
    if (which < N_FIELDS) {
        LS_REAL *f = (LS_REAL *)(void *)((char *)c + FIELDS[which]);
        const LS_REAL v = rd_real(kind, u);
        const LS_REAL x = (kind & 0x10u) ? *f * v : v;
        if (FIELDS[which] == FIELD(fs)) {
            set_fs(c, x);
        } else {
            *f = x;
        }
        return;
    }
    switch (which - N_FIELDS) {
    case 0:
        c->enc_counts = (kind & 1u) ? (int32_t)u : (int32_t)(u & 0xFFFFFu);
        break;
    case 1:
        c->cal.period = (int32_t)u;
        break;
    case 2:
        c->startup.pairs = u % 40u;
        break;
    default:
        c->obs.type = (ls_observer_type)(kind % 3u);
        c->pos.type = (ls_posctrl_type)(kind / 3u % 3u);
        c->demod.method = (ls_demod_method)(u % 4u);
        c->sep.type = (ls_biquad_type)(u / 4u % 5u);
        c->inject.shape = (ls_inject_shape)(u / 20u % 4u);
        c->bpf.type = (ls_biquad_type)(u / 80u % 5u);
        break;
    }
}

/* a broken property: say which, then abort (libFuzzer saves the input) */
#define fail() (fprintf(stderr, "fuzz_drive: property violated at line %d\n", __LINE__), abort())

static void check_pos(ls_pos p)
{
    if (!(p.theta >= LS_R(0.0) && p.theta < LS_TWO_PI) || p.period > LS_POS_PERIOD_MAX ||
        p.period < -LS_POS_PERIOD_MAX) {
        fail();
    }
}

static void check_cmd(const ls_cmd *c)
{
    const LS_REAL r[] = {c->v_est, c->v_fb, c->f_load_est, c->err_sig, c->hf_level, c->psi_comp, c->i_dq[0],
                         c->i_dq[1], c->i_dq_ref[0], c->i_dq_ref[1], c->v_dq[0], c->v_dq[1], c->v_hf, c->psi_cal};
    size_t k;
    for (k = 0u; k < sizeof r / sizeof r[0]; ++k) {
        if (!LS_ISFINITE(r[k])) {
            fail();
        }
    }
    for (k = 0u; k < 3u; ++k) {
        if (!(c->duty[k] >= LS_R(0.0) && c->duty[k] <= LS_R(1.0))) {
            fail();
        }
    }
    if (c->fault != 0u && c->enable) {
        fail();
    }
    check_pos(c->pos_fb);
    check_pos(c->pos_est);
    check_pos(c->pos_ref);
}

/* The plant: the ecce2010 motor (csrc/tests/ls_test_plant.h's, its d/q inductances) with its
 * flux linkage in alpha-beta, explicit steps of at most 62.5 us (at least one a PWM period) with the
 * previous step's duties (the computation delay), a mass with viscous friction and a load force,
 * optional d-axis saturation (L_d lower at +i_d than at -i_d: the start-up's polarity signal) and
 * current-sensor noise. Cheap and crude on purpose: it closes the loop, so that moves finish, the
 * calibration converges and the start-up decides, which held measurements never do. It stays
 * finite: the load force within +-100 N (below the motor's 160 N), the speed within +-20 m/s (end
 * stops), and a state that is not finite anyway starts again at rest at 0 (a runaway at a 500 N
 * load once overflowed it). */
typedef struct {
    double ld, lq, r, psi, kf, tau, mass, visc; /* H, H, ohm, Wb, N/A, m, kg, N s/m */
    double f_load, v_dc, ts, sat_k, noise;       /* N, V, s, 1/A, A rms */
    double x, v, lam[2], duty[3];                /* m, m/s, Wb (alpha, beta), - */
    int32_t counts;                              /* encoder counts per pole pitch */
    uint32_t rng;
} plant;

#define PLANT_2PI 6.283185307179586
#define PLANT_F_MAX 100.0
#define PLANT_V_MAX 20.0

static void plant_rest(plant *p, double x0)
{
    p->x = x0;
    p->v = 0.0;
    p->lam[0] = p->psi * cos(PLANT_2PI * x0 / p->tau);
    p->lam[1] = p->psi * sin(PLANT_2PI * x0 / p->tau);
}

static void plant_init(plant *p, double x0)
{
    p->ld = 3.19e-3;
    p->lq = 4.15e-3;
    p->r = 9.0;
    p->kf = 20.0;
    p->tau = 0.056;
    p->psi = p->kf * p->tau / (1.5 * PLANT_2PI);
    p->mass = 1.5;
    p->visc = 5.0;
    p->f_load = 0.0;
    p->v_dc = 72.0;
    p->ts = 1.0 / 16000.0;
    p->sat_k = 0.0;
    p->noise = 0.0;
    p->duty[0] = p->duty[1] = p->duty[2] = 0.5;
    p->counts = 56000;
    p->rng = 0x9E3779B9u;
    plant_rest(p, x0);
}

/* alpha-beta currents at x from the flux linkage */
static void plant_currents(const plant *p, double x, const double lam[2], double i[2])
{
    const double th = PLANT_2PI * x / p->tau, c = cos(th), s = sin(th);
    const double lam_d = c * lam[0] + s * lam[1], lam_q = -s * lam[0] + c * lam[1];
    double i_d = (lam_d - p->psi) / p->ld, i_q = lam_q / p->lq;
    if (p->sat_k != 0.0) { /* one fixed-point pass of L_d (1 - sat_k i_d), kept within [0.5, 1.5] L_d */
        const double k = 1.0 - p->sat_k * i_d;
        i_d = (lam_d - p->psi) / (p->ld * (k < 0.5 ? 0.5 : (k > 1.5 ? 1.5 : k)));
    }
    i[0] = c * i_d - s * i_q;
    i[1] = s * i_d + c * i_q;
}

static double plant_noise(plant *p)
{
    double acc = 0.0;
    int k;
    for (k = 0; k < 4; ++k) { /* a sum of four uniforms: roughly normal, unit variance */
        p->rng ^= p->rng << 13;
        p->rng ^= p->rng >> 17;
        p->rng ^= p->rng << 5;
        acc += (double)p->rng / 4294967296.0 - 0.5;
    }
    return acc * 1.7320508;
}

/* the encoder count, held within int32 (the mover stays within a few hundred metres anyway) */
static int32_t plant_count(const plant *p)
{
    const double c = floor(p->x / p->tau * (double)p->counts);
    return c > 2.0e9 ? 2000000000 : (c < -2.0e9 ? -2000000000 : (int32_t)c);
}

static void plant_measure(plant *p, ls_meas *m)
{
    double i[2];
    int k;
    plant_currents(p, p->x, p->lam, i);
    m->i_abc[0] = (LS_REAL)i[0];
    m->i_abc[1] = (LS_REAL)(-0.5 * i[0] + 0.8660254037844386 * i[1]);
    m->i_abc[2] = (LS_REAL)(-0.5 * i[0] - 0.8660254037844386 * i[1]);
    for (k = 0; k < 3 && p->noise > 0.0; ++k) {
        m->i_abc[k] += (LS_REAL)(p->noise * plant_noise(p));
    }
    m->v_dc = (LS_REAL)p->v_dc;
}

/* one PWM period with the duties of the previous step, then latch the new ones */
static void plant_advance(plant *p, const ls_cmd *cmd)
{
    const double va = (2.0 * p->duty[0] - p->duty[1] - p->duty[2]) * p->v_dc / 3.0;
    const double vb = (p->duty[1] - p->duty[2]) * p->v_dc / 1.7320508075688772;
    const int n = (int)ceil(p->ts / 62.5e-6 - 1e-9);
    const double h = p->ts / (double)n;
    int k;
    for (k = 0; k < n; ++k) {
        double i[2], f;
        plant_currents(p, p->x, p->lam, i);
        f = p->kf * (-sin(PLANT_2PI * p->x / p->tau) * i[0] + cos(PLANT_2PI * p->x / p->tau) * i[1]);
        p->lam[0] += h * (va - p->r * i[0]);
        p->lam[1] += h * (vb - p->r * i[1]);
        p->v += h * (f - p->f_load - p->visc * p->v) / p->mass;
        p->v = p->v > PLANT_V_MAX ? PLANT_V_MAX : (p->v < -PLANT_V_MAX ? -PLANT_V_MAX : p->v);
        p->x += h * p->v;
    }
    if (!(isfinite(p->x) && isfinite(p->v) && isfinite(p->lam[0]) && isfinite(p->lam[1]))) {
        plant_rest(p, 0.0);
    }
    for (k = 0; k < 3; ++k) {
        p->duty[k] = cmd->enable ? (double)cmd->duty[k] : 0.5; /* disabled: no net voltage */
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
size_t LLVMFuzzerMutate(uint8_t *data, size_t size, size_t max_size);
size_t LLVMFuzzerCustomMutator(uint8_t *data, size_t size, size_t max_size, unsigned int seed);
size_t LLVMFuzzerCustomCrossOver(const uint8_t *d1, size_t s1, const uint8_t *d2, size_t s2, uint8_t *out,
                                 size_t max_out, unsigned int seed);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const float comp_tab[8] = {0.0f, 0.05f, 0.07f, 0.05f, 0.0f, -0.05f, -0.07f, -0.05f};
    static const float gain_tab[8] = {4.0f, 5.0f, 6.0f, 5.0f, 4.0f, 5.0f, 6.0f, 5.0f};
    static const float comp_r_tab[8] = {0.01f, 0.0f, -0.01f, 0.0f, 0.01f, 0.0f, -0.01f, 0.0f};
    static const float gain_r_tab[8] = {0.5f, 0.2f, 0.0f, 0.2f, 0.5f, 0.2f, 0.0f, 0.2f};
    static const double x0_opt[4] = {0.0, 0.014, 0.0767, -0.163};
    static const unsigned n_scale[4] = {1u, 8u, 64u, 256u};
    float cal_tab[N_CAL];
    float learn_tab[4u * N_CAL];
    ls_lut learn_lut;
    reader r;
    ls_lut comp, gain, comp_r, gain_r;
    ls_lut_cfg lc;
    ls_drive_cfg cfg;
    ls_drive d;
    ls_cmd cmd;
    ls_meas m;
    plant pl;
    ls_status (*const setters[3])(ls_drive *, ls_pos) = {ls_drive_set_position, ls_drive_move_to,
                                                          ls_drive_step_to};
    uint8_t h[HDR], rec[REC];
    int32_t enc = 0;
    unsigned steps = 0u, k, n_ovr;
    r.p = data;
    r.n = size;
    lc.len = 8u;
    lc.table = comp_tab;
    if (ls_lut_init(&comp, &lc) != LS_OK) {
        fail();
    }
    lc.table = gain_tab;
    if (ls_lut_init(&gain, &lc) != LS_OK) {
        fail();
    }
    lc.table = comp_r_tab;
    if (ls_lut_init(&comp_r, &lc) != LS_OK) {
        fail();
    }
    lc.table = gain_r_tab;
    if (ls_lut_init(&gain_r, &lc) != LS_OK) {
        fail();
    }
    memset(cal_tab, 0, sizeof cal_tab);
    ls_drive_default_cfg(&cfg);
    cfg.demod.comp = &comp;
    cfg.demod.gain_table = &gain;
    cfg.demod.comp_r = &comp_r;
    cfg.demod.gain_r = &gain_r;
    cfg.cal.table = cal_tab;
    cfg.cal.points = 8u;
    rd_bytes(&r, h, HDR);
    preset(&cfg, h);
    n_ovr = h[4] & 15u;
    for (k = 0u; k < n_ovr; ++k) {
        uint8_t o[OVR];
        rd_bytes(&r, o, OVR);
        override(&cfg, o);
    }
    if ((h[7] & 8u) != 0u) { /* LS_MODE_COMMISSION: its table the demodulator's */
        cfg.emf_on = true;
        cfg.cal.learn = learn_tab;
        cfg.cal.table = cal_tab;
        cfg.traj.v_max = LS_R(1.0);
        lc.table = cal_tab;
        lc.len = cfg.cal.points;
        if (cfg.cal.points >= 4u && cfg.cal.points <= N_CAL && ls_lut_init(&learn_lut, &lc) == LS_OK) {
            cfg.demod.comp = &learn_lut;
        }
    }
    if (ls_drive_init(&d, &cfg) != LS_OK) {
        /* a refused configuration: the drive must refuse to run, and every setter (on it, or on no
         * drive) must say so and change nothing */
        const ls_pos p0 = {0, LS_R(0.0)};
        memset(&m, 0, sizeof m);
        ls_drive_reset(&d, p0);
        for (k = 0u; k < 3u; ++k) {
            if (setters[k](&d, p0) != LS_ERR_NULL || setters[k](NULL, p0) != LS_ERR_NULL) {
                fail();
            }
        }
        if (ls_drive_set_mode(&d, LS_MODE_SENSORED) != LS_ERR_NULL ||
            ls_drive_set_load(&d, LS_R(1.0)) != LS_ERR_NULL || ls_drive_set_mode(NULL, LS_MODE_OFF) != LS_ERR_NULL ||
            ls_drive_set_load(NULL, LS_R(0.0)) != LS_ERR_NULL || ls_drive_init(NULL, &cfg) != LS_ERR_NULL ||
            ls_drive_init(&d, NULL) != LS_ERR_NULL) {
            fail();
        }
        ls_drive_step(&d, &m, &cmd);
        if (cmd.enable || cmd.fault != LS_FAULT_CONFIG) {
            fail();
        }
        return 0;
    }
    plant_init(&pl, x0_opt[h[3] >> 6]);
    pl.f_load = (double)(int8_t)h[5] * 0.25;
    pl.noise = (double)(h[6] & 15u) * 0.002;
    pl.sat_k = (h[2] & 64u) ? 0.05 : 0.0;
    if (cfg.fs >= LS_R(1000.0) && cfg.fs <= LS_R(1.0e5)) {
        pl.ts = 1.0 / (double)cfg.fs;
    }
    if (cfg.enc_counts > 0 && cfg.enc_counts <= 1000000) {
        pl.counts = cfg.enc_counts;
    }
    memset(&m, 0, sizeof m);
    while (r.n > 0u && steps < MAX_STEPS) {
        uint32_t u, n;
        uint8_t op, arg, meas;
        int hostile = -1;
        LS_REAL hostile_v = LS_R(0.0);
        rd_bytes(&r, rec, REC);
        op = rec[0];
        arg = rec[1];
        u = be32(rec + 2);
        meas = rec[7];
        switch (op & 15u) {
        case 1:
            (void)ls_drive_set_mode(&d, (ls_mode)(arg % 7u));
            break;
        case 2: /* set_position, move_to, step_to */
        case 3:
        case 4:
            (void)setters[(op & 15u) - 2u](&d, rd_pos(arg, u));
            break;
        case 5:
            (void)ls_drive_set_load(&d, rd_real(arg, u));
            break;
        case 6:
            ls_drive_reset(&d, rd_pos(arg, u));
            break;
        case 7:
            enc = (arg & 1u) ? (int32_t)u : (int32_t)((uint32_t)enc + (uint32_t)(int32_t)(int16_t)(u & 0xFFFFu));
            break;
        case 8:
            hostile = (int)(arg & 3u);
            hostile_v = rd_real((uint8_t)(arg >> 2), u);
            break;
        case 9: {
            const LS_REAL f = rd_real(arg, u);
            pl.f_load = LS_ISFINITE(f) ? fmax(-PLANT_F_MAX, fmin(PLANT_F_MAX, (double)f)) : 0.0;
            break;
        }
        default:
            break;
        }
        n = (uint32_t)rec[6] * n_scale[(meas >> 4) & 3u];
        for (k = 0u; k < n && steps < MAX_STEPS; ++k, ++steps) {
            const bool from_plant = (meas & 1u) == 0u;
            if (from_plant) {
                plant_measure(&pl, &m);
            } else {
                m.i_abc[0] = m.i_abc[1] = m.i_abc[2] = LS_R(0.0);
                m.v_dc = LS_R(72.0);
            }
            switch ((meas >> 1) & 3u) {
            case 0:
                m.enc_count = plant_count(&pl);
                break;
            case 1:
                m.enc_count = enc;
                break;
            case 2:
                m.enc_count = enc;
                enc = (int32_t)((uint32_t)enc + 1u);
                break;
            default:
                m.enc_count = enc;
                enc = (int32_t)((uint32_t)enc - 1u);
                break;
            }
            m.enc_valid = (meas & 8u) == 0u;
            if (hostile >= 0) {
                if (hostile < 3) {
                    m.i_abc[hostile] = hostile_v;
                } else {
                    m.v_dc = hostile_v;
                }
            }
            ls_drive_step(&d, &m, &cmd);
            check_cmd(&cmd);
            if (from_plant) {
                plant_advance(&pl, &cmd);
            }
        }
    }
    return 0;
}

/* ---- the structure-aware mutator: records, not bytes ---- */
static uint32_t rng_next(uint32_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 17;
    *s ^= *s << 5;
    return *s;
}

/* where the step records start (the header and the override records it announces) */
static size_t records_start(const uint8_t *data, size_t size)
{
    const size_t r0 = size >= HDR ? HDR + OVR * (size_t)(data[4] & 15u) : HDR;
    return r0 < size ? r0 : size;
}

static void random_record(uint8_t *rec, uint32_t *s)
{
    static const uint8_t ops[] = {0, 0, 0, 1, 1, 2, 3, 3, 4, 5, 6, 7, 8, 9};
    const uint32_t a = rng_next(s), b = rng_next(s);
    rec[0] = ops[a % sizeof ops];
    rec[1] = (uint8_t)(a >> 8);
    memcpy(rec + 2, &b, 4);
    rec[6] = (uint8_t)(a >> 16);
    rec[7] = (uint8_t)((a >> 24) & 0x30u); /* the plant's measurements, a random length */
}

size_t LLVMFuzzerCustomMutator(uint8_t *data, size_t size, size_t max_size, unsigned int seed)
{
    uint32_t s = seed | 1u;
    const uint32_t choice = rng_next(&s) % 12u;
    size_t r0, nrec, i, j;
    if (size < HDR || choice < 4u) {
        return LLVMFuzzerMutate(data, size, max_size);
    }
    r0 = records_start(data, size);
    nrec = (size - r0) / REC;
    size = r0 + nrec * REC; /* whole records from here on */
    i = nrec > 0u ? rng_next(&s) % nrec : 0u;
    switch (choice) {
    case 4: /* a new record */
    case 5: /* a copy of a record */
        if (size + REC > max_size) {
            break;
        }
        j = rng_next(&s) % (nrec + 1u);
        memmove(data + r0 + (j + 1u) * REC, data + r0 + j * REC, (nrec - j) * REC);
        if (choice == 4u || nrec == 0u) {
            random_record(data + r0 + j * REC, &s);
        } else {
            memcpy(data + r0 + j * REC, data + r0 + (i < j ? i : i + 1u) * REC, REC);
        }
        return size + REC;
    case 6: /* repeat a run of records */
    {
        size_t len = 1u + rng_next(&s) % 8u, room;
        if (nrec == 0u) {
            break;
        }
        len = len < nrec - i ? len : nrec - i;
        room = (max_size - size) / REC;
        len = len < room ? len : room;
        if (len == 0u) {
            break;
        }
        memmove(data + r0 + (i + 2u * len) * REC, data + r0 + (i + len) * REC, (nrec - i - len) * REC);
        memcpy(data + r0 + (i + len) * REC, data + r0 + i * REC, len * REC);
        return size + len * REC;
    }
    case 7: /* delete a record */
        if (nrec == 0u) {
            break;
        }
        memmove(data + r0 + i * REC, data + r0 + (i + 1u) * REC, (nrec - i - 1u) * REC);
        return size - REC;
    case 8: /* a record's run of steps: longer, shorter, or from the other source */
        if (nrec == 0u) {
            break;
        }
        data[r0 + i * REC + 6u] = (uint8_t)rng_next(&s);
        data[r0 + i * REC + 7u] ^= (uint8_t)(1u << (rng_next(&s) % 6u));
        return size;
    case 9: /* a record's operation and its operand */
        if (nrec == 0u) {
            break;
        }
        data[r0 + i * REC] = (uint8_t)(rng_next(&s) % 10u);
        data[r0 + i * REC + 1u] = (uint8_t)rng_next(&s);
        return size;
    case 10: /* a record's value: a bit, a small change, or new */
    {
        uint8_t *v = data + r0 + i * REC + 2u;
        const uint32_t how = rng_next(&s) % 3u;
        uint32_t x;
        if (nrec == 0u) {
            break;
        }
        x = be32(v);
        x = how == 0u ? x ^ (1u << (rng_next(&s) % 32u)) : (how == 1u ? x + (rng_next(&s) % 33u) - 16u : rng_next(&s));
        v[0] = (uint8_t)(x >> 24);
        v[1] = (uint8_t)(x >> 16);
        v[2] = (uint8_t)(x >> 8);
        v[3] = (uint8_t)x;
        return size;
    }
    default: /* the header or an override record */
        data[rng_next(&s) % r0] = (uint8_t)rng_next(&s);
        return size;
    }
    return LLVMFuzzerMutate(data, size, max_size);
}

/* the first input's header, overrides and first records, then the second's last records */
size_t LLVMFuzzerCustomCrossOver(const uint8_t *d1, size_t s1, const uint8_t *d2, size_t s2, uint8_t *out,
                                 size_t max_out, unsigned int seed)
{
    uint32_t s = seed | 1u;
    const size_t r1 = records_start(d1, s1), r2 = records_start(d2, s2);
    const size_t n1 = (s1 - r1) / REC, n2 = (s2 - r2) / REC;
    size_t a = n1 > 0u ? rng_next(&s) % (n1 + 1u) : 0u, b = n2 > 0u ? rng_next(&s) % n2 : 0u, len;
    if (r1 > max_out) {
        return 0u;
    }
    a = a < (max_out - r1) / REC ? a : (max_out - r1) / REC;
    len = n2 - b;
    len = len < (max_out - r1) / REC - a ? len : (max_out - r1) / REC - a;
    memcpy(out, d1, r1 + a * REC);
    memcpy(out + r1 + a * REC, d2 + r2 + b * REC, len * REC);
    return r1 + (a + len) * REC;
}
