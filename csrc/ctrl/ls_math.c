/* General sine/cosine reduction (see linsense/ls_math.h). */
#include <math.h>
#include <string.h>

#include "linsense/ls_math.h"

const float ls_sin_tab[LS_SIN_TAB_N] = {
    0.000000000e+00f, 2.454122901e-02f, 4.906767607e-02f, 7.356456667e-02f, 9.801714122e-02f, 1.224106774e-01f,
    1.467304677e-01f, 1.709618866e-01f, 1.950903237e-01f, 2.191012353e-01f, 2.429801822e-01f, 2.667127550e-01f,
    2.902846634e-01f, 3.136817515e-01f, 3.368898630e-01f, 3.598950505e-01f, 3.826834261e-01f, 4.052413106e-01f,
    4.275550842e-01f, 4.496113360e-01f, 4.713967443e-01f, 4.928981960e-01f, 5.141027570e-01f, 5.349976420e-01f,
    5.555702448e-01f, 5.758081675e-01f, 5.956993103e-01f, 6.152315736e-01f, 6.343932748e-01f, 6.531728506e-01f,
    6.715589762e-01f, 6.895405650e-01f, 7.071067691e-01f, 7.242470980e-01f, 7.409511209e-01f, 7.572088242e-01f,
    7.730104327e-01f, 7.883464098e-01f, 8.032075167e-01f, 8.175848126e-01f, 8.314695954e-01f, 8.448535800e-01f,
    8.577286005e-01f, 8.700869679e-01f, 8.819212914e-01f, 8.932242990e-01f, 9.039893150e-01f, 9.142097831e-01f,
    9.238795042e-01f, 9.329928160e-01f, 9.415440559e-01f, 9.495281577e-01f, 9.569403529e-01f, 9.637760520e-01f,
    9.700312614e-01f, 9.757021070e-01f, 9.807852507e-01f, 9.852776527e-01f, 9.891765118e-01f, 9.924795628e-01f,
    9.951847196e-01f, 9.972904325e-01f, 9.987954497e-01f, 9.996988177e-01f, 1.000000000e+00f, 9.996988177e-01f,
    9.987954497e-01f, 9.972904325e-01f, 9.951847196e-01f, 9.924795628e-01f, 9.891765118e-01f, 9.852776527e-01f,
    9.807852507e-01f, 9.757021070e-01f, 9.700312614e-01f, 9.637760520e-01f, 9.569403529e-01f, 9.495281577e-01f,
    9.415440559e-01f, 9.329928160e-01f, 9.238795042e-01f, 9.142097831e-01f, 9.039893150e-01f, 8.932242990e-01f,
    8.819212914e-01f, 8.700869679e-01f, 8.577286005e-01f, 8.448535800e-01f, 8.314695954e-01f, 8.175848126e-01f,
    8.032075167e-01f, 7.883464098e-01f, 7.730104327e-01f, 7.572088242e-01f, 7.409511209e-01f, 7.242470980e-01f,
    7.071067691e-01f, 6.895405650e-01f, 6.715589762e-01f, 6.531728506e-01f, 6.343932748e-01f, 6.152315736e-01f,
    5.956993103e-01f, 5.758081675e-01f, 5.555702448e-01f, 5.349976420e-01f, 5.141027570e-01f, 4.928981960e-01f,
    4.713967443e-01f, 4.496113360e-01f, 4.275550842e-01f, 4.052413106e-01f, 3.826834261e-01f, 3.598950505e-01f,
    3.368898630e-01f, 3.136817515e-01f, 2.902846634e-01f, 2.667127550e-01f, 2.429801822e-01f, 2.191012353e-01f,
    1.950903237e-01f, 1.709618866e-01f, 1.467304677e-01f, 1.224106774e-01f, 9.801714122e-02f, 7.356456667e-02f,
    4.906767607e-02f, 2.454122901e-02f, 1.224646853e-16f, -2.454122901e-02f, -4.906767607e-02f, -7.356456667e-02f,
    -9.801714122e-02f, -1.224106774e-01f, -1.467304677e-01f, -1.709618866e-01f, -1.950903237e-01f, -2.191012353e-01f,
    -2.429801822e-01f, -2.667127550e-01f, -2.902846634e-01f, -3.136817515e-01f, -3.368898630e-01f, -3.598950505e-01f,
    -3.826834261e-01f, -4.052413106e-01f, -4.275550842e-01f, -4.496113360e-01f, -4.713967443e-01f, -4.928981960e-01f,
    -5.141027570e-01f, -5.349976420e-01f, -5.555702448e-01f, -5.758081675e-01f, -5.956993103e-01f, -6.152315736e-01f,
    -6.343932748e-01f, -6.531728506e-01f, -6.715589762e-01f, -6.895405650e-01f, -7.071067691e-01f, -7.242470980e-01f,
    -7.409511209e-01f, -7.572088242e-01f, -7.730104327e-01f, -7.883464098e-01f, -8.032075167e-01f, -8.175848126e-01f,
    -8.314695954e-01f, -8.448535800e-01f, -8.577286005e-01f, -8.700869679e-01f, -8.819212914e-01f, -8.932242990e-01f,
    -9.039893150e-01f, -9.142097831e-01f, -9.238795042e-01f, -9.329928160e-01f, -9.415440559e-01f, -9.495281577e-01f,
    -9.569403529e-01f, -9.637760520e-01f, -9.700312614e-01f, -9.757021070e-01f, -9.807852507e-01f, -9.852776527e-01f,
    -9.891765118e-01f, -9.924795628e-01f, -9.951847196e-01f, -9.972904325e-01f, -9.987954497e-01f, -9.996988177e-01f,
    -1.000000000e+00f, -9.996988177e-01f, -9.987954497e-01f, -9.972904325e-01f, -9.951847196e-01f, -9.924795628e-01f,
    -9.891765118e-01f, -9.852776527e-01f, -9.807852507e-01f, -9.757021070e-01f, -9.700312614e-01f, -9.637760520e-01f,
    -9.569403529e-01f, -9.495281577e-01f, -9.415440559e-01f, -9.329928160e-01f, -9.238795042e-01f, -9.142097831e-01f,
    -9.039893150e-01f, -8.932242990e-01f, -8.819212914e-01f, -8.700869679e-01f, -8.577286005e-01f, -8.448535800e-01f,
    -8.314695954e-01f, -8.175848126e-01f, -8.032075167e-01f, -7.883464098e-01f, -7.730104327e-01f, -7.572088242e-01f,
    -7.409511209e-01f, -7.242470980e-01f, -7.071067691e-01f, -6.895405650e-01f, -6.715589762e-01f, -6.531728506e-01f,
    -6.343932748e-01f, -6.152315736e-01f, -5.956993103e-01f, -5.758081675e-01f, -5.555702448e-01f, -5.349976420e-01f,
    -5.141027570e-01f, -4.928981960e-01f, -4.713967443e-01f, -4.496113360e-01f, -4.275550842e-01f, -4.052413106e-01f,
    -3.826834261e-01f, -3.598950505e-01f, -3.368898630e-01f, -3.136817515e-01f, -2.902846634e-01f, -2.667127550e-01f,
    -2.429801822e-01f, -2.191012353e-01f, -1.950903237e-01f, -1.709618866e-01f, -1.467304677e-01f, -1.224106774e-01f,
    -9.801714122e-02f, -7.356456667e-02f, -4.906767607e-02f, -2.454122901e-02f};

#ifdef LS_REAL_DOUBLE

void ls_sincos_full(LS_REAL x, LS_REAL *c, LS_REAL *s)
{
    *c = cos(x);
    *s = sin(x);
}

#else

/* Bits of 2/pi after the binary point, preceded by one word of zeros (the integer part): bit t of
 * this string (t = 0 the most significant bit of word 0) is the bit of weight 2^(31 - t). 224
 * fraction bits cover every float exponent. */
static const uint32_t two_over_pi_bits[8] = {
    0x00000000u, 0xA2F9836Eu, 0x4E441529u, 0xFC2757D1u, 0xF534DDC0u, 0xDB629599u, 0x3C439041u, 0xFE5163ABu};

/* Payne-Hanek: |x| = m 2^e (m < 2^24 an integer), so |x| 2/pi mod 4 needs only the bits of 2/pi
 * of weight 2^(1 - e) and below: a 96-bit window W of them times m gives the quadrant in bits
 * 94-95 of the 120-bit product and the fraction below (the bits of 2/pi left out add less than
 * 2^-70 of a quarter turn). 64 fraction bits are kept, normalised, and their leading 32 converted
 * to float. An exhaustive comparison of every float with double sin/cos: at most 1.3e-7. */
void ls_sincos_full(float x, float *c, float *s)
{
    uint32_t u, m, w[3], q, k, sh;
    int32_t e;
    uint64_t p0, p1, p2, f;
    float scale = 1.0f, r;
    int j;
    if (!LS_ISFINITE(x)) {
        *c = *s = x - x; /* NaN */
        return;
    }
    memcpy(&u, &x, sizeof u);
    if (((u >> 23) & 0xFFu) < 127u + 13u) { /* |x| < 2^13: the Cody-Waite reduction is exact */
        ls_sincos_reduce_(x, c, s);
        return;
    }
    m = (u & 0x7FFFFFu) | 0x800000u;
    e = (int32_t)((u >> 23) & 0xFFu) - 150; /* |x| = m 2^e, e in [-10, 104] */
    /* the window starts at bit t0 = e + 30 of two_over_pi_bits (weight 2^(1 - e)) */
    k = (uint32_t)(e + 30) >> 5;
    sh = (uint32_t)(e + 30) & 31u;
    for (j = 0; j < 3; ++j) {
        w[j] = sh == 0u ? two_over_pi_bits[k + (uint32_t)j]
                        : (two_over_pi_bits[k + (uint32_t)j] << sh) |
                              (two_over_pi_bits[k + (uint32_t)j + 1u] >> (32u - sh));
    }
    p2 = (uint64_t)m * w[2];
    p1 = (uint64_t)m * w[1] + (p2 >> 32);
    p0 = (uint64_t)m * w[0] + (p1 >> 32);
    q = (uint32_t)(p0 >> 30) & 3u;
    /* 64-bit fraction below the quadrant bits: 30 bits of p0, 32 of p1, 2 of p2 */
    f = ((p0 & 0x3FFFFFFFu) << 34) | ((p1 & 0xFFFFFFFFu) << 2) | ((p2 & 0xFFFFFFFFu) >> 30);
    if ((f >> 63) != 0u) { /* fraction >= 1/2: round to the next quadrant, r < 0 */
        q = (q + 1u) & 3u;
        f = (uint64_t)0u - f;
        scale = -1.0f;
    }
    if (f == 0u) {
        r = 0.0f;
    } else {
        /* normalise (every step an exact power-of-two scale), then 32 leading bits to float */
        if ((f >> 32) == 0u) {
            f <<= 32;
            scale *= 2.3283064365386963e-10f; /* 2^-32 */
        }
        if ((f >> 48) == 0u) {
            f <<= 16;
            scale *= 1.52587890625e-5f; /* 2^-16 */
        }
        if ((f >> 56) == 0u) {
            f <<= 8;
            scale *= 3.90625e-3f; /* 2^-8 */
        }
        if ((f >> 60) == 0u) {
            f <<= 4;
            scale *= 0.0625f;
        }
        if ((f >> 62) == 0u) {
            f <<= 2;
            scale *= 0.25f;
        }
        if ((f >> 63) == 0u) {
            f <<= 1;
            scale *= 0.5f;
        }
        /* r = f 2^-64 pi/2 */
        r = (float)(uint32_t)(f >> 32) * scale * (2.3283064365386963e-10f * 1.57079632679489662f);
    }
    if (x < 0.0f) { /* sin(-x) = -sin x: the quadrant and r of -x */
        q = (4u - q) & 3u;
        r = -r;
    }
    ls_sincos_kernel(r, q, c, s);
}

#endif /* LS_REAL_DOUBLE */

bool ls_friction_slope(LS_REAL c, LS_REAL b, LS_REAL band, LS_REAL *k)
{
    *k = c > LS_R(0.0) ? c / band : LS_R(0.0);
    return c >= LS_R(0.0) && b >= LS_R(0.0) && LS_ISFINITE3(c, b, *k) && *k >= LS_R(0.0);
}

#ifdef LS_REAL_DOUBLE
LS_REAL ls_atan2(LS_REAL y, LS_REAL x)
{
    return atan2(y, x);
}
#else
float ls_atan2(float y, float x)
{
    /* |z| <= 1 in the octant's frame: atan(y / x) where |y| <= |x|, else pi/2 - atan(x / y) */
    const float ax = fabsf(x), ay = fabsf(y);
    const int steep = ay > ax;
    float z, z2, a;
    if (ax == 0.0f && ay == 0.0f) {
        return 0.0f;
    }
    z = steep ? ax / ay : ay / ax;
    z2 = z * z;
    /* Abramowitz and Stegun 4.4.49 (|error| <= 2e-8 on [-1, 1]) */
    a = z * (1.0f + z2 * (-0.3333314528f + z2 * (0.1999355085f + z2 * (-0.1420889944f + z2 * (0.1065626393f +
        z2 * (-0.0752896400f + z2 * (0.0429096138f + z2 * (-0.0161657367f + z2 * 0.0028662257f))))))));
    if (steep) {
        a = 1.57079632679f - a;
    }
    if (x < 0.0f) {
        a = 3.14159265359f - a;
    }
    return y < 0.0f ? -a : a;
}
#endif
