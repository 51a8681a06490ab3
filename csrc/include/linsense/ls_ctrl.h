/* linsense firmware library: controllers.
 *
 * ls_pi       PI with output limits and anti-windup by conditional integration (no
 *             integration while the output is limited in the direction the error pushes, and the
 *             integrator kept within the output range): leaves the limit as soon as the error
 *             reverses.
 * ls_current  d/q current PI with decoupling (-omega L_q i_q, omega (L_d i_d + psi_pm)) and a
 *             voltage vector limited to a circle of radius v_max (from the DC bus), with the
 *             same conditional-integration anti-windup per axis.
 * ls_posctrl  position P (-> speed PI -> force) or PD (-> force), with speed and acceleration
 *             feed-forward.
 */
#ifndef LINSENSE_LS_CTRL_H
#define LINSENSE_LS_CTRL_H

#include "linsense/ls_types.h"

/* ------------------------------------------------------------------------------- PI */
typedef struct {
    LS_REAL kp;      /* output unit per input unit, > 0 */
    LS_REAL ki;      /* output unit per input unit and second, >= 0 */
    LS_REAL out_min; /* lower output limit, < out_max */
    LS_REAL out_max; /* upper output limit */
    LS_REAL fs;      /* Hz, sampling rate, > 0 */
} ls_pi_cfg;

typedef struct {
    ls_pi_cfg cfg;   /* copy of the configuration */
    LS_REAL integ;   /* integrator state, output unit */
    LS_REAL ts;      /* s, sampling period */
    bool saturated;  /* output was limited at the last step */
} ls_pi;

ls_status ls_pi_init(ls_pi *pi, const ls_pi_cfg *cfg);
void ls_pi_reset(ls_pi *pi);
/* u = kp e + integ + ff, limited; see the anti-windup rule above. */
LS_REAL ls_pi_step(ls_pi *pi, LS_REAL err, LS_REAL ff);

/* ------------------------------------------------------------------------------- current */
typedef struct {
    LS_REAL kp;       /* V/A, proportional gain (both axes), > 0 */
    LS_REAL ki;       /* V/(A s), integral gain (both axes), >= 0 */
    LS_REAL l_d;      /* H, d-axis inductance for decoupling, >= 0 */
    LS_REAL l_q;      /* H, q-axis inductance for decoupling, >= 0 */
    LS_REAL psi_pm;   /* Wb, PM flux linkage for back-EMF feed-forward, >= 0 */
    bool decouple;    /* add the decoupling and back-EMF terms */
    LS_REAL fs;       /* Hz, sampling rate, > 0 */
} ls_current_cfg;

typedef struct {
    ls_current_cfg cfg; /* copy of the configuration */
    LS_REAL integ_d;    /* V, d integrator */
    LS_REAL integ_q;    /* V, q integrator */
    LS_REAL ts;         /* s, sampling period */
    bool saturated;     /* voltage limited at the last step */
} ls_current;

ls_status ls_current_init(ls_current *c, const ls_current_cfg *cfg);
void ls_current_reset(ls_current *c);
/* i_d, i_q: measured (A); i_d_ref, i_q_ref (A); omega: electrical speed (rad/s); v_max (V):
 * radius of the allowed voltage circle. Writes v_d, v_q (V). */
void ls_current_step(ls_current *c, LS_REAL i_d, LS_REAL i_q, LS_REAL i_d_ref, LS_REAL i_q_ref,
                     LS_REAL omega, LS_REAL v_max, LS_REAL *v_d, LS_REAL *v_q);

/* ------------------------------------------------------------------------------- position */
typedef enum {
    LS_POSCTRL_P = 0,  /* position P -> speed reference -> speed PI -> force */
    LS_POSCTRL_PD = 1  /* position PD -> force */
} ls_posctrl_type;

typedef struct {
    ls_posctrl_type type; /* structure */
    LS_REAL kp_x;         /* P: 1/s (m/s per m); PD: N/m, > 0 */
    LS_REAL kd_x;         /* PD: N s/m (damping on the speed error), >= 0 */
    LS_REAL v_max;        /* m/s, speed-reference limit (P), > 0 */
    ls_pi_cfg speed;      /* speed PI (P type): N per m/s, N per m; limits in N */
    LS_REAL mass;         /* kg, for the acceleration feed-forward, >= 0 */
    LS_REAL force_max;    /* N, force limit, > 0 */
} ls_posctrl_cfg;

typedef struct {
    ls_posctrl_cfg cfg; /* copy of the configuration */
    ls_pi speed;        /* speed PI (P type) */
    LS_REAL v_ref;      /* m/s, speed reference at the last step (P type) */
} ls_posctrl;

ls_status ls_posctrl_init(ls_posctrl *p, const ls_posctrl_cfg *cfg);
void ls_posctrl_reset(ls_posctrl *p);
/* x_err = x_ref - x (m), v (m/s), v_ff (m/s), a_ff (m/s^2). Returns the force reference (N). */
LS_REAL ls_posctrl_step(ls_posctrl *p, LS_REAL x_err, LS_REAL v, LS_REAL v_ff, LS_REAL a_ff);

#endif /* LINSENSE_LS_CTRL_H */
