/* The simulator's inverter models one period at a time, with prescribed duties and currents:
 * internal functions (csrc/sim/ls_sim_internal.h; the Makefile links this test with the controller
 * library and the simulator's parts). A held mover, constant L (no saliency) and no PM flux keep the
 * expected values simple:
 *   - a pulse shorter than the dead time never reaches the pole when the current flows out;
 *   - with the current flowing in, it is lengthened by the dead time;
 *   - a turn-off delayed past the period end (duty within the dead time of 1, current flowing in)
 *     keeps the pole high into the next period, in the switching model (carried edge) and the
 *     average model (carried excess duty) alike. */
#include <math.h>
#include <stdio.h>

#include "itest_bench.h"

/* alpha current change at the period end from pole a held high for s more seconds around t_c:
 * (2/3) V_dc s / L, decayed with L/R over the rest of the period */
static double da_of(const bench *b, double s, double t_c)
{
    return (2.0 / 3.0) * b->c.v_dc * s / L_PH * exp(-b->c.r_s * (b->h - t_c) / L_PH);
}

static void tiny_pulse(void)
{
    bench b;
    const double dd = 0.8e-6 * 16000.0, i_out[2] = {1.0, 0.0}, i_in[2] = {-1.0, 0.0};
    const double tiny[3] = {0.3 * dd, 0.5, 0.5}, none[3] = {0.0, 0.5, 0.5};
    double a[2], z[2];
    ls_sim_carry c1 = ls_sim_no_carry, c2 = ls_sim_no_carry;
    bench_init(&b, 0.8e-6);
    /* current out of phase a: the turn-on waits for the dead time, the turn-off command comes
     * first and cancels it: no pulse at all */
    sw(&b, tiny, i_out, a, &c1);
    sw(&b, none, i_out, z, &c2);
    /* (not bit-equal: the command instants split the propagation into more segments, which
     * changes the 4th-order truncation, ~1e-7 of the current) */
    LS_CHECK_NEAR(a[0], z[0], 1e-6);
    LS_CHECK_NEAR(a[1], z[1], 1e-6);
    LS_CHECK(c1.t[0] < 0.0 && c1.t[1] < 0.0 && c1.t[2] < 0.0);
    /* current into phase a: the upper diode conducts in the dead time, the pulse is lengthened by
     * it, 0.3 dd T + dd T of pole a high */
    c1 = ls_sim_no_carry;
    c2 = ls_sim_no_carry;
    sw(&b, tiny, i_in, a, &c1);
    sw(&b, none, i_in, z, &c2);
    LS_CHECK_NEAR(a[0] - z[0], da_of(&b, 1.3 * dd * b.h, 0.5 * b.h), 0.02 * da_of(&b, 1.3 * dd * b.h, 0.5 * b.h));
    /* the average model agrees on both */
    c1 = ls_sim_no_carry;
    c2 = ls_sim_no_carry;
    av(&b, tiny, i_out, a, &c1);
    av(&b, none, i_out, z, &c2);
    LS_CHECK_NEAR(a[0], z[0], 1e-12);
    av(&b, tiny, i_in, a, &c1);
    av(&b, none, i_in, z, &c2);
    LS_CHECK_NEAR(a[0] - z[0], da_of(&b, 1.3 * dd * b.h, 0.5 * b.h), 0.02 * da_of(&b, 1.3 * dd * b.h, 0.5 * b.h));
}

static void spill(void)
{
    bench b;
    const double dd = 0.8e-6 * 16000.0, d = 0.995, i_in[2] = {-1.0, 0.0};
    const double high[3] = {d, 0.5, 0.5}, mid[3] = {0.5, 0.5, 0.5};
    const double t_spill = 0.5 * (1.0 + d) / 16000.0 + 0.8e-6 - 1.0 / 16000.0; /* s */
    double i1[2], with[2], without[2], sw_eff, av_eff;
    ls_sim_carry c = ls_sim_no_carry, none = ls_sim_no_carry;
    bench_init(&b, 0.8e-6);
    LS_CHECK(t_spill > 0.0);
    /* switching: the delayed turn-off lies past the period end and is carried */
    sw(&b, high, i_in, i1, &c);
    LS_CHECK_NEAR(c.t[0], t_spill, 1e-15);
    LS_CHECK(c.on[0] == 0 && c.t[1] < 0.0 && c.t[2] < 0.0);
    LS_CHECK(i1[0] < 0.0); /* the current still flowed in at the turn-off */
    sw(&b, mid, i1, with, &c);
    sw(&b, mid, i1, without, &none);
    LS_CHECK(c.t[0] < 0.0); /* used up */
    sw_eff = with[0] - without[0];
    LS_CHECK_NEAR(sw_eff, da_of(&b, t_spill, 0.5 * t_spill), 0.02 * da_of(&b, t_spill, 0.5 * t_spill));
    /* nothing is carried into a period at duty 1: the pole is high anyway */
    c = ls_sim_no_carry;
    sw(&b, high, i_in, i1, &c);
    {
        const double full[3] = {1.0, 0.5, 0.5};
        double f1[2], f2[2];
        ls_sim_carry n2 = ls_sim_no_carry;
        sw(&b, full, i1, f1, &c);
        sw(&b, full, i1, f2, &n2);
        LS_CHECK_NEAR(f1[0], f2[0], 1e-12);
    }
    /* average: the duty beyond 1 is carried as an excess. Its first period takes d + dd of pole
     * a up to 1 (the switching model's first period has it low for (1 - d) h/2 at the start),
     * so compare the two models over both periods: with the carry they agree to the current
     * ripple; without it each loses what crossed the period end, the switching model more */
    c = ls_sim_no_carry;
    none = ls_sim_no_carry;
    av(&b, high, i_in, i1, &c);
    LS_CHECK_NEAR(c.excess[0], d + dd - 1.0, 1e-12);
    av(&b, mid, i1, with, &c);
    LS_CHECK(c.excess[0] == 0.0);
    {
        double s1[2], s2[2], a1[2], a2[2];
        ls_sim_carry cs = ls_sim_no_carry, ca = ls_sim_no_carry;
        sw(&b, high, i_in, s1, &cs);
        sw(&b, mid, s1, s2, &cs);
        av(&b, high, i_in, a1, &ca);
        av(&b, mid, a1, a2, &ca);
        av_eff = s2[0] - a2[0];
        printf("  spill past the period end: %.3g us carried, adds %.4g A to i_alpha; switching - average "
               "after two periods: %.3g A with the carry\n", t_spill * 1e6, sw_eff, av_eff);
        LS_CHECK(fabs(av_eff) < 0.1 * sw_eff);
    }
}

int main(void)
{
    tiny_pulse();
    spill();
    return ls_test_report("itest_inverter");
}
