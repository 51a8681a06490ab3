/* Controllers: PI anti-windup (leaves saturation at once when the error reverses, where a plain
 * PI would stay wound up), limits, current controller (steady state, decoupling, voltage
 * circle), position controller structures. */
#include <math.h>

#include "linsense/ls_current.h"
#include "linsense/ls_pi.h"
#include "linsense/ls_posctrl.h"
#include "ls_test.h"

static void test_pi_antiwindup(void)
{
    ls_pi_cfg cfg = {LS_R(2.0), LS_R(100.0), LS_R(-1.0), LS_R(1.0), LS_R(1000.0)};
    ls_pi pi;
    int k;
    LS_REAL u = LS_R(0.0);
    double plain_integ = 0.0; /* what a PI without anti-windup would hold */
    LS_CHECK(ls_pi_init(&pi, &cfg) == LS_OK);
    /* large positive error for 1 s: output saturates at +1 */
    for (k = 0; k < 1000; ++k) {
        u = ls_pi_step(&pi, LS_R(5.0), LS_R(0.0));
        plain_integ += 100.0 * 5.0 / 1000.0;
    }
    LS_CHECK(u == LS_R(1.0));
    LS_CHECK(pi.saturated);
    LS_CHECK(pi.integ <= LS_R(1.0) + LS_R(1e-6)); /* integrator held at the limit ... */
    LS_CHECK(plain_integ > 400.0);                /* ... where a plain PI would be at 500 */
    /* the error reverses: the output leaves the limit at the first step, continuously (no jump
     * to the opposite limit) */
    {
        double integ_prev = (double)pi.integ;
        u = ls_pi_step(&pi, LS_R(-0.1), LS_R(0.0));
        LS_CHECK(u < LS_R(1.0) && u > LS_R(-1.0));
        LS_CHECK_NEAR(u, 2.0 * -0.1 + integ_prev + 100.0 * -0.1 / 1000.0, 1e-5);
    }
    /* a plain PI would need plain_integ / (ki * 0.1) seconds to unwind: > 40 s */
    LS_CHECK(plain_integ / (100.0 * 0.1) > 40.0);
    /* small errors: linear PI behaviour (integral of a constant) */
    ls_pi_reset(&pi);
    for (k = 0; k < 100; ++k) {
        u = ls_pi_step(&pi, LS_R(0.01), LS_R(0.05));
    }
    LS_CHECK_NEAR(u, 2.0 * 0.01 + 100.0 * 0.01 * 0.1 + 0.05, 1e-5);
    LS_CHECK(!pi.saturated);
    /* NaN input is ignored, never propagated */
    u = ls_pi_step(&pi, (LS_REAL)NAN, LS_R(0.0));
    LS_CHECK(LS_ISFINITE(u));
    /* refusals */
    cfg.kp = LS_R(0.0);
    LS_CHECK(ls_pi_init(&pi, &cfg) == LS_ERR_PARAM);
    cfg.kp = LS_R(1.0); cfg.out_min = LS_R(2.0);
    LS_CHECK(ls_pi_init(&pi, &cfg) == LS_ERR_PARAM);
    cfg.out_min = LS_R(-1.0); cfg.ki = LS_R(-1.0);
    LS_CHECK(ls_pi_init(&pi, &cfg) == LS_ERR_PARAM);
}

/* first-order R-L plant per axis, no coupling: the PI must remove the error */
static void test_current(void)
{
    ls_current_cfg cfg;
    ls_current c;
    const double R = 9.0, L = 4e-3, ts = 1.0 / 16000.0;
    double i_d = 0, i_q = 0;
    LS_REAL v_d, v_q;
    int k;
    cfg.kp = LS_R(6.0); cfg.ki = LS_R(14000.0); cfg.l_d = LS_R(4e-3); cfg.l_q = LS_R(4e-3);
    cfg.psi_pm = LS_R(0.1); cfg.decouple = false; cfg.fs = LS_R(16000.0);
    LS_CHECK(ls_current_init(&c, &cfg) == LS_OK);
    for (k = 0; k < 1600; ++k) {
        ls_current_step(&c, (LS_REAL)i_d, (LS_REAL)i_q, LS_R(0.5), LS_R(1.0), LS_R(0.0), LS_R(40.0), &v_d, &v_q);
        i_d += ts * ((double)v_d - R * i_d) / L;
        i_q += ts * ((double)v_q - R * i_q) / L;
    }
    LS_CHECK_NEAR(i_d, 0.5, 1e-3);
    LS_CHECK_NEAR(i_q, 1.0, 1e-3);
    LS_CHECK_NEAR(v_q, 9.0, 0.05);
    /* decoupling adds omega (L_d i_d + psi_pm) on q and -omega L_q i_q on d */
    cfg.decouple = true; cfg.ki = LS_R(0.0);
    LS_CHECK(ls_current_init(&c, &cfg) == LS_OK);
    ls_current_step(&c, LS_R(0.5), LS_R(1.0), LS_R(0.5), LS_R(1.0), LS_R(100.0), LS_R(40.0), &v_d, &v_q);
    LS_CHECK_NEAR(v_d, -100.0 * 4e-3 * 1.0, 1e-5);
    LS_CHECK_NEAR(v_q, 100.0 * (4e-3 * 0.5 + 0.1), 1e-5);
    /* voltage circle: a huge error is limited to |v| = v_max, direction kept */
    ls_current_reset(&c);
    ls_current_step(&c, LS_R(0.0), LS_R(0.0), LS_R(30.0), LS_R(40.0), LS_R(0.0), LS_R(20.0), &v_d, &v_q);
    LS_CHECK_NEAR(sqrt((double)(v_d * v_d + v_q * v_q)), 20.0, 1e-4);
    LS_CHECK_NEAR(v_q / v_d, 40.0 / 30.0, 1e-4);
    LS_CHECK(c.saturated);
    /* non-finite input gives zero voltage */
    ls_current_step(&c, (LS_REAL)NAN, LS_R(0.0), LS_R(1.0), LS_R(1.0), LS_R(0.0), LS_R(20.0), &v_d, &v_q);
    LS_CHECK(v_d == 0 && v_q == 0);
}

static void test_posctrl(void)
{
    ls_posctrl_cfg cfg;
    ls_posctrl p;
    LS_REAL f;
    cfg.type = LS_POSCTRL_PD; cfg.kp_x = LS_R(1000.0); cfg.kd_x = LS_R(50.0); cfg.v_max = LS_R(1.0);
    cfg.mass = LS_R(1.5); cfg.force_max = LS_R(40.0);
    cfg.speed.kp = LS_R(100.0); cfg.speed.ki = LS_R(1000.0); cfg.speed.out_min = LS_R(-1.0);
    cfg.speed.out_max = LS_R(1.0); cfg.speed.fs = LS_R(16000.0);
    cfg.fric_c = LS_R(0.0); cfg.fric_v = LS_R(0.0); cfg.fric_band = LS_R(0.0);
    LS_CHECK(ls_posctrl_init(&p, &cfg) == LS_OK);
    f = ls_posctrl_step(&p, LS_R(0.01), LS_R(0.1), LS_R(0.2), LS_R(2.0));
    LS_CHECK_NEAR(f, 1000.0 * 0.01 + 50.0 * 0.1 + 1.5 * 2.0, 1e-4);
    f = ls_posctrl_step(&p, LS_R(1.0), LS_R(0.0), LS_R(0.0), LS_R(0.0));
    LS_CHECK_NEAR(f, 40.0, 1e-6);
    cfg.type = LS_POSCTRL_P; cfg.kp_x = LS_R(20.0);
    LS_CHECK(ls_posctrl_init(&p, &cfg) == LS_OK);
    f = ls_posctrl_step(&p, LS_R(0.001), LS_R(0.0), LS_R(0.05), LS_R(1.0));
    LS_CHECK_NEAR(p.v_ref, 20.0 * 0.001 + 0.05, 1e-6);
    LS_CHECK_NEAR(f, 100.0 * (20.0 * 0.001 + 0.05) + 1000.0 * 0.07 / 16000.0 + 1.5, 1e-3);
    f = ls_posctrl_step(&p, LS_R(1.0), LS_R(0.0), LS_R(0.0), LS_R(0.0));
    LS_CHECK_NEAR(p.v_ref, 1.0, 1e-6); /* speed reference limited to v_max */
    LS_CHECK_NEAR(f, 40.0, 1e-6);      /* force limited to force_max */
    /* friction fed forward at the speed reference: Coulomb linear below the band, plus viscous */
    cfg.force_max = LS_R(40.0); cfg.fric_c = LS_R(1.5); cfg.fric_v = LS_R(4.0); cfg.fric_band = LS_R(0.002);
    LS_CHECK(ls_posctrl_init(&p, &cfg) == LS_OK);
    f = ls_posctrl_step(&p, LS_R(0.0), LS_R(0.0), LS_R(0.001), LS_R(0.0));
    LS_CHECK_NEAR(f, 100.0 * 0.001 + 1000.0 * 0.001 / 16000.0 + 1.5 * 0.5 + 4.0 * 0.001, 1e-4);
    ls_posctrl_reset(&p);
    f = ls_posctrl_step(&p, LS_R(0.0), LS_R(0.1), LS_R(0.1), LS_R(0.0));
    LS_CHECK_NEAR(f, 1.5 + 4.0 * 0.1, 1e-4); /* saturated Coulomb beyond the band */
    cfg.fric_band = LS_R(0.0);
    LS_CHECK(ls_posctrl_init(&p, &cfg) == LS_ERR_PARAM); /* Coulomb friction needs a band */
    cfg.fric_band = LS_R(0.002); cfg.fric_v = LS_R(-1.0);
    LS_CHECK(ls_posctrl_init(&p, &cfg) == LS_ERR_PARAM);
    cfg.fric_v = LS_R(0.0); cfg.force_max = LS_R(0.0);
    LS_CHECK(ls_posctrl_init(&p, &cfg) == LS_ERR_PARAM);
}

int main(void)
{
    test_pi_antiwindup();
    test_current();
    test_posctrl();
    return ls_test_report("test_ctrl");
}
