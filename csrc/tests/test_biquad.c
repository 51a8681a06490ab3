/* Biquad filters: measured frequency response (steady-state sine in, amplitude and phase out)
 * against the design transfer function H(z) of the cookbook formulas evaluated in double, plus
 * the properties the drive relies on: 0 dB at the band-pass centre, a deep notch, and refusal
 * of bad configurations. */
#include <math.h>
#include <stdio.h>

#include "linsense/ls_biquad.h"
#include "ls_test.h"

#define PI 3.14159265358979323846

/* |H| and arg H of the analogue-prototype design at f (double precision reference) */
static void design_response(ls_biquad_type type, double f0, double q, double fs, double f, double *mag,
                            double *ph)
{
    double w0 = 2 * PI * f0 / fs, cw = cos(w0), al = sin(w0) / (2 * q);
    double b0, b1, b2, a0 = 1 + al, a1 = -2 * cw, a2 = 1 - al;
    double w = 2 * PI * f / fs;
    double nr, ni, dr, di;
    if (type == LS_BIQUAD_LOWPASS) {
        b0 = (1 - cw) / 2; b1 = 1 - cw; b2 = b0;
    } else if (type == LS_BIQUAD_BANDPASS) {
        b0 = al; b1 = 0; b2 = -al;
    } else {
        b0 = 1; b1 = -2 * cw; b2 = 1;
    }
    nr = b0 + b1 * cos(w) + b2 * cos(2 * w);
    ni = -b1 * sin(w) - b2 * sin(2 * w);
    dr = a0 + a1 * cos(w) + a2 * cos(2 * w);
    di = -a1 * sin(w) - a2 * sin(2 * w);
    *mag = sqrt(nr * nr + ni * ni) / sqrt(dr * dr + di * di);
    *ph = atan2(ni, nr) - atan2(di, dr);
}

/* measured by correlation over whole periods after the transient */
static void measure(ls_biquad *bq, double f, double fs, double *mag, double *ph)
{
    int n_settle = 20000, n = (int)fs, k; /* 1 s: whole periods of every integer frequency */
    double si = 0, sq = 0;
    ls_biquad_reset(bq);
    for (k = 0; k < n_settle; ++k) {
        (void)ls_biquad_step(bq, (LS_REAL)sin(2 * PI * f * k / fs));
    }
    for (k = n_settle; k < n_settle + n; ++k) {
        double y = (double)ls_biquad_step(bq, (LS_REAL)sin(2 * PI * f * k / fs));
        si += y * sin(2 * PI * f * k / fs);
        sq += y * cos(2 * PI * f * k / fs);
    }
    *mag = 2 * sqrt(si * si + sq * sq) / n;
    *ph = atan2(sq, si);
}

static double wrap(double a)
{
    while (a > PI) a -= 2 * PI;
    while (a < -PI) a += 2 * PI;
    return a;
}

static void check_type(ls_biquad_type type, double f0, double q)
{
    const double fs = 16000.0;
    static const double freqs[] = {10, 100, 300, 700, 950, 1000, 1050, 1500, 3000, 6000};
    ls_biquad_cfg cfg;
    ls_biquad bq;
    unsigned i;
    cfg.type = type; cfg.f0 = (LS_REAL)f0; cfg.q = (LS_REAL)q; cfg.fs = (LS_REAL)fs;
    LS_CHECK(ls_biquad_init(&bq, &cfg) == LS_OK);
    for (i = 0; i < sizeof freqs / sizeof freqs[0]; ++i) {
        double m_meas, p_meas, m_des, p_des;
        measure(&bq, freqs[i], fs, &m_meas, &p_meas);
        design_response(type, f0, q, fs, freqs[i], &m_des, &p_des);
        LS_CHECK_NEAR(m_meas, m_des, 2e-3 + 2e-3 * m_des);
        if (m_des > 0.05) {
            LS_CHECK_NEAR(wrap(p_meas - p_des), 0.0, 5e-3);
        }
    }
}

/* The drive's specialised steps (ls_biquad_step_bp, _notch, _sym) drop only the operations on the
 * zero and the repeated coefficients: the same outputs and states as ls_biquad_step, bit for bit,
 * over a long random run. */
static void test_specialised_steps(void)
{
    static const ls_biquad_type types[] = {LS_BIQUAD_BANDPASS, LS_BIQUAD_NOTCH, LS_BIQUAD_LOWPASS};
    unsigned t, seed = 12345u;
    long k, differ = 0;
    for (t = 0; t < 3u; ++t) {
        ls_biquad_cfg cfg = {types[t], LS_R(1000.0), LS_R(2.0), LS_R(16000.0)};
        ls_biquad a, b;
        LS_CHECK(ls_biquad_init(&a, &cfg) == LS_OK);
        b = a;
        for (k = 0; k < 200000; ++k) {
            LS_REAL x, ya, yb;
            seed = seed * 1103515245u + 12345u;
            x = (LS_REAL)((double)(seed >> 8) / 16777216.0 - 0.5) * LS_R(4.0);
            ya = ls_biquad_step(&a, x);
            yb = types[t] == LS_BIQUAD_BANDPASS ? ls_biquad_step_bp(&b, x)
                 : types[t] == LS_BIQUAD_NOTCH  ? ls_biquad_step_notch(&b, x)
                                                : ls_biquad_step_sym(&b, x);
            differ += ya != yb || a.z1 != b.z1 || a.z2 != b.z2;
        }
    }
    printf("  specialised biquad steps: %ld of 600000 samples differ from the general step\n", differ);
    LS_CHECK(differ == 0);
}

int main(void)
{
    ls_biquad_cfg cfg = {LS_BIQUAD_BANDPASS, LS_R(1000.0), LS_R(2.0), LS_R(16000.0)};
    ls_biquad bq;
    double m, p;
    test_specialised_steps();
    check_type(LS_BIQUAD_LOWPASS, 150.0, 0.70710678);
    check_type(LS_BIQUAD_BANDPASS, 1000.0, 2.0);
    check_type(LS_BIQUAD_NOTCH, 1000.0, 2.0);
    /* properties used by the drive */
    LS_CHECK(ls_biquad_init(&bq, &cfg) == LS_OK);
    measure(&bq, 1000.0, 16000.0, &m, &p);
    LS_CHECK_NEAR(m, 1.0, 2e-3); /* band-pass: unity gain ... */
    LS_CHECK_NEAR(p, 0.0, 2e-3); /* ... and zero phase at the injection frequency */
    cfg.type = LS_BIQUAD_NOTCH;
    LS_CHECK(ls_biquad_init(&bq, &cfg) == LS_OK);
    measure(&bq, 1000.0, 16000.0, &m, &p);
    LS_CHECK(m < 1e-3); /* notch removes the injection from the current loop */
    measure(&bq, 5.0, 16000.0, &m, &p);
    LS_CHECK_NEAR(m, 1.0, 1e-3); /* and passes the fundamental */
    /* the first difference (square-wave injection): y[k] = x[k] - x[k-1], exactly, whatever f0, q */
    {
        ls_biquad_cfg dc = {LS_BIQUAD_DIFF, LS_R(0.0), LS_R(0.0), LS_R(16000.0)};
        LS_REAL x_prev = LS_R(0.0);
        int k;
        LS_CHECK(ls_biquad_init(&bq, &dc) == LS_OK);
        for (k = 0; k < 100; ++k) {
            const LS_REAL x = LS_R(0.37) * (LS_REAL)(k % 7) - LS_R(1.1) * (LS_REAL)(k % 3);
            LS_CHECK(ls_biquad_step(&bq, x) == x - x_prev);
            x_prev = x;
        }
        dc.fs = LS_R(0.0);
        LS_CHECK(ls_biquad_init(&bq, &dc) == LS_ERR_PARAM);
    }
    /* refusals */
    cfg.f0 = LS_R(8000.0);
    LS_CHECK(ls_biquad_init(&bq, &cfg) == LS_ERR_PARAM);
    cfg.f0 = LS_R(1000.0); cfg.q = LS_R(0.0);
    LS_CHECK(ls_biquad_init(&bq, &cfg) == LS_ERR_PARAM);
    cfg.q = LS_R(1.0); cfg.fs = (LS_REAL)NAN;
    LS_CHECK(ls_biquad_init(&bq, &cfg) == LS_ERR_PARAM);
    cfg.fs = LS_R(16000.0); cfg.type = (ls_biquad_type)7;
    LS_CHECK(ls_biquad_init(&bq, &cfg) == LS_ERR_PARAM);
    LS_CHECK(ls_biquad_init(NULL, &cfg) == LS_ERR_NULL);
    return ls_test_report("test_biquad");
}
