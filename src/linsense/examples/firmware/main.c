/* linsense firmware example: how an MCU project uses the controller library.
 *
 * Build and run (docs/firmware.md, "The exported project"):
 *   linsense firmware export fw --motor ecce2010
 *   cmake -S fw -B fw/build && cmake --build fw/build && fw/build/firmware_example
 * The export writes this file beside the library's sources and headers, the drive's configuration
 * designed for the motor (ls_cfg_<motor>.h: the gains, the compensation table and the
 * demodulator's gain table, what `linsense tune --format c` writes) and ls_example.h, which names
 * that configuration for this file and describes the synthetic motor below; the library holds no
 * motor's numbers. `make example` (from the repository root) does the same for ecce2010.
 *
 * Hardware access is replaced by two stubs: adc_read() returns phase currents from a small
 * synthetic motor model (the motor's armature held at a fixed position, the HF response only: its
 * alpha-beta inductance there and its resistance) and pwm_write() discards the duty cycles after
 * feeding the voltages back to that model. The drive starts sensorless 10 electrical degrees away
 * from the true position and must converge to it; the program prints the estimate and exits
 * non-zero if it does not.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "linsense/ls_drive.h"
#include "ls_example.h" /* generated: includes ls_cfg_<motor>.h and names it EX_CFG, EX_COMP, ...;
                           the synthetic motor EX_L_*, EX_R_S, EX_V_DC, EX_F_PWM, EX_THETA_DEG */

/* ---- application state: statically allocated, as on an MCU (the library has no globals) ---- */
static ls_lut comp_lut, gain_lut, comp_r_lut, gain_r_lut;
static ls_drive drive;
static ls_cmd cmd;

/* ---- stand-ins for the hardware ------------------------------------------------------------ */
static double motor_i[2]; /* A, alpha-beta current of the synthetic motor */

/* alpha-beta inductance of the motor at the true position (ls_example.h: its HF model's L_ab at
 * EX_THETA_DEG, the armature held there) */
static void motor_inductance(double L[2][2])
{
    L[0][0] = EX_L_AA;
    L[1][1] = EX_L_BB;
    L[0][1] = L[1][0] = EX_L_AB;
}

static void adc_read(ls_meas *m)
{
    m->i_abc[0] = (LS_REAL)motor_i[0];
    m->i_abc[1] = (LS_REAL)(-0.5 * motor_i[0] + 0.8660254037844386 * motor_i[1]);
    m->i_abc[2] = (LS_REAL)(-0.5 * motor_i[0] - 0.8660254037844386 * motor_i[1]);
    m->v_dc = (LS_REAL)EX_V_DC;
    m->enc_valid = false; /* sensorless: no encoder */
    m->enc_count = 0;
}

/* the synthetic motor over one PWM period, v = R i + L di/dt, with the duty cycles written in the
 * previous period (a PWM unit's shadow registers load them at the period's start: the one period of
 * computation delay the drive expects, ls_drive_cfg.delay_comp); then the new ones are latched */
static double duty_next[3] = {0.5, 0.5, 0.5};
static void pwm_write(const ls_cmd *c)
{
    const double vdc = EX_V_DC, R = EX_R_S, h = 1.0 / EX_F_PWM / 8;
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
    ls_lut_cfg lut_cfg = {EX_COMP, EX_LEN};
    ls_lut_cfg gain_cfg = {EX_GAIN, EX_LEN};
    ls_lut_cfg comp_r_cfg = {EX_COMP_R, EX_LEN};
    ls_lut_cfg gain_r_cfg = {EX_GAIN_R, EX_LEN};
    ls_drive_cfg cfg;
    ls_status st;
    ls_pos start;
    long k;
    const long steps = EX_STEPS; /* 0.25 s of PWM periods */
    double est_deg = 0.0;

    if (ls_lut_init(&comp_lut, &lut_cfg) != LS_OK || ls_lut_init(&gain_lut, &gain_cfg) != LS_OK ||
        ls_lut_init(&comp_r_lut, &comp_r_cfg) != LS_OK || ls_lut_init(&gain_r_lut, &gain_r_cfg) != LS_OK) {
        return 2;
    }
    EX_CFG(&cfg, &comp_lut, &gain_lut, &comp_r_lut, &gain_r_lut); /* the design and its tables */
    cfg.mod.dtc = false;          /* the synthetic motor has an ideal inverter: nothing to */
    cfg.mod.dead_time = 0.0f;     /* compensate, and no dead-time residual to take out */
    cfg.obs.type = LS_OBS_PLL;    /* the armature is held: the tracking loop alone (the designed */
    cfg.load_ff = false;          /* mechanical observer's model expects the force to move it) */
    st = ls_drive_init(&drive, &cfg);
    if (st != LS_OK) {
        fprintf(stderr, "configuration refused (%s)\n",
                st == LS_ERR_VERSION ? "LS_ERR_VERSION: ls_cfg header of another linsense version" : "LS_ERR_PARAM");
        return 2;
    }
    start.period = 0;
    start.theta = (LS_REAL)((EX_THETA_DEG - 10.0) * deg); /* a 10 deg initial error */
    ls_drive_set_position(&drive, start);
    if (ls_drive_set_mode(&drive, LS_MODE_SENSORLESS_LUT) != LS_OK) {
        return 2;
    }
    memset(&cmd, 0, sizeof cmd);
    for (k = 0; k < steps; ++k) {
        pwm_isr();
        if (cmd.fault != LS_FAULT_NONE) {
            fprintf(stderr, "fault 0x%02x at step %ld\n", (unsigned)cmd.fault, k);
            return 1;
        }
        if (k % 500 == 0 || k == steps - 1) {
            est_deg = (double)cmd.pos_est.theta / deg;
            printf("step %4ld  t = %6.4f s  estimate %7.3f deg  (true %.1f)  error signal %+.4f rad  HF %.3f A rms  k_r %.3f\n",
                   k, (double)k / EX_F_PWM, est_deg, EX_THETA_DEG, (double)cmd.err_sig, sqrt((double)cmd.hf_level), (double)drive.dtres.k_r);
        }
    }
    printf("%s: converged to %.3f deg, %.3f deg from the true position\n", EX_MOTOR, est_deg, est_deg - EX_THETA_DEG);
    return fabs(est_deg - EX_THETA_DEG) < 0.5 ? 0 : 1;
}
