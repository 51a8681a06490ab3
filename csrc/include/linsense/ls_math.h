/* linsense firmware library: sine and cosine of one angle, and the exponential.
 *
 *   ls_sincos(x, &c, &s)        c = cos(x), s = sin(x), x in rad; inline
 *   ls_sincos_full(x, &c, &s)   the same, out of line (for init code: no inline copy)
 *   ls_phasor_advance(p, dc, ds)   the unit phasor p = (c, s) turned by the step (dc, ds)
 *   ls_exp(x)                   e^x; inline
 *   ls_atan2(y, x)              the angle of (x, y), rad in [-pi, pi]; out of line
 *
 * Float build: no libm call. Where the drive works, |x| <= LS_SINCOS_TAB_MAX (25 rad: the
 * position within the period, a compensation angle), x = k 2 pi / N + r with |r| <= pi / N
 * (N = 256, two-part Cody-Waite subtraction, exact), the sine table gives cos and sin of k 2 pi / N
 * and short Taylor polynomials those of r, combined by one rotation (as CMSIS-DSP's
 * arm_sin_cos_f32; about half the instructions of the polynomial path). Beyond, up to
 * LS_SINCOS_FAST_MAX, x is reduced to r = x - j pi/2, |r| <= pi/4 (a little more), by a
 * three-part Cody-Waite subtraction, exact; r goes through the Cephes minimax polynomials of
 * degree 7 (sin) and 8 (cos), and the quadrant j mod 4 swaps and negates them. Maximum absolute
 * error 9.5e-8 over every float with 25 < |x| <= 8192, 1.3e-7 beyond (csrc/tests/test_math.c
 * checks <= 2e-7 against double sin/cos, and measures the table path). Larger |x| take an exact
 * Payne-Hanek reduction in 32/64-bit integer arithmetic (no double, no libm), valid for every
 * finite float; NaN and +-Inf give NaN. The drive uses it every step, and with it the library
 * needs no sinf/cosf (on a Cortex-M4F, newlib's are slow and large).
 *
 * ls_exp, float build: no libm call either (newlib's expf costs about 115 Cortex-M4F cycles and,
 * being another implementation than glibc's, rounds some results differently from the host's: with
 * ls_exp the library's steps compute the same floats on every target). Cody-Waite reduction by
 * ln 2 and Cephes' degree-7 minimax polynomial (about 30 instructions); relative error at most
 * 8.2e-8 against double exp over every float of [LS_EXP_MIN, LS_EXP_MAX] (measured exhaustively;
 * csrc/tests/test_math.c checks <= 1e-7 on a grid of a million points); 0 below LS_EXP_MIN, +Inf
 * above LS_EXP_MAX, NaN for NaN. -ffp-contract=off keeps it the same on every target.
 *
 * ls_atan2, float build: no libm call (newlib's atan2f and atanf would add about 1 kB to the
 * library for the one caller, ls_emf): the octant reduced to |z| <= 1 with one division, then
 * Abramowitz and Stegun's 4.4.49 polynomial of degree 17 (error 2e-8 rad before rounding;
 * csrc/tests/test_emf.c checks <= 4e-7 rad against double atan2 on a grid of the circle, about a
 * float's step at pi). 0 for
 * (0, 0); NaN for a NaN argument.
 *
 * Double build (-DLS_REAL_DOUBLE): libm sin, cos, exp and atan2.
 */
#ifndef LINSENSE_LS_MATH_H
#define LINSENSE_LS_MATH_H

#include "linsense/ls_types.h"

/* rad, largest |x| reduced inline (2^13: j < 2^13 keeps every product j * PIO2_* exact). */
#define LS_SINCOS_FAST_MAX LS_R(8192.0)

/* points of the sine table over one turn (a power of 2) */
#define LS_SIN_TAB_N 256u
/* sin(2 pi k / N), k = 0 ... N - 1, rounded to float (1 kB of read-only data, as in CMSIS-DSP's
 * arm_sin_cos_f32; csrc/tests/test_math.c checks it against double sin); in the double build too
 * (the calibration's dither reads it). */
extern const float ls_sin_tab[LS_SIN_TAB_N];
#ifndef LS_REAL_DOUBLE
/* rad, largest |x| taken by the table (8 pi a little less: |k| < 2^10 keeps k 2 pi / N exact). */
#define LS_SINCOS_TAB_MAX 25.0f
#endif

/* cos and sin of any x (rad), out of line; NaN for a non-finite x. */
void ls_sincos_full(LS_REAL x, LS_REAL *c, LS_REAL *s);

/* The angle of the vector (x, y), rad in [-pi, pi] (atan2(y, x)); out of line. */
LS_REAL ls_atan2(LS_REAL y, LS_REAL x);

/* A friction model's parameters checked (ls_friction: Coulomb c >= 0 N, viscous b >= 0 N s/m, both
 * finite, and with c > 0 a finite band > 0 m/s): true, with *k = c / band N s/m (0 for c = 0). */
bool ls_friction_slope(LS_REAL c, LS_REAL b, LS_REAL band, LS_REAL *k);


/* Turn the unit phasor (c, s) by the step (dc, ds) = (cos, sin) of a fixed angle and pull it back
 * onto the unit circle (first-order Newton step for 1/|z|, exact to O(err^2) per step, so the error
 * never accumulates): an oscillator at any frequency with no trigonometry per step. Inline. */
typedef struct {
    LS_REAL c, s; /* -, cos and sin */
} ls_phasor;

static inline ls_phasor ls_phasor_advance(ls_phasor p, LS_REAL dc, LS_REAL ds)
{
    /* (by value: through pointers into the callers' structs it cost 4 instructions per step) */
    const LS_REAL cn = p.c * dc - p.s * ds;
    const LS_REAL sn = p.s * dc + p.c * ds;
    const LS_REAL g = LS_R(1.5) - LS_R(0.5) * (cn * cn + sn * sn);
    ls_phasor r;
    r.c = cn * g;
    r.s = sn * g;
    return r;
}

#ifdef LS_REAL_DOUBLE

static inline void ls_sincos(LS_REAL x, LS_REAL *c, LS_REAL *s)
{
    *c = cos(x);
    *s = sin(x);
}

static inline LS_REAL ls_exp(LS_REAL x)
{
    return exp(x);
}

#else

/* cos and sin of r (rad, |r| <= pi/4 + a little) rotated by q quarter turns: cos(r + q pi/2),
 * sin(r + q pi/2). Coefficients: Cephes sinf/cosf (minimax on [-pi/4, pi/4]). */
static inline void ls_sincos_kernel(float r, uint32_t q, float *c, float *s)
{
    /* Estrin's scheme: two short chains instead of one long Horner chain */
    const float r2 = r * r;
    const float r4 = r2 * r2;
    const float sp = r + (r * r2) * ((-1.6666654611e-1f + r2 * 8.3321608736e-3f) + r4 * -1.9515295891e-4f);
    const float cp = (1.0f - 0.5f * r2) +
                     r4 * ((4.166664568298827e-2f + r2 * -1.388731625493765e-3f) + r4 * 2.443315711809948e-5f);
    const float c0 = (q & 1u) != 0u ? sp : cp; /* cos(r + q pi/2) = +-cos r or -+sin r */
    const float s0 = (q & 1u) != 0u ? cp : sp;
    *c = ((q + 1u) & 2u) != 0u ? -c0 : c0;      /* q = 1, 2: negative */
    *s = (q & 2u) != 0u ? -s0 : s0;             /* q = 2, 3: negative */
}

/* The Cody-Waite path, for |x| <= LS_SINCOS_FAST_MAX (ls_sincos_full takes it there). */
static inline void ls_sincos_reduce_(float x, float *c, float *s)
{
    /* j = nearest integer to x 2/pi: |x 2/pi| < 5216, so x 2/pi + 8192.5 > 0 truncates to
     * floor(x 2/pi + 1/2) + 8192 (its rounding, at most 2^-11, only moves |r| a little past
     * pi/4, where the polynomials are still accurate) */
    const float t = x * 0.636619772367581343f + 8192.5f;
    const int32_t q = (int32_t)t - 8192;
    const float j = (float)q;
    /* pi/2 = 1.5703125 + 4.837512969970703125e-4 + 7.54978995489188216e-8 (8 and 11 bits, so
     * j * the first two is exact) */
    const float r = ((x - j * 1.5703125f) - j * 4.837512969970703125e-4f) - j * 7.54978995489188216e-8f;
    ls_sincos_kernel(r, (uint32_t)q, c, s);
}

static inline void ls_sincos(float x, float *c, float *s)
{
    if (LS_FABS(x) <= LS_SINCOS_TAB_MAX) { /* (false for NaN) */
        /* k = nearest integer to x N / (2 pi): |x N / (2 pi)| <= 1019, so + 1024.5 > 0 truncates to
         * floor(x N / (2 pi) + 1/2) + 1024 (its rounding only moves |r| a little past pi / N) */
        const int32_t k = (int32_t)(x * 40.7436654315f + 1024.5f) - 1024;
        const float kf = (float)k;
        /* r = x - k 2 pi / N, |r| <= pi / N = 0.0123: 2 pi / N = 0.02454376220703125 (13 bits, so
         * k times it is exact) - 6.960085841e-8 */
        const float r = (x - kf * 0.02454376220703125f) - kf * -6.960085841e-8f;
        const uint32_t i = (uint32_t)k & (LS_SIN_TAB_N - 1u); /* (k mod N, also for k < 0) */
        const float s0 = ls_sin_tab[i], c0 = ls_sin_tab[(i + LS_SIN_TAB_N / 4u) & (LS_SIN_TAB_N - 1u)];
        const float r2 = r * r;
        const float cr = 1.0f - 0.5f * r2;             /* cos r, to r^4 / 24 < 1e-9 */
        const float sr = r - (r * r2) * (1.0f / 6.0f); /* sin r, to r^5 / 120 < 3e-12 */
        *c = c0 * cr - s0 * sr;
        *s = s0 * cr + c0 * sr;
    } else {
        float c1, s1; /* (the caller's c and s stay in registers: their address does not escape) */
        ls_sincos_full(x, &c1, &s1);
        *c = c1;
        *s = s1;
    }
}

/* ls_exp's range: below LS_EXP_MIN it gives 0, above LS_EXP_MAX +Inf (e^x is still a normal float
 * down to -87.34 and up to 88.72: a little of the float range is given up for a simple reduction) */
#define LS_EXP_MIN (-87.0f)
#define LS_EXP_MAX (88.0f)

/* e^x = 2^k e^r: k = nearest(x / ln 2), r = x - k ln 2 by a two-part Cody-Waite subtraction (ln 2 =
 * 0.693359375 - 2.12194440e-4, the first of 9 bits: k times it is exact for |k| <= 2^15), so
 * |r| <= ln 2 / 2 (a little more: the rounding of x / ln 2); e^r by Cephes' minimax polynomial on
 * that interval (expf.c: 1 + r + r^2 (1/2 + ...)), times 2^k built in the exponent field (a normal
 * float for every k here). */
static inline float ls_exp(float x)
{
    float r, z, p;
    int32_t k;
    union {
        uint32_t u;
        float f;
    } scale; /* (2^k: C99's union punning, no memcpy in a header) */
    if (!(x >= LS_EXP_MIN)) { /* (NaN: NaN) */
        return x == x ? 0.0f : x;
    }
    if (x > LS_EXP_MAX) {
        return HUGE_VALF;
    }
    /* x / ln 2 in [-125.52, 126.96]: + 128.5 > 0 truncates to floor(x / ln 2 + 1/2) + 128 */
    k = (int32_t)(x * 1.44269504088896341f + 128.5f) - 128;
    r = (x - (float)k * 0.693359375f) - (float)k * -2.12194440e-4f;
    z = r * r;
    p = ((((1.9875691500e-4f * r + 1.3981999507e-3f) * r + 8.3334519073e-3f) * r + 4.1665795894e-2f) * r +
         1.6666665459e-1f) * r +
        5.0000001201e-1f;
    p = (p * z + r) + 1.0f;
    scale.u = (uint32_t)(k + 127) << 23; /* (k in [-126, 127]) */
    return p * scale.f;
}

#endif /* LS_REAL_DOUBLE */

#endif /* LINSENSE_LS_MATH_H */
