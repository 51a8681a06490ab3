/* linsense firmware library: position references.
 *
 * Minimum-time trapezoidal profile under |v| <= v_max, |a| <= a_max (triangular when the move is
 * shorter than v_max^2 / a_max), evaluated in closed form at t = k Ts (no accumulated error), or
 * a step: the same profile under the drive's own limits v_step, a_step (a_step 0: the reference
 * jumps, the paper's step). Positions are ls_pos, so moves start anywhere on a long axis.
 *   D >= v^2/a: T = D/v_max + v_max/a_max;  otherwise T = 2 sqrt(D/a_max).
 */
#ifndef LINSENSE_LS_TRAJ_H
#define LINSENSE_LS_TRAJ_H

#include "linsense/ls_pos.h"
#include "linsense/ls_types.h"

typedef struct {
    LS_REAL v_max;      /* m/s, > 0 */
    LS_REAL a_max;      /* m/s^2, > 0 */
    LS_REAL v_step;     /* m/s, a step's speed limit (ls_traj_jump), > 0 when a_step > 0, else >= 0 */
    LS_REAL a_step;     /* m/s^2, a step's acceleration, >= 0; 0: a step jumps the reference */
    LS_REAL a_lpf;      /* Hz, first-order low-pass of the acceleration output (the force feed-forward:
                           its steps, through the HF band-pass, disturb the demodulated error),
                           >= 0, a_lpf / fs <= 1; 0: unfiltered */
    LS_REAL pole_pitch; /* m, tau, > 0 */
    LS_REAL fs;         /* Hz, sampling rate, > 0 */
} ls_traj_cfg;

typedef struct {
    ls_traj_cfg cfg;  /* copy of the configuration */
    ls_pos start;     /* start of the present move */
    ls_pos target;    /* end of the present move */
    LS_REAL dist;     /* m, |target - start| */
    LS_REAL sign;     /* -, direction of the move, +1 or -1 */
    LS_REAL t_acc;    /* s, acceleration time */
    LS_REAL t_total;  /* s, duration of the move */
    LS_REAL v_peak;   /* m/s, peak speed of the move */
    LS_REAL acc;      /* m/s^2, acceleration of the move (a_max, or a_step for a step) */
    LS_REAL a_out;    /* m/s^2, the acceleration output (low-passed) */
    LS_REAL a_k;      /* -, the low-pass's gain per step, 2 pi a_lpf Ts (1: unfiltered) */
    uint32_t k;       /* -, steps since the start of the move (< LS_TRAJ_STEPS_MAX + 1) */
    bool active;      /* a move is in progress */
    LS_REAL ts;       /* s, sampling period */
    LS_REAL kx;       /* rad/m, 2 pi / tau */
} ls_traj;

ls_status ls_traj_init(ls_traj *t, const ls_traj_cfg *cfg);
/* Hold at p. */
void ls_traj_reset(ls_traj *t, ls_pos p);
/* -, longest move in steps (2^31: 37 h at 16 kHz); the step counter k stays within uint32_t */
#define LS_TRAJ_STEPS_MAX LS_R(2147483648.0)

/* Start a minimum-time move from the present reference to target (any position: normalised, and
 * saturated at the end of the range beyond it). A move that would last more than
 * LS_TRAJ_STEPS_MAX steps ends, in its direction, where that many steps take it: the reference
 * never wraps back (command the rest again). */
void ls_traj_move(ls_traj *t, ls_pos target);
/* Step to target: a minimum-time move under v_step and a_step (as ls_traj_move), or, with
 * a_step 0, the reference jumps to target (no profile). */
void ls_traj_jump(ls_traj *t, ls_pos target);
/* Reference for this step: position, speed (m/s), acceleration (m/s^2, through the low-pass
 * a_lpf); then advance. Inline (every PWM period). */
static inline void ls_traj_step(ls_traj *t, ls_pos *x_ref, LS_REAL *v_ref, LS_REAL *a_ref)
{
    if (t->active) {
        const LS_REAL am = t->acc;
        const LS_REAL tt = (LS_REAL)t->k * t->ts;
        if (tt < t->t_total) {
            LS_REAL s, v, a;
            if (tt < t->t_acc) {
                s = LS_R(0.5) * am * tt * tt;
                v = am * tt;
                a = am;
            } else if (tt < t->t_total - t->t_acc) {
                s = LS_R(0.5) * am * t->t_acc * t->t_acc + t->v_peak * (tt - t->t_acc);
                v = t->v_peak;
                a = LS_R(0.0);
            } else {
                LS_REAL r = t->t_total - tt;
                s = t->dist - LS_R(0.5) * am * r * r;
                v = am * r;
                a = -am;
            }
            *x_ref = ls_pos_add(t->start, t->sign * s * t->kx);
            *v_ref = t->sign * v;
            t->a_out += t->a_k * (t->sign * a - t->a_out);
            *a_ref = t->a_out;
            t->k++;
            return;
        }
        t->active = false; /* (the move's end: at the target from this step) */
    }
    *x_ref = t->target;
    *v_ref = LS_R(0.0);
    t->a_out -= t->a_k * t->a_out;
    *a_ref = t->a_out;
}

#endif /* LINSENSE_LS_TRAJ_H */
