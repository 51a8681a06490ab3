/* Benchmark driver: ls_drive_step in sensorless mode with the LUT, float build, closed around
 * the compact test plant, during a minimum-time move (every block active). Run it under
 *   valgrind --tool=callgrind --toggle-collect=ls_drive_step ./bench_drive N [dtc [startup]]
 * so that only the instructions executed inside ls_drive_step are counted (tools/bench.sh).
 * startup = 1: LS_MODE_STARTUP instead, from an unknown position on a saturating plant (N steps of
 * it: 2800 steps are the whole start-up, beyond it the drive holds in sensorless LUT mode). */
#include <stdio.h>
#include <stdlib.h>

#include "linsense/ls_drive.h"
#include "ls_lut_ecce2010_q.h" /* the table of the default (elliptical) injection */
#include "ls_test_plant.h"

int main(int argc, char **argv)
{
    long n = argc > 1 ? atol(argv[1]) : 20000;
    long k;
    ls_lut_cfg lc = {ls_lut_ecce2010_q, LS_LUT_ECCE2010_Q_LEN};
    ls_lut lut;
    ls_drive_cfg cfg;
    ls_drive d;
    tp_plant p;
    ls_cmd c;
    ls_meas m;
    if (ls_lut_init(&lut, &lc) != LS_OK) {
        return 2;
    }
    ls_drive_default_cfg(&cfg);
    cfg.demod.comp = &lut;
    cfg.mod.dtc = argc > 2 && atoi(argv[2]) != 0; /* the plant has no dead time: off unless asked */
    if (ls_drive_init(&d, &cfg) != LS_OK) {
        return 2;
    }
    tp_init(&p, 0.0);
    ls_drive_set_position(&d, tp_pos_of_m(0.0, p.tau));
    if (ls_drive_set_mode(&d, LS_MODE_SENSORLESS_LUT) != LS_OK) {
        return 2;
    }
    ls_drive_move_to(&d, tp_pos_of_m(0.020, p.tau));
    if (argc > 3 && atoi(argv[3]) != 0) { /* LS_MODE_STARTUP from an unknown position, saturating plant */
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
