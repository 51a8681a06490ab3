/* linsense firmware example: how an MCU project uses the controller library.
 *
 * Build and run:  make example   (from the repository root)
 * The build generates the drive's configuration for the motor (designed gains, the compensation
 * table and the demodulator's gain table) with
 *   linsense tune --motor ecce2010 --format c --out ls_cfg_ecce2010.h
 * and compiles this file with the sources in csrc/ctrl, exactly as a firmware project would: the
 * library holds no motor's numbers.
 *
 * Hardware access is replaced by two stubs: adc_read() returns phase currents from a small
 * synthetic motor model (an ecce2010 armature held at a fixed position, the HF response only)
 * and pwm_write() discards the duty cycles after feeding the voltages back to that model.
 * The drive starts sensorless 10 electrical degrees away from the true position and must
 * converge to it; the program prints the estimate and exits non-zero if it does not.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "linsense/ls_drive.h"
#include "ls_cfg_ecce2010.h" /* generated: the tables and ls_cfg_ecce2010(&cfg, &comp, &gain, ...) */

/* ---- application state: statically allocated, as on an MCU (the library has no globals) ---- */
static ls_lut comp_lut, gain_lut, comp_r_lut, gain_r_lut;
static ls_drive drive;
static ls_cmd cmd;

/* ---- stand-ins for the hardware ------------------------------------------------------------ */
#define TRUE_THETA_DEG 40.0
static double motor_i[2]; /* A, alpha-beta current of the synthetic motor */

/* alpha-beta inductance of ecce2010 at the true position (from `linsense model`, theta = 40 deg):
 * L_ab = R(th) [[L_d, L_dq], [L_dq, L_q]] R(th)^T with the closed forms of docs/theory.md */
static void motor_inductance(double L[2][2])
{
    const double pi = 3.14159265358979323846, th = TRUE_THETA_DEG * pi / 180.0;
    const double c2 = cos(2 * th - 2 * pi / 3), s2 = sin(2 * th - 2 * pi / 3);
    const double L0 = 2.75e-3, L2 = -0.317e-3, M0 = -0.92e-3, M2 = -0.317e-3, dM0 = -0.47e-3;
    double ld = L0 + L2 / 2 - M0 + M2 - 2.0 / 3 * dM0 * (1 + c2);
    double lq = L0 - L2 / 2 - M0 - M2 - 2.0 / 3 * dM0 * (1 - c2);
    double ldq = 2.0 / 3 * dM0 * s2;
    double c = cos(th), s = sin(th);
    L[0][0] = c * c * ld - 2 * c * s * ldq + s * s * lq;
    L[1][1] = s * s * ld + 2 * c * s * ldq + c * c * lq;
    L[0][1] = L[1][0] = c * s * (ld - lq) + (c * c - s * s) * ldq;
}

static void adc_read(ls_meas *m)
{
    m->i_abc[0] = (LS_REAL)motor_i[0];
    m->i_abc[1] = (LS_REAL)(-0.5 * motor_i[0] + 0.8660254037844386 * motor_i[1]);
    m->i_abc[2] = (LS_REAL)(-0.5 * motor_i[0] - 0.8660254037844386 * motor_i[1]);
    m->v_dc = LS_R(72.0);
    m->enc_valid = false; /* sensorless: no encoder */
    m->enc_count = 0;
}

/* the synthetic motor over one PWM period, v = R i + L di/dt, with the duty cycles written in the
 * previous period (a PWM unit's shadow registers load them at the period's start: the one period of
 * computation delay the drive expects, ls_drive_cfg.delay_comp); then the new ones are latched */
static double duty_next[3] = {0.5, 0.5, 0.5};
static void pwm_write(const ls_cmd *c)
{
    const double vdc = 72.0, R = 9.0, h = 1.0 / 16000.0 / 8;
    double L[2][2], det, v[3], va, vb;
    int k;
    motor_inductance(L);
    det = L[0][0] * L[1][1] - L[0][1] * L[1][0];
    for (k = 0; k < 3; ++k) {
        v[k] = duty_next[k] * vdc;
        duty_next[k] = c->enable ? (double)c->duty[k] : 0.5;
    }
    va = (2 * v[0] - v[1] - v[2]) / 3;
    vb = (v[1] - v[2]) / sqrt(3.0);
    for (k = 0; k < 8; ++k) {
        double ea = va - R * motor_i[0], eb = vb - R * motor_i[1];
        motor_i[0] += h * (L[1][1] * ea - L[0][1] * eb) / det;
        motor_i[1] += h * (-L[1][0] * ea + L[0][0] * eb) / det;
    }
}

/* ---- the PWM interrupt: sample, step, write (docs/firmware.md) -------------------------------- */
static void pwm_isr(void)
{
    ls_meas meas;
    adc_read(&meas);              /* currents sampled at the carrier peak */
    ls_drive_step(&drive, &meas, &cmd);
    pwm_write(&cmd);              /* duties take effect from the next period */
}

int main(void)
{
    const double deg = 3.14159265358979323846 / 180.0;
    ls_lut_cfg lut_cfg = {ls_cfg_ecce2010_comp, ECCE2010_LEN};
    ls_lut_cfg gain_cfg = {ls_cfg_ecce2010_gain, ECCE2010_LEN};
    ls_lut_cfg comp_r_cfg = {ls_cfg_ecce2010_comp_r, ECCE2010_LEN};
    ls_lut_cfg gain_r_cfg = {ls_cfg_ecce2010_gain_r, ECCE2010_LEN};
    ls_drive_cfg cfg;
    ls_pos start;
    long k;
    double est_deg = 0.0;

    if (ls_lut_init(&comp_lut, &lut_cfg) != LS_OK || ls_lut_init(&gain_lut, &gain_cfg) != LS_OK ||
        ls_lut_init(&comp_r_lut, &comp_r_cfg) != LS_OK || ls_lut_init(&gain_r_lut, &gain_r_cfg) != LS_OK) {
        return 2;
    }
    ls_cfg_ecce2010(&cfg, &comp_lut, &gain_lut, &comp_r_lut, &gain_r_lut); /* the design and its tables */
    cfg.mod.dtc = false;          /* the synthetic motor has an ideal inverter: nothing to */
    cfg.mod.dead_time = 0.0f;     /* compensate, and no dead-time residual to take out */
    cfg.obs.type = LS_OBS_PLL;    /* the armature is held: the tracking loop alone (the designed */
    cfg.load_ff = false;          /* mechanical observer's model expects the force to move it) */
    if (ls_drive_init(&drive, &cfg) != LS_OK) {
        fprintf(stderr, "configuration refused\n");
        return 2;
    }
    start.period = 0;
    start.theta = (LS_REAL)((TRUE_THETA_DEG - 10.0) * deg); /* a 10 deg initial error */
    ls_drive_set_position(&drive, start);
    if (ls_drive_set_mode(&drive, LS_MODE_SENSORLESS_LUT) != LS_OK) {
        return 2;
    }
    memset(&cmd, 0, sizeof cmd);
    for (k = 0; k < 4000; ++k) { /* 0.25 s of PWM periods */
        pwm_isr();
        if (cmd.fault != LS_FAULT_NONE) {
            fprintf(stderr, "fault 0x%02x at step %ld\n", (unsigned)cmd.fault, k);
            return 1;
        }
        if (k % 500 == 0 || k == 3999) {
            est_deg = (double)cmd.pos_est.theta / deg;
            printf("step %4ld  t = %6.4f s  estimate %7.3f deg  (true %.1f)  error signal %+.4f rad  HF %.3f A rms  k_r %.3f\n",
                   k, (double)k / 16000.0, est_deg, TRUE_THETA_DEG, (double)cmd.err_sig, sqrt((double)cmd.hf_level), (double)drive.dtres.k_r);
        }
    }
    printf("converged to %.3f deg, %.3f deg from the true position\n", est_deg, est_deg - TRUE_THETA_DEG);
    return fabs(est_deg - TRUE_THETA_DEG) < 0.5 ? 0 : 1;
}
