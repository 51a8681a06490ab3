/* HF injection: amplitude, frequency and phase continuity against cos(2 pi f k / fs) over a
 * long run (no drift), amplitude ramps at the configured rate, the elliptical q component
 * kappa A sin(2 pi f k / fs), refusal of fs < 4 f and of kappa outside [0, 1); the rotating
 * shape (A cos, A sin in the stationary frame) and the square wave (+-A every step, f = fs/2
 * exactly, refused otherwise). */
#include <math.h>

#include "linsense/ls_inject.h"
#include "ls_test.h"

#define PI 3.14159265358979323846

/* Switch on, run 1 s at 16 kHz and return the largest deviation of (v, v_q) from
 * (12 cos, amp_q sin) of 2 pi 1000 k / fs after the 160-step ramp. */
static double carrier_dev(ls_inject *inj, double amp_q)
{
    double max_dev = 0.0;
    long k;
    ls_inject_enable(inj, true);
    for (k = 0; k < 16000; ++k) {
        double v = (double)ls_inject_step(inj);
        if (k >= 160) {
            double ph = 2 * PI * 1000.0 * (double)k / 16000.0;
            double dev = fabs(v - 12.0 * cos(ph)) + fabs((double)inj->v_q - amp_q * sin(ph));
            max_dev = dev > max_dev ? dev : max_dev;
        }
    }
    return max_dev;
}

int main(void)
{
    ls_inject_cfg cfg = {LS_INJ_PULSATING, LS_R(12.0), LS_R(1000.0), LS_R(16000.0), LS_R(1200.0), LS_R(0.0)};
    ls_inject inj;
    long k;
    double max_dev = 0.0;
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_OK);
    ls_inject_enable(&inj, true);
    /* ramp: 12 V at 1200 V/s takes 10 ms = 160 steps */
    for (k = 0; k < 160; ++k) {
        (void)ls_inject_step(&inj);
    }
    LS_CHECK_NEAR(inj.amp, 12.0, 1e-3);
    /* phase-continuous carrier over 10 s (160000 steps): compare with the exact cosine */
    for (k = 160; k < 160000; ++k) {
        double v = (double)ls_inject_step(&inj);
        double ref = 12.0 * cos(2 * PI * 1000.0 * (double)k / 16000.0);
        double dev = fabs(v - ref);
        if (dev > max_dev) {
            max_dev = dev;
        }
    }
    printf("  injection: max deviation from the exact carrier over 10 s: %.3g V\n", max_dev);
    LS_CHECK(max_dev < (sizeof(LS_REAL) == 4 ? 0.05 : 1e-6));
    LS_CHECK_NEAR(inj.c * inj.c + inj.s * inj.s, 1.0, 1e-5);
    /* ramp down: linear, reaches zero after 160 steps, never negative */
    ls_inject_enable(&inj, false);
    for (k = 0; k < 80; ++k) {
        (void)ls_inject_step(&inj);
    }
    LS_CHECK_NEAR(inj.amp, 6.0, 1e-3);
    for (k = 0; k < 100; ++k) {
        (void)ls_inject_step(&inj);
    }
    LS_CHECK(inj.amp == 0);
    LS_CHECK(ls_inject_step(&inj) == 0);
    LS_CHECK(inj.v_q == 0); /* pulsating: nothing on q */
    /* elliptical: kappa A sin on q, in quadrature with the d carrier */
    cfg.quad = LS_R(0.5);
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_OK);
    max_dev = carrier_dev(&inj, 6.0);
    printf("  elliptical injection: max deviation over 1 s: %.3g V\n", max_dev);
    LS_CHECK(max_dev < (sizeof(LS_REAL) == 4 ? 0.01 : 1e-6));
    cfg.quad = LS_R(1.0);
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_ERR_PARAM);
    cfg.quad = LS_R(-0.1);
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_ERR_PARAM);
    cfg.quad = (LS_REAL)NAN;
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_ERR_PARAM);
    cfg.quad = LS_R(0.0);
    /* refusals */
    cfg.fs = LS_R(3999.0);
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_ERR_PARAM);
    cfg.fs = LS_R(16000.0); cfg.ramp_rate = LS_R(0.0);
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_ERR_PARAM);
    cfg.ramp_rate = LS_R(1.0); cfg.amplitude = LS_R(-1.0);
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_ERR_PARAM);
    cfg.amplitude = (LS_REAL)INFINITY;
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_ERR_PARAM);
    /* rotating: v = A cos(phi), v_q = A sin(phi) (the beta part), kappa must be 0 */
    cfg.amplitude = LS_R(12.0);
    cfg.ramp_rate = LS_R(1200.0);
    cfg.shape = LS_INJ_ROTATING;
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_OK);
    max_dev = carrier_dev(&inj, 12.0);
    printf("  rotating injection: max deviation over 1 s: %.3g V\n", max_dev);
    LS_CHECK(max_dev < (sizeof(LS_REAL) == 4 ? 0.01 : 1e-6));
    cfg.quad = LS_R(0.5);
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_ERR_PARAM);
    cfg.quad = LS_R(0.0);
    /* square wave: +-A alternating exactly, at fs/2 only */
    cfg.shape = LS_INJ_SQUARE;
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_ERR_PARAM); /* 1 kHz */
    cfg.freq = LS_R(8000.0);
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_OK);
    ls_inject_enable(&inj, true);
    for (k = 0; k < 160; ++k) {
        (void)ls_inject_step(&inj);
    }
    for (k = 160; k < 160160; ++k) {
        LS_REAL v = ls_inject_step(&inj);
        LS_CHECK(v == (k % 2 == 0 ? LS_R(12.0) : LS_R(-12.0)) && inj.v_q == LS_R(0.0));
        if (ls_test_failed > 0) {
            break;
        }
    }
    cfg.quad = LS_R(0.5);
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_ERR_PARAM);
    cfg.quad = LS_R(0.0);
    cfg.shape = (ls_inject_shape)7;
    LS_CHECK(ls_inject_init(&inj, &cfg) == LS_ERR_PARAM);
    return ls_test_report("test_inject");
}
