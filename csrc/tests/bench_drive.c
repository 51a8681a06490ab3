/* Benchmark driver: ls_drive_step in sensorless mode with the LUT, float build, closed around
 * the compact test plant, during a minimum-time move (every block active). Run it under
 *   valgrind --tool=callgrind --toggle-collect=ls_drive_step ./bench_drive N [DTC [SHAPE [G [R]]]]
 * SHAPE: 0 pulsating (elliptical, the default), 1 rotating, 2 square wave at fs/2, each with its
 * table; 3 LS_MODE_STARTUP from an unknown position on a saturating plant (the default injection;
 * 2800 steps are the whole start-up, beyond it the drive holds in sensorless LUT mode).
 * 4 LS_MODE_SENSORED with the HF estimate beside the encoder (inject_sensored), 5
 * LS_MODE_CALIBRATION (12 points of period 1, the default injection), 6 LS_MODE_SENSORED with the
 * square wave beside the encoder (4 and 6: ls_drive_sensored.c, 5: ls_drive_calibration.c), 7
 * LS_MODE_COMMISSION (the default injection, emf_on, a 0.4 m move at 1 m/s: the learning runs at
 * its cruise; ls_drive_commission.c).
 * G = 1: with a gain table (rotating, square); R = 1: without the dead-time residual model, 2: with
 * its interpolating model (dtres.forward false) instead of the forward one.
 * so that only the instructions executed inside ls_drive_step are counted (tools/bench.sh). */
#include <stdio.h>
#include <stdlib.h>

#include "linsense/ls_drive.h"
#include "ls_lut_ecce2010_q.h"   /* the table of the default (elliptical) injection */
#include "ls_lut_ecce2010_rot.h" /* of the rotating injection */
#include "ls_lut_ecce2010_sq.h"  /* of the square wave at fs/2 */
#include "ls_test_plant.h"

int main(int argc, char **argv)
{
    long n = argc > 1 ? atol(argv[1]) : 20000;
    long k;
    ls_lut_cfg lc = {ls_lut_ecce2010_q, LS_LUT_ECCE2010_Q_LEN};
    ls_lut_cfg lc_rot = {ls_lut_ecce2010_rot, LS_LUT_ECCE2010_ROT_LEN};
    ls_lut_cfg lc_sq = {ls_lut_ecce2010_sq, LS_LUT_ECCE2010_SQ_LEN};
    ls_lut lut, lut_g, lut_r;
    static float gain_tab[64], slope_tab[64]; /* (the slopes 0: read every step, no effect) */
    ls_lut_cfg gc = {gain_tab, 64u}, rc = {slope_tab, 64u};
    int shape, j;
    ls_drive_cfg cfg;
    ls_drive d;
    tp_plant p;
    ls_cmd c;
    ls_meas m;
    shape = argc > 3 ? atoi(argv[3]) : 0;
    for (j = 0; j < 64; ++j) {
        gain_tab[j] = 1.0f;
    }
    if (ls_lut_init(&lut, shape == 1 ? &lc_rot : (shape == 2 || shape == 6) ? &lc_sq : &lc) != LS_OK ||
        ls_lut_init(&lut_g, &gc) != LS_OK || ls_lut_init(&lut_r, &rc) != LS_OK) {
        return 2;
    }
    ls_drive_default_cfg(&cfg);
    cfg.demod.comp = &lut;
    /* the tables' slopes in the resistance's scale, which the design writes (read every step) */
    cfg.demod.comp_r = &lut_r;
    cfg.demod.gain_r = &lut_r;
    cfg.mod.dtc = argc > 2 && atoi(argv[2]) != 0; /* the plant has no dead time: off unless asked */
    cfg.hf_dtres = !(argc > 5 && atoi(argv[5]) == 1); /* the dead-time residual model (on unless asked) */
    cfg.dtres.forward = !(argc > 5 && atoi(argv[5]) == 2);
    if (shape == 1) { /* rotating: stationary-frame vector, negative-sequence demodulation */
        cfg.inject.shape = LS_INJ_ROTATING;
        cfg.inject.quad = 0.0f;
        cfg.demod.method = LS_DEMOD_ROTATING;
        cfg.demod.gain = 1.0f;
        cfg.demod.min_level = 3.8e-4f; /* linsense.tune.injection.rotating_design for ecce2010, */
        cfg.demod.ref_phase = 1.4613f; /* 12 V at 1 kHz, 16 kHz, delay_comp 1.5 */
        cfg.demod.gain_table = argc > 4 && atoi(argv[4]) != 0 ? &lut_g : NULL;
    } else if (shape == 2 || shape == 6) { /* square wave at fs/2: first difference, low-pass separation */
        cfg.inject.shape = LS_INJ_SQUARE;
        cfg.inject.quad = 0.0f;
        cfg.inject.freq = 0.5f * cfg.fs;
        cfg.bpf.type = LS_BIQUAD_DIFF;
        cfg.sep.type = LS_BIQUAD_LOWPASS;
        cfg.sep.f0 = 2000.0f;
        cfg.sep.q = 0.7071f;
        cfg.demod.f_notch = 0.0f;
        cfg.mod.dtc_lead = -0.5f;
        cfg.hf_dtres = false; /* (not with the square wave: i_d_inj instead) */
        cfg.i_d_inj = 1.0f;
        cfg.mod.l_ripple = 4.0e-3f; /* the edges' ripple in the compensation */
        cfg.mod.i_band = 0.01f;
        cfg.i_d_near = 0.124f; /* the d-current schedule near the normal positions */
        cfg.near_in = 0.0617f;
        cfg.near_out = 0.1187f;
        cfg.demod.gain_table = argc > 4 && atoi(argv[4]) != 0 ? &lut_g : NULL;
        for (j = 0; j < 64; ++j) {
            gain_tab[j] = (float)cfg.demod.gain; /* the nominal L_q / (L_q - L_d) */
        }
    }
    if (shape >= 4) { /* the encoder modes, the HF observer running beside */
        static float cal_table[12];
        cfg.inject_sensored = true;
        cfg.cal.points = 12u;
        cfg.cal.table = cal_table;
        cfg.cal.period = 1;
    }
    if (shape == 7) { /* LS_MODE_COMMISSION: its table the demodulator's, started at the model's */
        static float com_table[LS_LUT_ECCE2010_Q_LEN], com_learn[4u * LS_LUT_ECCE2010_Q_LEN];
        static ls_lut com_lut;
        ls_lut_cfg lcom = {com_table, LS_LUT_ECCE2010_Q_LEN};
        unsigned i;
        for (i = 0; i < LS_LUT_ECCE2010_Q_LEN; ++i) {
            com_table[i] = ls_lut_ecce2010_q[i];
        }
        if (ls_lut_init(&com_lut, &lcom) != LS_OK) {
            return 2;
        }
        cfg.emf_on = true;
        cfg.demod.comp = &com_lut;
        cfg.cal.points = LS_LUT_ECCE2010_Q_LEN;
        cfg.cal.table = com_table;
        cfg.cal.learn = com_learn;
        cfg.cal.k_int = LS_R(500.0);
        cfg.cal.t_hold = LS_R(0.02);
        cfg.cal.t_settle = LS_R(0.02);
        cfg.cal.slope = LS_R(0.33);
        cfg.traj.v_max = LS_R(1.0);
        cfg.traj.a_max = LS_R(10.0);
        cfg.pos.v_max = LS_R(1.2);
    }
    if (ls_drive_init(&d, &cfg) != LS_OK) {
        return 2;
    }
    tp_init(&p, 0.0);
    ls_drive_set_position(&d, tp_pos_of_m(0.0, p.tau));
    if (ls_drive_set_mode(&d, LS_MODE_SENSORLESS_LUT) != LS_OK) {
        return 2;
    }
    ls_drive_move_to(&d, tp_pos_of_m(0.020, p.tau));
    if (shape == 4 || shape == 6) {
        if (ls_drive_set_mode(&d, LS_MODE_SENSORED) != LS_OK) {
            return 2;
        }
        ls_drive_move_to(&d, tp_pos_of_m(0.020, p.tau));
    } else if (shape == 7) {
        if (ls_drive_set_mode(&d, LS_MODE_COMMISSION) != LS_OK) {
            return 2;
        }
        ls_drive_move_to(&d, tp_pos_of_m(0.400, p.tau));
    } else if (shape == 5) {
        tp_init(&p, 0.056 + 0.001);
        if (ls_drive_set_mode(&d, LS_MODE_CALIBRATION) != LS_OK) {
            return 2;
        }
    }
    if (shape == 3) { /* LS_MODE_STARTUP from an unknown position, saturating plant */
        ls_pos zero = {0, LS_R(0.0)};
        tp_init(&p, 0.0123);
        p.sat_k = 0.01;
        ls_drive_reset(&d, zero);
        if (ls_drive_set_mode(&d, LS_MODE_STARTUP) != LS_OK) {
            return 2;
        }
    }
    for (k = 0; k < n; ++k) {
        tp_measure(&p, &m);
        ls_drive_step(&d, &m, &c);
        tp_advance(&p, &c);
    }
    printf("bench_drive: %ld steps, fault %u, final position %.3f mm, estimate %.3f mm\n", n, c.fault,
           p.x * 1e3, tp_pos_m(c.pos_est, p.tau) * 1e3);
    return c.fault == 0 ? 0 : 1;
}
