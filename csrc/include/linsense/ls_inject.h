/* linsense firmware library: HF voltage injection.
 *
 * Three shapes (docs/theory.md):
 *   LS_INJ_PULSATING: v_d_hf[k] = A[k] cos(phi[k]) on the estimated d-axis, phi advancing by
 *                     2 pi f / fs per step (the paper's), and optionally v_q_hf[k] = kappa A[k]
 *                     sin(phi[k]) on the estimated q-axis (elliptical): then no phase current stays
 *                     near zero through the HF period, which is what makes the estimate robust to
 *                     the inverter's dead time;
 *   LS_INJ_ROTATING:  v_alpha = A cos(phi), v_beta = A sin(phi) in the STATIONARY frame (the returned
 *                     value is the alpha part, v_q the beta part: the drive adds them unrotated);
 *   LS_INJ_SQUARE:    v_d_hf[k] = +-A alternating every step (f = fs / 2 exactly) on the estimated
 *                     d-axis, for the difference-based demodulation (Kim, Ha, Sul, IEEE TIA 2012).
 * The carrier is a unit
 * phasor rotated by a fixed step each sample (no trigonometry per step) and renormalised, so
 * it is phase-continuous for any frequency, including through amplitude ramps.
 */
#ifndef LINSENSE_LS_INJECT_H
#define LINSENSE_LS_INJECT_H

#include "linsense/ls_math.h"
#include "linsense/ls_types.h"

typedef enum {
    LS_INJ_PULSATING = 0,
    LS_INJ_ROTATING = 1,
    LS_INJ_SQUARE = 2
} ls_inject_shape;

typedef struct {
    ls_inject_shape shape; /* pulsating (default, 0), rotating or square */
    LS_REAL amplitude; /* V, peak HF voltage when on, >= 0 */
    LS_REAL freq;      /* Hz, injection frequency, > 0 (square: exactly fs / 2) */
    LS_REAL fs;        /* Hz, sampling rate, >= 4 freq (pulsating, rotating) */
    LS_REAL ramp_rate; /* V/s, amplitude slew when switched on or off, > 0 */
    LS_REAL quad;      /* -, kappa in [0, 1): kappa A sin(phi) added on the estimated q-axis (elliptical
                          injection, docs/theory.md; 0: pulsating, as the paper); 0 unless pulsating */
} ls_inject_cfg;

typedef struct {
    ls_inject_cfg cfg; /* copy of the configuration (rotating: with quad = 1, the beta part) */
    LS_REAL c, s;      /* -, cos and sin of the present carrier phase */
    LS_REAL dc, ds;    /* -, cos and sin of the phase step 2 pi f / fs */
    LS_REAL amp;       /* V, present amplitude */
    LS_REAL amp_step;  /* V, amplitude change per step during a ramp */
    bool on;           /* injection requested on */
    LS_REAL v_q;       /* V, q-axis component of the last step, kappa A sin(phi) (rotating: the
                          beta component A sin(phi)) */
} ls_inject;

ls_status ls_inject_init(ls_inject *inj, const ls_inject_cfg *cfg);
/* Phase 0, amplitude 0, off. */
void ls_inject_reset(ls_inject *inj);
/* Request on (ramp up to cfg.amplitude) or off (ramp down to 0). */
void ls_inject_enable(ls_inject *inj, bool on);
/* HF voltage for this step (V), then advance the carrier by one step. The
 * carrier phasor (c, s) in the state then belongs to the next sample. Inline (every PWM period). */
static inline LS_REAL ls_inject_step(ls_inject *inj)
{
    LS_REAL v;
    LS_REAL target = inj->on ? inj->cfg.amplitude : LS_R(0.0);
    if (inj->amp < target) {
        inj->amp = inj->amp + inj->amp_step < target ? inj->amp + inj->amp_step : target;
    } else if (inj->amp > target) {
        inj->amp = inj->amp - inj->amp_step > target ? inj->amp - inj->amp_step : target;
    }
    v = inj->amp * inj->c;
    inj->v_q = inj->cfg.quad * inj->amp * inj->s;
    {
        ls_phasor p; /* the carrier, one step on */
        p.c = inj->c;
        p.s = inj->s;
        p = ls_phasor_advance(p, inj->dc, inj->ds);
        inj->c = p.c;
        inj->s = p.s;
    }
    return v;
}

#endif /* LINSENSE_LS_INJECT_H */
