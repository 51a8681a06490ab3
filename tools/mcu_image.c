/* The smallest firmware that uses the whole drive API, for tools/check_mcu.sh's code size: what a
 * firmware engineer ships is the library as linked into an image (-ffunction-sections
 * -fdata-sections -Wl,--gc-sections), not the sum of its objects (which also holds functions the
 * drive never calls). The ADC, PWM and host commands are volatile registers; the tables are the
 * application's (here empty, filled by a calibration or a generated header). */
#include "linsense/ls_drive.h"

volatile LS_REAL adc_i[3], adc_v_dc;       /* A, V: the converter's results */
volatile int32_t enc_count_reg;            /* -, the encoder's counter */
volatile uint32_t host_mode, host_cmd;     /* the host's commands */
volatile LS_REAL host_target, host_load;   /* m, N */
volatile LS_REAL pwm_duty[3];              /* -, the timer's compare registers */
volatile uint32_t fault_reg;

static float comp_tab[360], gain_tab[64], cal_tab[56];
static ls_lut comp, gain;
static ls_drive drive;

int main(void)
{
    const ls_lut_cfg cc = {comp_tab, 360u}, gc = {gain_tab, 64u};
    ls_drive_cfg cfg;
    ls_pos p = {0, LS_R(0.0)};
    ls_drive_default_cfg(&cfg);
    if (ls_lut_init(&comp, &cc) != LS_OK || ls_lut_init(&gain, &gc) != LS_OK) {
        return 1;
    }
    cfg.demod.comp = &comp;
    cfg.demod.gain_table = &gain;
    cfg.cal.table = cal_tab;
    if (ls_drive_init(&drive, &cfg) != LS_OK) {
        return 1;
    }
    ls_drive_reset(&drive, p);
    for (;;) { /* the PWM interrupt, polled */
        ls_meas m;
        ls_cmd c;
        switch (host_cmd) {
        case 1u:
            (void)ls_drive_set_mode(&drive, (ls_mode)host_mode);
            break;
        case 2u:
            p.theta = host_target;
            (void)ls_drive_move_to(&drive, p);
            break;
        case 3u:
            p.theta = host_target;
            (void)ls_drive_step_to(&drive, p);
            break;
        case 4u:
            p.theta = host_target;
            (void)ls_drive_set_position(&drive, p);
            break;
        case 5u:
            (void)ls_drive_set_load(&drive, host_load);
            break;
        default:
            break;
        }
        m.i_abc[0] = adc_i[0];
        m.i_abc[1] = adc_i[1];
        m.i_abc[2] = adc_i[2];
        m.v_dc = adc_v_dc;
        m.enc_valid = true;
        m.enc_count = enc_count_reg;
        ls_drive_step(&drive, &m, &c);
        pwm_duty[0] = c.duty[0];
        pwm_duty[1] = c.duty[1];
        pwm_duty[2] = c.duty[2];
        fault_reg = c.fault;
    }
}
