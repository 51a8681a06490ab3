/* expf for the replay's "common libm" builds (tools/pil.py): one implementation, linked into both the
 * host and the Cortex-M4F replay in place of the C library's (glibc on the host, newlib on the
 * target; the drive's only libm call in a step is expf, in the dead-time residual model when its
 * resistance scale adapts, ls_dtres.c), so that the comparison isolates the compiled library from
 * the two libms. Double arithmetic with +, -, *, / only (IEEE-754 rounds each the same on both: SSE2
 * on the host, the correctly rounded soft-float helpers on the M4F; -ffp-contract=off): exp(x) =
 * 2^n exp(r), n = nearest(x / ln 2), r = x - n ln 2 (|r| <= 0.35, ln 2 in two parts), exp(r) by its
 * Taylor series to r^13 (truncation < 1e-16), rounded once to float. Not a firmware function. */
#include <stdint.h>
#include <string.h>

float expf(float x);

float expf(float x)
{
    const double ln2_hi = 6.93147180369123816490e-01, ln2_lo = 1.90821492927058770002e-10;
    double xd = (double)x, r, p, scale;
    int32_t n, k;
    uint64_t bits;
    if (!(xd == xd)) {
        return x + x;
    }
    if (xd > 88.8) {
        return (float)(1e300 * 1e300);
    }
    if (xd < -104.0) {
        return 0.0f;
    }
    {
        double t = xd * 1.44269504088896338700e+00;
        n = (int32_t)(t < 0.0 ? t - 0.5 : t + 0.5);
    }
    r = (xd - (double)n * ln2_hi) - (double)n * ln2_lo;
    p = 1.0;
    for (k = 13; k >= 1; k--) {
        p = 1.0 + p * r / (double)k;
    }
    bits = (uint64_t)(n + 1023) << 52;
    memcpy(&scale, &bits, sizeof scale);
    return (float)(p * scale);
}
