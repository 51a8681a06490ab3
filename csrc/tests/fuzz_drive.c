/* libFuzzer target for ls_drive (make fuzz): the input is a sequence of operations on one drive.
 *
 *   byte 0          number of configuration overrides n (mod 32)
 *   n overrides     field byte (which field of ls_drive_cfg, see FIELDS) + a value
 *   operations      op byte, then its operands, until the input ends:
 *                   set_mode, set_position, move_to, step_to, set_load, reset, and runs of
 *                   ls_drive_step with fuzzed measurements (currents, v_dc, encoder validity and
 *                   count, each a plausible value or a hostile one)
 *
 * Values are hostile on purpose: raw bit patterns, NaN, +-Inf, +-max, denormals, huge and tiny
 * numbers, or small plausible ones. After every step the target aborts unless every real in ls_cmd
 * is finite, the duties are in [0, 1], every position is normalised and within
 * +-LS_POS_PERIOD_MAX periods, and the outputs are off while a fault is latched. AddressSanitizer
 * and UndefinedBehaviorSanitizer (-fno-sanitize-recover=all) abort on any undefined behaviour,
 * including an out-of-range float-to-int conversion.
 */
#include <float.h>
#include <stdio.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "linsense/ls_drive.h"

typedef struct {
    const uint8_t *p;
    size_t n;
} reader;

static uint8_t rd_u8(reader *r)
{
    uint8_t v;
    if (r->n == 0u) {
        return 0u;
    }
    v = *r->p;
    r->p++;
    r->n--;
    return v;
}

static uint32_t rd_u32(reader *r)
{
    uint32_t v = 0u;
    int k;
    for (k = 0; k < 4; ++k) {
        v = (v << 8) | rd_u8(r);
    }
    return v;
}

/* A real: a selector byte picks a class of value. */
static LS_REAL rd_real(reader *r)
{
    static const double special[] = {0.0,     -0.0,    1.0,     -1.0,     0.5,      1e-3,    1e-30,
                                     -1e-30,  1e6,     -1e6,    1e10,     -1e10,    1e20,    -1e20,
                                     1e30,    -1e30,   3e38,    -3e38,    1e-38,    1.4e-45, 1e300,
                                     -1e300,  16000.0, 72.0,    2147483647.0, -2147483648.0, 4.3e9,
                                     1.6777216e7, 8.0e6, 0.056, 100.0,  1e4};
    const uint8_t sel = rd_u8(r);
    switch (sel & 7u) {
    case 0: { /* raw bits */
#ifdef LS_REAL_DOUBLE
        uint64_t u = ((uint64_t)rd_u32(r) << 32) | rd_u32(r);
        double x;
        memcpy(&x, &u, sizeof x);
        return x;
#else
        uint32_t u = rd_u32(r);
        float x;
        memcpy(&x, &u, sizeof x);
        return x;
#endif
    }
    case 1: { /* a special value (possibly overflowing to Inf in float) */
        const double v = special[(sel >> 3) % (sizeof special / sizeof special[0])];
        return (LS_REAL)v;
    }
    case 2:
        return (sel & 8u) ? (LS_REAL)NAN : ((sel & 16u) ? (LS_REAL)INFINITY : -(LS_REAL)INFINITY);
    case 3: /* small integer, scaled by a power of ten */
        return (LS_REAL)(int8_t)rd_u8(r) * (LS_REAL)((sel >> 3) & 1u ? 0.01 : 1.0);
    case 4: /* a factor of two around the default (the caller multiplies) */
        return (LS_REAL)(0.5 + (double)rd_u8(r) / 170.0);
    default: /* plausible: a byte over [-1, 1) times 10^(sel >> 3 mod 8 - 3) */
    {
        static const double scale[8] = {1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0, 1e3, 1e4};
        return (LS_REAL)(((double)(int8_t)rd_u8(r) / 128.0) * scale[(sel >> 3) & 7u]);
    }
    }
}

static ls_pos rd_pos(reader *r)
{
    ls_pos p;
    const uint8_t sel = rd_u8(r);
    switch (sel & 3u) {
    case 0: /* any period */
        p.period = (int32_t)rd_u32(r);
        break;
    case 1: /* a small one */
        p.period = (int32_t)(int8_t)rd_u8(r);
        break;
    case 2: /* near the range's ends */
        p.period = ((sel & 4u) ? -1 : 1) * (LS_POS_PERIOD_MAX - (int32_t)(rd_u8(r) & 3u) + 1);
        break;
    default:
        p.period = 0;
        break;
    }
    p.theta = rd_real(r);
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
    FIELD(pos.speed.ki), FIELD(pos.mass), FIELD(pos.force_max), FIELD(traj.v_max), FIELD(traj.a_max), FIELD(traj.v_step), FIELD(traj.a_step), FIELD(traj.a_lpf),
    FIELD(traj.pole_pitch), FIELD(mod.dead_time), FIELD(mod.i_band), FIELD(mod.dtc_lead), FIELD(dtres.r_s),
    FIELD(dtres.l_d), FIELD(dtres.l_q), FIELD(prot.i_max), FIELD(prot.v_dc_min), FIELD(prot.v_dc_max),
    FIELD(prot.err_max), FIELD(prot.err_time), FIELD(prot.omega_max), FIELD(cal.k_int), FIELD(cal.t_settle),
    FIELD(cal.t_hold), FIELD(cal.tol), FIELD(cal.t_max), FIELD(cal.dither_amp), FIELD(cal.dither_freq),
    FIELD(i_d_inj), FIELD(demod.ref_phase), FIELD(mod.l_ripple), FIELD(i_d_near), FIELD(near_in),
    FIELD(near_out), FIELD(hf_delay), FIELD(dtres.l_ea), FIELD(dtres.l_eb)};
#define N_FIELDS (sizeof FIELDS / sizeof FIELDS[0])
#define N_CAL 64u

static void set_field(ls_drive_cfg *c, size_t off, LS_REAL v, bool relative)
{
    LS_REAL *f = (LS_REAL *)(void *)((char *)c + off);
    *f = relative ? *f * v : v;
}

/* the sample rate is one field for the drive: every module's copy follows it */
static void set_fs(ls_drive_cfg *c, LS_REAL fs)
{
    c->fs = c->inject.fs = c->bpf.fs = c->sep.fs = c->demod.fs = c->obs.fs = c->enc_obs.fs = fs;
    c->current.fs = c->traj.fs = c->prot.fs = c->pos.speed.fs = c->dtres.fs = c->mod.f_pwm = fs;
}

static void overrides(reader *r, ls_drive_cfg *c)
{
    unsigned n = rd_u8(r) & 31u, k;
    for (k = 0u; k < n; ++k) {
        const uint8_t which = rd_u8(r);
        const uint8_t kind = rd_u8(r);
        if (which < N_FIELDS) {
            const LS_REAL v = rd_real(r);
            if (FIELDS[which] == FIELD(fs)) {
                set_fs(c, (kind & 1u) ? c->fs * v : v);
            } else {
                set_field(c, FIELDS[which], v, (kind & 1u) != 0u);
            }
            continue;
        }
        switch (which - N_FIELDS) {
        case 0:
            c->enc_counts = (int32_t)rd_u32(r);
            break;
        case 1:
            c->cal.period = (int32_t)rd_u32(r);
            break;
        case 2:
            c->cal.points = rd_u32(r) % (N_CAL + 1u); /* (the table below holds N_CAL) */
            break;
        case 3:
            c->obs.type = (ls_observer_type)(kind % 3u);
            break;
        case 4:
            c->pos.type = (ls_posctrl_type)(kind % 3u);
            break;
        case 5:
            c->mod.dtc = (kind & 1u) != 0u;
            c->hf_dtres = (kind & 2u) != 0u;
            c->inject_sensored = (kind & 4u) != 0u;
            c->current.decouple = (kind & 8u) != 0u;
            c->dtres.forward = (kind & 16u) != 0u;
            c->dtres.adapt = (kind & 32u) != 0u;
            break;
        case 6:
            c->demod.method = (ls_demod_method)(kind % 4u);
            c->sep.type = (ls_biquad_type)(kind / 4u % 5u);
            /* the injection's shape and the band-pass's type (rotating, square: their own paths) */
            c->inject.shape = (ls_inject_shape)(kind / 20u % 4u);
            c->bpf.type = (ls_biquad_type)(kind / 80u % 5u);
            break;
        case 7:
            c->demod.comp = (kind & 1u) ? NULL : c->demod.comp;
            c->demod.gain_table = (kind & 2u) ? NULL : c->demod.gain_table;
            c->cal.table = (kind & 4u) ? NULL : c->cal.table;
            break;
        default:
            break;
        }
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

static LS_REAL meas_real(reader *r, LS_REAL plausible)
{
    const uint8_t sel = rd_u8(r);
    if (sel < 200u) {
        return plausible + (LS_REAL)((int)sel - 100) * LS_R(0.01);
    }
    return rd_real(r);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const float comp_tab[8] = {0.0f, 0.05f, 0.07f, 0.05f, 0.0f, -0.05f, -0.07f, -0.05f};
    static const float gain_tab[8] = {4.0f, 5.0f, 6.0f, 5.0f, 4.0f, 5.0f, 6.0f, 5.0f};
    float cal_tab[N_CAL];
    reader r;
    ls_lut comp, gain;
    ls_lut_cfg cc, gc;
    ls_drive_cfg cfg;
    ls_drive d;
    ls_cmd cmd;
    ls_meas m;
    ls_status (*const setters[3])(ls_drive *, ls_pos) = {ls_drive_set_position, ls_drive_move_to,
                                                          ls_drive_step_to};
    int32_t enc = 0;
    unsigned ops = 0u, steps = 0u;
    r.p = data;
    r.n = size;
    cc.table = comp_tab;
    cc.len = 8u;
    gc.table = gain_tab;
    gc.len = 8u;
    if (ls_lut_init(&comp, &cc) != LS_OK || ls_lut_init(&gain, &gc) != LS_OK) {
        fail();
    }
    memset(cal_tab, 0, sizeof cal_tab);
    ls_drive_default_cfg(&cfg);
    cfg.demod.comp = &comp;
    cfg.demod.gain_table = &gain;
    cfg.cal.table = cal_tab;
    cfg.cal.points = 8u;
    overrides(&r, &cfg);
    if (ls_drive_init(&d, &cfg) != LS_OK) {
        /* a refused configuration: the drive must refuse to run */
        memset(&m, 0, sizeof m);
        ls_drive_step(&d, &m, &cmd);
        if (cmd.enable || cmd.fault != LS_FAULT_CONFIG) {
            fail();
        }
        return 0;
    }
    m.i_abc[0] = m.i_abc[1] = m.i_abc[2] = LS_R(0.0);
    m.v_dc = LS_R(72.0);
    m.enc_valid = true;
    m.enc_count = 0;
    while (r.n > 0u && ops < 4096u && steps < 65536u) { /* (bounded: no input runs for long) */
        const uint8_t op = rd_u8(&r);
        ++ops;
        switch (op & 15u) {
        case 0:
            (void)ls_drive_set_mode(&d, (ls_mode)(rd_u8(&r) % 6u));
            break;
        case 1: /* set_position, move_to, step_to */
        case 2:
        case 3:
            (void)setters[(op & 15u) - 1u](&d, rd_pos(&r));
            break;
        case 4:
            (void)ls_drive_set_load(&d, rd_real(&r));
            break;
        case 5:
            ls_drive_reset(&d, rd_pos(&r));
            break;
        case 6: /* encoder: a move of a few counts, or any count */
        {
            const uint8_t sel = rd_u8(&r);
            if (sel & 1u) {
                enc = (int32_t)rd_u32(&r);
            } else {
                enc = (int32_t)((uint32_t)enc + (uint32_t)(int32_t)(int8_t)rd_u8(&r));
            }
            m.enc_valid = (sel & 2u) == 0u;
            break;
        }
        default: /* a run of steps; each may change one measurement */
        {
            unsigned n = 1u + (unsigned)rd_u8(&r) * ((op & 16u) ? 16u : 1u), k;
            const uint8_t what = rd_u8(&r);
            switch (what & 7u) {
            case 0:
            case 1:
            case 2:
                m.i_abc[what & 3u] = meas_real(&r, LS_R(0.0));
                break;
            case 3:
                m.v_dc = meas_real(&r, LS_R(72.0));
                break;
            default:
                break;
            }
            for (k = 0u; k < n; ++k, ++steps) {
                m.enc_count = enc;
                ls_drive_step(&d, &m, &cmd);
                check_cmd(&cmd);
                if (what & 8u) { /* the encoder moves one count per step */
                    enc = (int32_t)((uint32_t)enc + ((what & 16u) ? 1u : 0xFFFFFFFFu));
                }
            }
            break;
        }
        }
    }
    return 0;
}
