/* linsense firmware library: the HF current the inverter's dead-time error drove, to be taken out
 * of the current the HF estimator sees.
 *
 * The modulator's dead-time compensation predicts each leg's current sign 1.5 periods ahead; where
 * a phase current is small (a phase perpendicular to the injection axis carries little HF current,
 * only the force current), the prediction misses and the residual error voltage acts like a relay
 * on the sign of the force current, biasing the demodulated position error by degrees
 * (docs/simulator.md, "Dead time and the closed loop"). After the period both end-point currents
 * are known: ls_mod_residual interpolates each leg's current at its edges and returns the voltage
 * error the inverter actually left. This module passes that voltage through a nominal R-L_d-L_q
 * model in the estimated frame (exact first-order step per axis) and returns the alpha-beta current
 * it drove, which the drive subtracts before the HF band-pass:
 *   i_d[k+1] = a_d i_d[k] + b_d v_d[k],  a_d = exp(-R T / L_d),  b_d = (1 - a_d) / R  (T / L_d for R = 0)
 * and likewise on q.
 */
#ifndef LINSENSE_LS_DTRES_H
#define LINSENSE_LS_DTRES_H

#include "linsense/ls_types.h"

typedef struct {
    LS_REAL fs;  /* Hz, sampling rate, > 0 */
    LS_REAL r_s; /* ohm, phase resistance of the model, >= 0 */
    LS_REAL l_d; /* H, d-axis HF inductance of the model, > 0 */
    LS_REAL l_q; /* H, q-axis HF inductance of the model, > 0 */
    bool ripple; /* the PWM current ripple at the edges decides the sign of a small current */
} ls_dtres_cfg;

typedef struct {
    ls_dtres_cfg cfg;   /* copy of the configuration */
    LS_REAL a_d, a_q;   /* -, per-step decay exp(-R T / L) */
    LS_REAL b_d, b_q;   /* A/V, per-step input gain (1 - a) / R (T / L for R = 0) */
    LS_REAL i_d, i_q;   /* A, modelled current in the estimated frame */
    LS_REAL k_rip;      /* 1/H s, T / L of the PWM ripple at the edges (0: ripple ignored) */
} ls_dtres;

ls_status ls_dtres_init(ls_dtres *r, const ls_dtres_cfg *cfg);
void ls_dtres_reset(ls_dtres *r);

/* v_ab: the voltage error of the period that has just ended (V, alpha-beta); (c, s): cos and sin
 * of the estimated angle. Writes the modelled current at this sample into i_ab (A, alpha-beta).
 * Inline (called every PWM period). */
static inline void ls_dtres_step(ls_dtres *r, const LS_REAL v_ab[2], LS_REAL c, LS_REAL s, LS_REAL i_ab[2])
{
    const LS_REAL v_d = c * v_ab[0] + s * v_ab[1];
    const LS_REAL v_q = -s * v_ab[0] + c * v_ab[1];
    r->i_d = r->a_d * r->i_d + r->b_d * v_d;
    r->i_q = r->a_q * r->i_q + r->b_q * v_q;
    i_ab[0] = c * r->i_d - s * r->i_q;
    i_ab[1] = s * r->i_d + c * r->i_q;
}

#endif /* LINSENSE_LS_DTRES_H */
