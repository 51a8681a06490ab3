/* The hand-over block (ls_fuse, linsense/ls_fuse.h; docs/theory.md section 11): the EMF error's
 * weight is 0 up to v_lo, 1 from v_hi and a straight line between, and moves no more per step than
 * the speed does over the band; below the band the HF error passes bit for bit; negative speeds give
 * the positive ones' outputs bit for bit; the injection's flag changes only above v_off (off) and
 * below v_on (on), never twice without the speed crossing the whole hysteresis, also for a speed
 * hovering with noise in the band and around either threshold; after a fade the HF error is ignored
 * until t_settle at full amplitude (the EMF error alone in the band, nothing below it), at a reset it
 * counts at once; init refuses each bad field.
 *
 * Mutations this test kills (checked by hand, the header edited and the test rebuilt): v_on and
 * v_off swapped in ls_fuse_step (the hysteresis' thresholds), the n_full reset at a fade dropped (the
 * settle counter), the exact "return eps_hf" below the band replaced by the blend (-0.0 and a
 * huge EMF error), the weight's clamp at 1 dropped; in ls_fuse_emf_run the start at w_emf_off, the
 * stop at w_emf_on, a reset that leaves it running. */
#include <stdint.h>
#include <string.h>

#include "linsense/ls_fuse.h"
#include "ls_test.h"

#define PI 3.14159265358979323846
#define FS 16384.0  /* Hz: a power of two, so that t_settle fs is exact in float */
#define TAU 0.056   /* m: ecce2010's pitch */
#define V_LO 0.2    /* m/s */
#define V_HI 0.4
#define V_ON 0.5
#define V_OFF 0.575
#define T_SETTLE 0.0078125 /* s: 128 periods at FS */

static ls_fuse_cfg base_cfg(void)
{
    ls_fuse_cfg c;
    c.fs = (LS_REAL)FS;
    c.pole_pitch = (LS_REAL)TAU;
    c.v_lo = (LS_REAL)V_LO;
    c.v_hi = (LS_REAL)V_HI;
    c.v_on = (LS_REAL)V_ON;
    c.v_off = (LS_REAL)V_OFF;
    c.t_settle = (LS_REAL)T_SETTLE;
    return c;
}

static LS_REAL omega_of(double v)
{
    return (LS_REAL)(v * 2.0 * PI / TAU);
}

/* the float arithmetic's floor on a weight / an error of order 1 */
static double tol(void)
{
    return sizeof(LS_REAL) == 4 ? 2e-6 : 1e-12;
}

/* uniform in [-1, 1), a fixed sequence */
static double noise(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return (double)(*s >> 8) / 8388608.0 - 1.0;
}

static void init_ok(ls_fuse *f)
{
    ls_fuse_cfg c = base_cfg();
    LS_CHECK(ls_fuse_init(f, &c) == LS_OK);
}

/* The weight's ramp: against the formula at every speed of a fine sweep (both signs), the output the
 * blend (1 - w) eps_hf + w eps_emf, and the step's change bounded by the speed's over the band. */
static void test_ramp(void)
{
    const LS_REAL e_hf = (LS_REAL)0.3, e_emf = (LS_REAL)-0.2;
    const int n = 4000;
    int k, sgn, worst_k = -1;
    double worst = 0.0, prev_w = 0.0, prev_v = 0.0;
    for (sgn = -1; sgn <= 1; sgn += 2) {
        ls_fuse f;
        init_ok(&f);
        for (k = 0; k <= n; ++k) {
            const double v = V_ON * 0.999 * k / n; /* (below v_on: the injection stays on) */
            const double w_ref = v <= V_LO ? 0.0 : v >= V_HI ? 1.0 : (v - V_LO) / (V_HI - V_LO);
            const LS_REAL out = ls_fuse_step(&f, omega_of(sgn * v), true, e_hf, e_emf);
            LS_CHECK(f.hf_used);
            LS_CHECK(f.inject);
            LS_CHECK_NEAR(f.w, w_ref, tol());
            LS_CHECK_NEAR(out, (1.0 - w_ref) * (double)e_hf + w_ref * (double)e_emf, 2.0 * tol());
            if (k > 0) { /* continuous: |dw| <= |dv| / (v_hi - v_lo) */
                const double slope = fabs((double)f.w - prev_w) / (fabs(v - prev_v) / (V_HI - V_LO));
                if (slope > worst) {
                    worst = slope;
                    worst_k = k;
                }
            }
            prev_w = (double)f.w;
            prev_v = v;
        }
    }
    printf("ramp: largest |dw| / (|dv| / (v_hi - v_lo)) %.6g (step %d)\n", worst, worst_k);
    LS_CHECK(worst <= 1.0 + 1e-3);
    LS_CHECK(worst >= 0.999); /* (the sweep crosses the band) */
}

/* Below the band the HF error passes bit for bit, whatever the EMF error (a huge one, -0.0 HF). */
static void test_exact_below(void)
{
    static const double hf[6] = {0.0, -0.0, 1e-30, -0.7, 3.1, 1.2345678};
    static const double emf[3] = {0.0, -2.9, 3.0e38};
    static const double speeds[5] = {0.0, 0.01, 0.1, 0.19, V_LO};
    int a, b, c, sgn, bad = 0;
    for (sgn = -1; sgn <= 1; sgn += 2) {
        for (c = 0; c < 5; ++c) {
            for (a = 0; a < 6; ++a) {
                for (b = 0; b < 3; ++b) {
                    ls_fuse f;
                    LS_REAL out, in = (LS_REAL)hf[a];
                    init_ok(&f);
                    out = ls_fuse_step(&f, omega_of(sgn * speeds[c]), true, in, (LS_REAL)emf[b]);
                    bad += memcmp(&out, &in, sizeof out) != 0;
                    LS_CHECK(f.w == 0 && f.hf_used);
                }
            }
        }
    }
    LS_CHECK(bad == 0);
}

/* Negative speeds: every output, weight and flag of a random walk of the speed equals the mirrored
 * walk's, bit for bit. */
static void test_symmetric(void)
{
    ls_fuse p, m;
    uint32_t s = 7u;
    double v = 0.0;
    int k, bad = 0;
    init_ok(&p);
    init_ok(&m);
    for (k = 0; k < 200000; ++k) {
        const LS_REAL e_hf = (LS_REAL)(0.5 * noise(&s)), e_emf = (LS_REAL)(0.5 * noise(&s));
        LS_REAL op, om;
        v += 0.002 * noise(&s);
        v = v < 0.0 ? -v : v > 0.9 ? 1.8 - v : v;
        op = ls_fuse_step(&p, omega_of(v), p.inject && k % 3 != 0, e_hf, e_emf);
        om = ls_fuse_step(&m, -omega_of(v), m.inject && k % 3 != 0, e_hf, e_emf);
        bad += memcmp(&op, &om, sizeof op) != 0 || memcmp(&p.w, &m.w, sizeof p.w) != 0 ||
               p.inject != m.inject || p.hf_used != m.hf_used || p.n_full != m.n_full;
    }
    LS_CHECK(bad == 0);
}

/* A run of the flag against a speed profile: the injection's amplitude follows the flag after
 * `ramp` steps (hf_full as the drive computes it). Counts the flag's transitions, checks each is at
 * its threshold (off: |v| > v_off, on: |v| < v_on) and that between two transitions the speed crossed
 * the whole hysteresis (above v_off and below v_on); returns the transitions. */
typedef struct {
    ls_fuse f;
    int amp;            /* steps of ramp done, [0, ramp] */
    int ramp;
    long transitions;
    long bad_threshold; /* transitions not at their threshold */
    long bad_twice;     /* two transitions without the speed crossing the hysteresis */
    double v_max_since, v_min_since; /* |v| since the last transition */
    int seen;           /* a transition seen */
} flag_run;

static void flag_start(flag_run *r, int ramp)
{
    init_ok(&r->f);
    r->amp = ramp;
    r->ramp = ramp;
    r->transitions = 0;
    r->bad_threshold = 0;
    r->bad_twice = 0;
    r->v_max_since = 0.0;
    r->v_min_since = 1e9;
    r->seen = 0;
}

static void flag_step(flag_run *r, double v)
{
    const bool before = r->f.inject;
    const LS_REAL om = omega_of(v), a = LS_FABS(om);
    r->v_max_since = fmax(r->v_max_since, fabs(v));
    r->v_min_since = fmin(r->v_min_since, fabs(v));
    (void)ls_fuse_step(&r->f, om, r->amp >= r->ramp, (LS_REAL)0.1, (LS_REAL)-0.1);
    if (r->f.inject != before) {
        /* at the threshold: against the block's own electrical speeds (no rounding doubt) */
        r->bad_threshold += r->f.inject ? !(a < r->f.w_on) : !(a > r->f.w_off);
        if (r->seen && !(r->v_max_since > V_OFF * (1.0 - 1e-6) && r->v_min_since < V_ON * (1.0 + 1e-6))) {
            r->bad_twice++;
        }
        r->transitions++;
        r->seen = 1;
        r->v_max_since = fabs(v);
        r->v_min_since = fabs(v);
    }
    r->amp = r->f.inject ? (r->amp < r->ramp ? r->amp + 1 : r->ramp) : (r->amp > 0 ? r->amp - 1 : 0);
}

static void test_hysteresis_sweep(void)
{
    int k, sgn;
    for (sgn = -1; sgn <= 1; sgn += 2) {
        flag_run r;
        double v_first_off = -1.0, v_first_on = -1.0;
        flag_start(&r, 32);
        for (k = 0; k <= 20000; ++k) { /* 0 -> 1 m/s and back, 1e-4 m/s per step */
            const double v = sgn * (k <= 10000 ? k : 20000 - k) * 1e-4;
            const bool before = r.f.inject;
            flag_step(&r, v);
            if (before && !r.f.inject && v_first_off < 0.0) {
                v_first_off = fabs(v);
            }
            if (!before && r.f.inject && v_first_on < 0.0) {
                v_first_on = fabs(v);
            }
        }
        printf("sweep %+d: %ld transitions, off at %.4f m/s (v_off %.3f), on at %.4f m/s (v_on %.3f)\n", sgn,
               r.transitions, v_first_off, V_OFF, v_first_on, V_ON);
        LS_CHECK(r.transitions == 2);
        LS_CHECK(r.bad_threshold == 0 && r.bad_twice == 0);
        LS_CHECK(v_first_off > V_OFF && v_first_off <= V_OFF + 1.0001e-4);
        LS_CHECK(v_first_on < V_ON && v_first_on >= V_ON - 1.0001e-4);
        LS_CHECK(r.f.inject);
    }
}

/* A speed hovering with noise (amplitude below half the hysteresis) in the band's middle, around
 * v_on and around v_off, each from both states of the flag; and a wide random walk: the flag changes
 * at most once in a hover (never back), and in the walk only at its thresholds, never twice
 * without the whole hysteresis crossed. In the band the weight moves no more than the speed does. */
static void test_hover(void)
{
    static const double centre[3] = {0.5 * (V_LO + V_HI), V_ON, V_OFF};
    const double amp = 0.45 * (V_OFF - V_ON);
    int c, from_off, k;
    for (c = 0; c < 3; ++c) {
        for (from_off = 0; from_off <= 1; ++from_off) {
            flag_run r;
            uint32_t s = 12345u + (uint32_t)c;
            double prev_w = -1.0, prev_v = 0.0, worst = -1.0;
            flag_start(&r, 32);
            if (from_off) { /* above v_off first: the injection faded */
                flag_step(&r, 1.0);
                r.transitions = 0;
                r.seen = 0;
            }
            for (k = 0; k < 100000; ++k) {
                const double v = centre[c] + amp * noise(&s);
                flag_step(&r, v);
                if (prev_w >= 0.0 && r.f.hf_used) { /* |dw| beyond |dv| / (v_hi - v_lo) */
                    worst = fmax(worst, fabs((double)r.f.w - prev_w) - fabs(v - prev_v) / (V_HI - V_LO));
                }
                prev_w = r.f.hf_used ? (double)r.f.w : -1.0;
                prev_v = v;
            }
            printf("hover at %.4f m/s +- %.4f from %s: %ld transitions, |dw| - |dv| / band <= %.3g\n", centre[c],
                   amp, from_off ? "off" : "on", r.transitions, worst);
            LS_CHECK(r.transitions <= 1);
            LS_CHECK(r.bad_threshold == 0 && r.bad_twice == 0);
            LS_CHECK(worst <= 10.0 * tol());
            if (c == 0) { /* in the band: the flag never moves, the HF error keeps counting */
                LS_CHECK(r.transitions == (from_off ? 1 : 0));
                LS_CHECK(r.f.inject && r.f.hf_used);
            }
        }
    }
    { /* a wide random walk over both thresholds, back and forth many times */
        flag_run r;
        uint32_t s = 99u;
        double v = 0.3;
        flag_start(&r, 16);
        for (k = 0; k < 400000; ++k) {
            v += 0.004 * noise(&s);
            v = v < 0.0 ? -v : v > 0.8 ? 1.6 - v : v;
            flag_step(&r, k % 2 ? v : -v); /* (the sign alternating: |v| counts) */
        }
        printf("random walk: %ld transitions, %ld off-threshold, %ld without the hysteresis crossed\n",
               r.transitions, r.bad_threshold, r.bad_twice);
        LS_CHECK(r.transitions >= 20);
        LS_CHECK(r.bad_threshold == 0 && r.bad_twice == 0);
    }
}

/* The settle counter: at a reset the HF error counts at the first full-amplitude step; after a fade
 * only from the n_settle-th step at full amplitude (the EMF error alone in the band meanwhile,
 * nothing below it); steps not at full amplitude do not count; n_settle rounded up; t_settle = 0. */
static void test_settle(void)
{
    ls_fuse f;
    ls_fuse_cfg c = base_cfg();
    LS_REAL out;
    uint32_t k;
    init_ok(&f);
    LS_CHECK(f.n_settle == 128u);
    out = ls_fuse_step(&f, omega_of(0.3), true, (LS_REAL)0.2, (LS_REAL)-0.2);
    LS_CHECK(f.hf_used); /* (at once after the reset) */
    LS_CHECK_NEAR(out, 0.0, tol());
    /* the fade: above v_off the flag drops, the counter restarts; the fading step itself is still at
     * full amplitude (hf_full as the drive computes it, before ls_inject_enable) but does not count:
     * the HF error returns after n_settle full steps from the next one, t_settle */
    (void)ls_fuse_step(&f, omega_of(0.6), true, (LS_REAL)0.2, (LS_REAL)-0.2);
    LS_CHECK(!f.inject && f.n_full == 0u && !f.hf_used);
    /* back below v_on with the amplitude not yet full: the EMF alone in the band, nothing below it */
    out = ls_fuse_step(&f, omega_of(0.45), false, (LS_REAL)0.2, (LS_REAL)-0.2);
    LS_CHECK(f.inject && !f.hf_used && f.w == 1 && out == (LS_REAL)-0.2);
    out = ls_fuse_step(&f, omega_of(0.3), false, (LS_REAL)0.2, (LS_REAL)-0.2);
    LS_CHECK(!f.hf_used && f.w == 1 && out == (LS_REAL)-0.2);
    out = ls_fuse_step(&f, omega_of(0.1), false, (LS_REAL)0.2, (LS_REAL)-0.2);
    LS_CHECK(!f.hf_used && f.w == 0 && out == 0);
    LS_CHECK(f.n_full == 0u);
    /* full amplitude: 127 steps ignored, the 128th (n_settle) counts */
    for (k = 1u; k < 128u; ++k) {
        out = ls_fuse_step(&f, omega_of(0.3), true, (LS_REAL)0.2, (LS_REAL)-0.2);
        if (f.hf_used || out != (LS_REAL)-0.2) {
            break;
        }
    }
    LS_CHECK(k == 128u);
    out = ls_fuse_step(&f, omega_of(0.3), true, (LS_REAL)0.2, (LS_REAL)-0.2);
    LS_CHECK(f.hf_used && f.n_full == 128u);
    LS_CHECK_NEAR(out, 0.0, tol());
    /* a dip of the amplitude without a fade does not restart the count */
    (void)ls_fuse_step(&f, omega_of(0.3), false, (LS_REAL)0.2, (LS_REAL)-0.2);
    LS_CHECK(!f.hf_used);
    (void)ls_fuse_step(&f, omega_of(0.3), true, (LS_REAL)0.2, (LS_REAL)-0.2);
    LS_CHECK(f.hf_used);
    /* a reset after a fade: counts at once */
    (void)ls_fuse_step(&f, omega_of(0.7), false, (LS_REAL)0.2, (LS_REAL)-0.2);
    LS_CHECK(!f.inject && f.n_full == 0u);
    ls_fuse_reset(&f);
    LS_CHECK(f.inject && f.n_full == f.n_settle && f.w == 0 && !f.hf_used);
    (void)ls_fuse_step(&f, omega_of(0.1), true, (LS_REAL)0.2, (LS_REAL)-0.2);
    LS_CHECK(f.hf_used);
    /* rounded up: 128 + 2^-6 periods -> 129 */
    c.t_settle = (LS_REAL)(T_SETTLE + 1.0 / 1048576.0);
    LS_CHECK(ls_fuse_init(&f, &c) == LS_OK && f.n_settle == 129u);
    /* t_settle = 0: the HF error counts at the first full step after a fade */
    c.t_settle = 0;
    LS_CHECK(ls_fuse_init(&f, &c) == LS_OK && f.n_settle == 0u);
    (void)ls_fuse_step(&f, omega_of(0.7), true, (LS_REAL)0.2, (LS_REAL)-0.2);
    (void)ls_fuse_step(&f, omega_of(0.3), false, (LS_REAL)0.2, (LS_REAL)-0.2);
    LS_CHECK(!f.hf_used);
    (void)ls_fuse_step(&f, omega_of(0.3), true, (LS_REAL)0.2, (LS_REAL)-0.2);
    LS_CHECK(f.hf_used);
}

/* Where the EMF estimate runs (ls_fuse_emf_run): off after a reset; on only above LS_FUSE_EMF_ON
 * v_lo, off again only below LS_FUSE_EMF_OFF v_lo, either sign of the speed; a speed sweeping up and
 * down through both thresholds changes it exactly twice per sweep, one hovering with noise between
 * them never; a NaN speed keeps it as it is (on stays on, off stays off: it never starts it). */
static void test_emf_run(void)
{
    ls_fuse f;
    const double on = LS_FUSE_EMF_ON * V_LO, off = LS_FUSE_EMF_OFF * V_LO;
    uint32_t s = 12345u;
    int k, changes = 0, sign;
    bool prev;
    init_ok(&f);
    LS_CHECK(!f.emf_run);
    LS_CHECK(on > off && on < V_LO); /* (the header's constants: on below the band, hysteresis) */
    for (sign = -1; sign <= 1; sign += 2) {
        ls_fuse_reset(&f);
        LS_CHECK(!ls_fuse_emf_run(&f, omega_of(sign * 0.999 * on)));
        LS_CHECK(ls_fuse_emf_run(&f, omega_of(sign * 1.001 * on)));
        LS_CHECK(ls_fuse_emf_run(&f, omega_of(sign * 1.001 * off))); /* (between: kept) */
        LS_CHECK(ls_fuse_emf_run(&f, omega_of(sign * 5.0 * V_HI)));
        LS_CHECK(!ls_fuse_emf_run(&f, omega_of(sign * 0.999 * off)));
        LS_CHECK(!ls_fuse_emf_run(&f, omega_of(sign * 0.999 * on))); /* (between: kept) */
    }
    /* NaN: kept on, never started */
    LS_CHECK(ls_fuse_emf_run(&f, omega_of(V_HI)) && ls_fuse_emf_run(&f, (LS_REAL)NAN));
    ls_fuse_reset(&f);
    LS_CHECK(!ls_fuse_emf_run(&f, (LS_REAL)NAN));
    /* sweeps: 0 -> 2 v_lo -> 0, twice: four changes */
    ls_fuse_reset(&f);
    prev = f.emf_run;
    for (k = 0; k < 8000; ++k) {
        const double ph = (double)(k % 4000) / 2000.0; /* 0..2 */
        const double v = 2.0 * V_LO * (ph < 1.0 ? ph : 2.0 - ph);
        const bool now = ls_fuse_emf_run(&f, omega_of(v));
        changes += now != prev;
        LS_CHECK(now ? v > 0.9999 * off : v < 1.0001 * on);
        prev = now;
    }
    LS_CHECK(changes == 4);
    /* hovering between the thresholds with noise: no change */
    changes = 0;
    prev = f.emf_run;
    for (k = 0; k < 20000; ++k) {
        const double v = 0.5 * (on + off) + 0.45 * (on - off) * noise(&s);
        const bool now = ls_fuse_emf_run(&f, omega_of(v));
        changes += now != prev;
        prev = now;
    }
    LS_CHECK(changes == 0);
}

/* init refuses each bad field (and accepts the edges allowed: v_on = v_hi, t_settle = 0). */
static void test_refusals(void)
{
    ls_fuse f;
    ls_fuse_cfg c = base_cfg();
    const LS_REAL nan = (LS_REAL)NAN, inf = (LS_REAL)INFINITY;
#define REFUSED(field, value)                                 \
    do {                                                      \
        c = base_cfg();                                       \
        c.field = (LS_REAL)(value);                           \
        LS_CHECK(ls_fuse_init(&f, &c) == LS_ERR_PARAM);       \
    } while (0)
    LS_CHECK(ls_fuse_init(NULL, &c) == LS_ERR_NULL);
    LS_CHECK(ls_fuse_init(&f, NULL) == LS_ERR_NULL);
    REFUSED(fs, 0);
    REFUSED(fs, -FS);
    REFUSED(fs, nan);
    REFUSED(fs, inf);
    REFUSED(pole_pitch, 0);
    REFUSED(pole_pitch, -TAU);
    REFUSED(pole_pitch, nan);
    REFUSED(pole_pitch, inf);
    REFUSED(pole_pitch, sizeof(LS_REAL) == 4 ? 1e-38 : 1e-320); /* (the electrical speeds overflow) */
    REFUSED(v_lo, 0);
    REFUSED(v_lo, -V_LO);
    REFUSED(v_lo, nan);
    REFUSED(v_lo, inf);
    REFUSED(v_hi, V_LO); /* (= v_lo) */
    REFUSED(v_hi, 0.5 * V_LO);
    REFUSED(v_hi, nan);
    REFUSED(v_on, 0.99 * V_HI);
    REFUSED(v_on, nan);
    REFUSED(v_off, V_ON); /* (= v_on) */
    REFUSED(v_off, 0.9 * V_ON);
    REFUSED(v_off, nan);
    REFUSED(v_off, inf);
    REFUSED(t_settle, -1e-6);
    REFUSED(t_settle, 1.0);
    REFUSED(t_settle, nan);
    REFUSED(t_settle, inf);
    c = base_cfg(); /* t_settle fs beyond 32 bits */
    c.fs = (LS_REAL)1e10;
    c.t_settle = (LS_REAL)0.5;
    LS_CHECK(ls_fuse_init(&f, &c) == LS_ERR_PARAM);
    c = base_cfg(); /* the edges allowed */
    c.v_on = c.v_hi;
    c.t_settle = 0;
    LS_CHECK(ls_fuse_init(&f, &c) == LS_OK);
#undef REFUSED
}

int main(void)
{
    test_ramp();
    test_exact_below();
    test_symmetric();
    test_hysteresis_sweep();
    test_hover();
    test_settle();
    test_emf_run();
    test_refusals();
    return ls_test_report("test_fuse");
}
