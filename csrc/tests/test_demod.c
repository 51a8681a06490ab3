/* The rotating injection's negative-sequence demodulator (LS_DEMOD_ROTATING): on a synthetic
 * current with a positive sequence and a negative sequence of phase 2 theta + ref_phase, the
 * ratio is sin(2 delta) / 2 with delta = theta - theta_est - Psi(theta_est), for any estimate and
 * table value, and the level is |i_n|^2; a weak signal is held at 0; a non-finite or huge
 * ref_phase is refused. */
#include <math.h>

#include "linsense/ls_demod.h"
#include "ls_test.h"

#define PI 3.14159265358979323846

/* run the demodulator for 0.2 s at 16 kHz on the rotating injection's current and return the
 * last error */
static double run(ls_demod *d, double theta, double theta_est, double i_n, double ref, double i_p)
{
    const double w = 2 * PI * 1000.0, fs = 16000.0;
    LS_REAL err = LS_R(0.0);
    long k;
    ls_demod_reset(d);
    for (k = 0; k < 3200; ++k) {
        const double ph = w * (double)k / fs;
        /* i_p exp(j phi) + i_n exp(j (2 theta + ref)) exp(-j phi) */
        const double ia = i_p * cos(ph) + i_n * cos(2 * theta + ref - ph);
        const double ib = i_p * sin(ph) + i_n * sin(2 * theta + ref - ph);
        err = ls_demod_step(d, (LS_REAL)ia, (LS_REAL)ib, (LS_REAL)theta_est, (LS_REAL)cos(ph), (LS_REAL)sin(ph),
                            LS_R(0.0));
    }
    return (double)err;
}

int main(void)
{
    static const float psi_tab[4] = {0.1f, 0.1f, 0.1f, 0.1f}; /* rad, a constant table */
    ls_lut_cfg lc = {psi_tab, 4u};
    ls_lut lut;
    ls_demod_cfg cfg;
    ls_demod d;
    double worst = 0.0, theta, e;
    cfg.method = LS_DEMOD_ROTATING;
    cfg.f_lpf = LS_R(300.0);
    cfg.fs = LS_R(16000.0);
    cfg.gain = LS_R(1.0);
    cfg.comp = NULL;
    cfg.gain_table = NULL;
    cfg.comp_r = NULL; /* (left unset, init read stack garbage: a CMake build's layout trapped it) */
    cfg.gain_r = NULL;
    cfg.min_level = LS_R(1e-4);
    cfg.f_notch = LS_R(2000.0);
    cfg.ref_phase = LS_R(1.3);
    LS_CHECK(ls_demod_init(&d, &cfg) == LS_OK);
    for (theta = -3.0; theta < 3.2; theta += 0.7) {
        for (e = -0.6; e <= 0.61; e += 0.3) {
            const double err = run(&d, theta, theta - e, 0.06, 1.3, 0.5);
            const double dev = fabs(err - 0.5 * sin(2 * e));
            worst = dev > worst ? dev : worst;
        }
    }
    printf("  rotating demodulator: ratio against sin(2 delta)/2: worst %.2e\n", worst);
    LS_CHECK(worst < 2e-3);
    LS_CHECK(d.valid && fabs((double)d.level - 0.06 * 0.06) < 1e-5);
    /* with the table: delta = theta - theta_est - Psi */
    LS_CHECK(ls_lut_init(&lut, &lc) == LS_OK);
    cfg.comp = &lut;
    LS_CHECK(ls_demod_init(&d, &cfg) == LS_OK);
    LS_CHECK_NEAR(run(&d, 0.4, 0.4, 0.06, 1.3, 0.5), 0.5 * sin(-0.2), 2e-3);
    LS_CHECK_NEAR(run(&d, 0.4, 0.3, 0.06, 1.3, 0.5), 0.0, 2e-3);
    /* too weak a negative sequence: held at 0, not valid */
    LS_CHECK(run(&d, 0.4, 0.0, 0.005, 1.3, 0.5) == 0.0 && !d.valid);
    /* refusals */
    cfg.ref_phase = (LS_REAL)NAN;
    LS_CHECK(ls_demod_init(&d, &cfg) == LS_ERR_PARAM);
    cfg.ref_phase = LS_R(100.0);
    LS_CHECK(ls_demod_init(&d, &cfg) == LS_ERR_PARAM);
    cfg.ref_phase = LS_R(0.0);
    cfg.method = (ls_demod_method)9;
    LS_CHECK(ls_demod_init(&d, &cfg) == LS_ERR_PARAM);
    return ls_test_report("test_demod");
}
