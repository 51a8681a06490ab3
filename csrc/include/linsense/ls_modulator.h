/* linsense firmware library: 2-level inverter modulator.
 *
 * Min-max zero-sequence injection (equivalent to centred space-vector modulation): phase
 * references from the inverse Clarke transform, offset -(max + min)/2, duty = 1/2 + v/V_dc,
 * limited to [0, 1]. Linear up to |v_ab| = V_dc/sqrt(3). Optional dead-time compensation adds
 * t_dead f_pwm sat(i_pred / i_band) to each duty (the edge lost to the dead time, with a smooth
 * sign around zero current). The duties act one period after the currents were sampled and the
 * dead-time error follows the current at the switching instants, so the sign is taken from the
 * current extrapolated dtc_lead periods ahead, i_pred = i + dtc_lead (i - i_prev) (1.5: the
 * middle of the next period). With HF injection the current crosses zero twice per injection
 * period; without the lead the compensation is wrong around every crossing and biases the
 * position estimate by several degrees (measured with the simulator).
 */
#ifndef LINSENSE_LS_MODULATOR_H
#define LINSENSE_LS_MODULATOR_H

#include "linsense/ls_types.h"

typedef struct {
    LS_REAL f_pwm;     /* Hz, switching frequency, > 0 */
    LS_REAL dead_time; /* s, inverter dead time, >= 0 and < 0.1 / f_pwm */
    bool dtc;          /* dead-time compensation on */
    LS_REAL i_band;    /* A, current band of the smooth sign used by the compensation, > 0 */
    LS_REAL dtc_lead;  /* -, periods of current extrapolation for the compensation sign, [0, 4] */
} ls_mod_cfg;

typedef struct {
    ls_mod_cfg cfg;    /* copy of the configuration */
    LS_REAL d_dead;    /* -, duty equivalent of the dead time */
    LS_REAL i_prev[3]; /* A, phase currents of the previous step (for the extrapolation) */
    bool have_prev;    /* i_prev is valid */
} ls_mod;

ls_status ls_mod_init(ls_mod *m, const ls_mod_cfg *cfg);
void ls_mod_reset(ls_mod *m);
/* v_a, v_b: alpha-beta voltage reference (V); v_dc (V); i_abc: phase currents (A) for the
 * dead-time compensation (may be NULL when off). Writes duty[3] in [0, 1]. Returns true when
 * the reference was beyond the linear range (over-modulation clipped). */
bool ls_mod_step(ls_mod *m, LS_REAL v_a, LS_REAL v_b, LS_REAL v_dc, const LS_REAL i_abc[3],
                 LS_REAL duty[3]);

#endif /* LINSENSE_LS_MODULATOR_H */
