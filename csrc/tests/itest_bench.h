/* Shared by the simulator's internal tests (itest_*.c, linked with the simulator's parts, whose
 * internal functions ls_sim_internal.h declares): one PWM period of the inverter models with
 * prescribed duties, on a held mover with constant L (no saliency) and no PM flux, so that the
 * expected values stay simple. */
#ifndef LINSENSE_ITEST_BENCH_H
#define LINSENSE_ITEST_BENCH_H

#include <string.h>

#include "ls_sim_internal.h"
#include "ls_test.h"

#define L_PH 4e-3 /* H, phase inductance */
#define R_PH 9.0  /* ohm */

typedef struct {
    ls_sim_cfg c;
    ls_sim_coef q;
    ls_sim_maps pm;
    ls_sim_frozen fz;
    double h;
} bench;

/* the plant above with the given dead time (s) */
static void bench_init(bench *b, double dead_time)
{
    ls_sim_cfg *c = &b->c;
    memset(c, 0, sizeof *c);
    c->n_order = 1;
    c->lab_cos[0][0] = L_PH; /* L_aa */
    c->lab_cos[1][0] = L_PH; /* L_bb */
    c->r_s = R_PH; c->pole_pitch = 0.056; c->psi_pm = 0.0; c->mass = 1.5;
    c->x_min = -0.5; c->x_max = 0.5; c->fidelity = LS_SIM_SWITCHING; c->v_dc = 72.0; c->f_pwm = 16000.0;
    c->dead_time = dead_time; c->i_gain[0] = c->i_gain[1] = c->i_gain[2] = 1.0; c->enc_counts = 56000;
    c->motion = LS_SIM_HELD; c->decimate = 1; c->i_abort = 20.0;
    LS_CHECK(ls_sim_check(c) == LS_OK);
    ls_sim_coef_init(c, &b->q);
    ls_sim_maps_at(c, &b->q, 0.0, &b->pm);
    LS_CHECK(ls_sim_freeze(c, &b->pm, 0.0, &b->fz));
    b->h = 1.0 / c->f_pwm;
}

/* one switching period from i0 (alpha-beta) with the given duties and carry */
static void sw(const bench *b, const double duty[3], const double i0[2], double i1[2], ls_sim_carry *carry)
{
    double f_int;
    i1[0] = i0[0];
    i1[1] = i0[1];
    ls_sim_period_switching(&b->c, &b->q, &b->fz, &b->pm, duty, b->h, i1, &f_int, carry);
}

/* the same with the average model */
static void av(const bench *b, const double duty[3], const double i0[2], double i1[2], ls_sim_carry *carry)
{
    i1[0] = i0[0];
    i1[1] = i0[1];
    ls_sim_period_average(&b->c, &b->q, &b->fz, duty, b->h, i1, carry);
}

#endif /* LINSENSE_ITEST_BENCH_H */
