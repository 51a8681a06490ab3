/* linsense simulator, the sensors (ls_sim.h): phase currents with gain, offset, Gaussian noise and ADC
 * quantisation, and the incremental encoder. */
#include "ls_sim_internal.h"

static uint64_t rng_next(uint64_t *s)
{
    uint64_t x = *s;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *s = x;
    return x * 2685821657736338717ull;
}

static double rng_gauss(uint64_t *s)
{
    double u1 = ((double)(rng_next(s) >> 11) + 0.5) * (1.0 / 9007199254740992.0);
    double u2 = (double)(rng_next(s) >> 11) * (1.0 / 9007199254740992.0);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * LS_SIM_PI * u2);
}

LS_SIM_HOT void ls_sim_measure(const ls_sim_cfg *c, const ls_sim_coef *q, const double i_ab[2], double x,
                               bool encoder, uint64_t *rng, ls_meas *m)
{
    double iabc[3], u;
    int j;
    ls_sim_ab_to_abc(i_ab, iabc);
    for (j = 0; j < 3; ++j) {
        double y = c->i_gain[j] * iabc[j] + c->i_offset[j];
        if (c->i_noise > 0.0) {
            y += c->i_noise * rng_gauss(rng);
        }
        if (q->lsb > 0.0) {
            y = q->lsb * floor(y / q->lsb + 0.5);
            y = y > c->adc_range ? c->adc_range : (y < -c->adc_range ? -c->adc_range : y);
        }
        m->i_abc[j] = (LS_REAL)y;
    }
    m->v_dc = (LS_REAL)c->v_dc;
    m->enc_valid = true;
    m->enc_count = 0;
    if (encoder) { /* only modes that read it pay for the conversion */
        u = floor(x / c->pole_pitch * (double)c->enc_counts);
        /* a 32-bit counter: beyond its range (or a diverged plant's NaN) the count saturates, range-
         * checked before the conversion; the drive's plausibility check sees the jump */
        if (!(u >= -2147483648.0)) {
            u = -2147483648.0;
        } else if (u > 2147483647.0) {
            u = 2147483647.0;
        }
        m->enc_count = (int32_t)u;
    }
}

