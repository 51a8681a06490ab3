/* Unit tests of ls_sincos (linsense/ls_math.h): the float build's sine table against double sin;
 * maximum absolute error against double sin/cos on a dense grid of [-4 pi, 4 pi] (where the drive
 * uses it: the table path), on a coarser grid up to the end of the
 * inline reduction, across the whole float range (the Payne-Hanek path), at the quadrant
 * boundaries, and NaN/Inf inputs (NaN out, no crash). */
#include <float.h>
#include <stdint.h>
#include <string.h>

#include "linsense/ls_math.h"
#include "ls_test.h"

#define PI_D 3.14159265358979323846

/* the float build must reach 2e-7; the double build uses libm */
#ifdef LS_REAL_DOUBLE
#define TOL 1e-15
#else
#define TOL 2e-7
#endif

static double worst;
static double worst_x;

static void probe(LS_REAL x)
{
    LS_REAL c, s;
    double ec, es;
    ls_sincos(x, &c, &s);
    ec = fabs((double)c - cos((double)x));
    es = fabs((double)s - sin((double)x));
    if (!(ec <= worst)) { /* also NaN */
        worst = ec;
        worst_x = (double)x;
    }
    if (!(es <= worst)) {
        worst = es;
        worst_x = (double)x;
    }
}

static void test_dense(void)
{
    const long n = 4000000;
    long k;
    worst = 0.0;
    for (k = 0; k <= n; ++k) {
        probe((LS_REAL)(-4.0 * PI_D + 8.0 * PI_D * (double)k / (double)n));
    }
    printf("  [-4 pi, 4 pi], %ld points: max abs error %.3g at x = %.9g\n", n + 1, worst, worst_x);
    LS_CHECK(worst <= TOL);
}

/* every float in a few ulp-neighbourhoods of the quadrant boundaries and of 0 */
static void test_boundaries(void)
{
    int q, i;
    worst = 0.0;
    for (q = -16; q <= 16; ++q) {
        LS_REAL x = (LS_REAL)(q * PI_D / 4.0);
        for (i = 0; i < 2000; ++i) {
            probe(x);
            x = nextafterf((float)x, 1e30f);
        }
        x = (LS_REAL)(q * PI_D / 4.0);
        for (i = 0; i < 2000; ++i) {
            probe(x);
            x = nextafterf((float)x, -1e30f);
        }
    }
    probe(LS_R(0.0));
    probe(LS_R(-0.0));
    probe((LS_REAL)FLT_MIN);
    probe((LS_REAL)1e-30);
    printf("  around k pi/4 and 0: max abs error %.3g at x = %.9g\n", worst, worst_x);
    LS_CHECK(worst <= TOL);
}

static void test_wide(void)
{
    const long n = 2000000;
    long k;
    worst = 0.0;
    for (k = 0; k <= n; ++k) {
        probe((LS_REAL)(-8192.0 + 16384.0 * (double)k / (double)n));
    }
    printf("  [-8192, 8192], %ld points: max abs error %.3g at x = %.9g\n", n + 1, worst, worst_x);
    LS_CHECK(worst <= TOL);
}

/* the general reduction: pseudo-random floats of every exponent from 2^12 up to FLT_MAX */
static void test_huge(void)
{
    uint32_t seed = 1u, k;
    worst = 0.0;
    for (k = 0; k < 400000u; ++k) {
        uint32_t u;
        float x;
        seed = seed * 1664525u + 1013904223u;
        u = ((139u + (seed >> 8) % 116u) << 23) | ((seed * 2654435761u) & 0x7FFFFFu); /* 2^12..2^127 */
        if ((k & 1u) != 0u) {
            u |= 0x80000000u;
        }
        memcpy(&x, &u, sizeof x);
        probe((LS_REAL)x);
    }
    probe((LS_REAL)FLT_MAX);
    probe((LS_REAL)-FLT_MAX);
    probe((LS_REAL)8192.0f);
    probe((LS_REAL)nextafterf(8192.0f, 1e30f));
    probe((LS_REAL)-8192.0f);
    probe((LS_REAL)nextafterf(-8192.0f, -1e30f));
    probe((LS_REAL)16777216.0f);
    probe((LS_REAL)1e10f);
    probe((LS_REAL)1e30f);
    printf("  |x| in [2^12, FLT_MAX]: max abs error %.3g at x = %.9g\n", worst, worst_x);
    LS_CHECK(worst <= TOL);
}

static void test_nonfinite(void)
{
    LS_REAL c = LS_R(0.0), s = LS_R(0.0);
    ls_sincos((LS_REAL)NAN, &c, &s);
    LS_CHECK(c != c && s != s);
    ls_sincos((LS_REAL)INFINITY, &c, &s);
    LS_CHECK(c != c && s != s);
    ls_sincos((LS_REAL)-INFINITY, &c, &s);
    LS_CHECK(c != c && s != s);
    ls_sincos_full((LS_REAL)NAN, &c, &s);
    LS_CHECK(c != c && s != s);
    ls_sincos_full(LS_R(0.5), &c, &s); /* the general entry accepts small arguments too */
    LS_CHECK_NEAR(c, cos(0.5), TOL);
    LS_CHECK_NEAR(s, sin(0.5), TOL);
}

#ifndef LS_REAL_DOUBLE
/* the sine table: every point the float nearest sin(2 pi k / N) (half an ulp, at most 3e-8), and
 * the table path's edges: |x| = LS_SINCOS_TAB_MAX and just beyond (the polynomial path) */
static void test_table(void)
{
    unsigned k;
    double worst_tab = 0.0;
    for (k = 0u; k < LS_SIN_TAB_N; ++k) {
        const double e = fabs((double)ls_sin_tab[k] - sin(2.0 * PI_D * (double)k / (double)LS_SIN_TAB_N));
        worst_tab = e > worst_tab ? e : worst_tab;
    }
    printf("  sine table, %u points: max error %.3g\n", (unsigned)LS_SIN_TAB_N, worst_tab);
    LS_CHECK(worst_tab <= 3e-8);
    worst = 0.0;
    probe(LS_SINCOS_TAB_MAX);
    probe(-LS_SINCOS_TAB_MAX);
    probe(nextafterf(LS_SINCOS_TAB_MAX, 100.0f));
    probe(nextafterf(-LS_SINCOS_TAB_MAX, -100.0f));
    LS_CHECK(worst <= TOL);
}
#endif

/* ls_exp against double exp: the relative error on a grid of its range (steps of 2e-5 relative, 1e-7
 * near 0: about 1.7 million points; an exhaustive run over every float measured at most 8.2e-8),
 * and its ends and non-finite inputs. */
static void test_exp(void)
{
#ifdef LS_REAL_DOUBLE
    const double tol = 1e-15;
    const LS_REAL lo = LS_R(-700.0), hi = LS_R(700.0);
#else
    const double tol = 1e-7;
    const LS_REAL lo = LS_EXP_MIN, hi = LS_EXP_MAX;
#endif
    double w = 0.0;
    LS_REAL x;
    long n = 0;
    for (x = lo; x <= hi; x += LS_FABS(x) * LS_R(2e-5) + LS_R(1e-7), ++n) {
        const double e = exp((double)x);
        const double r = fabs((double)ls_exp(x) - e) / e;
        w = r > w ? r : w;
    }
    printf("  ls_exp: max relative error %.3g over %ld points\n", w, n);
    LS_CHECK(w <= tol);
    LS_CHECK(ls_exp(LS_R(0.0)) == LS_R(1.0));
    LS_CHECK(ls_exp(-(LS_REAL)INFINITY) == LS_R(0.0));
    LS_CHECK(ls_exp((LS_REAL)INFINITY) == (LS_REAL)INFINITY);
    LS_CHECK(ls_exp((LS_REAL)NAN) != ls_exp((LS_REAL)NAN));
#ifndef LS_REAL_DOUBLE
    LS_CHECK(ls_exp(nextafterf(LS_EXP_MIN, -100.0f)) == 0.0f && ls_exp(nextafterf(LS_EXP_MAX, 100.0f)) == INFINITY);
    LS_CHECK(ls_exp(LS_EXP_MIN) > 0.0f && ls_exp(LS_EXP_MIN) >= FLT_MIN && ls_exp(LS_EXP_MAX) < FLT_MAX);
#endif
}

int main(void)
{
#ifndef LS_REAL_DOUBLE
    test_table();
#endif
    test_exp();
    test_dense();
    test_boundaries();
    test_wide();
    test_huge();
    test_nonfinite();
    return ls_test_report("test_math");
}
