/* linsense firmware library: start-up from an unknown position with the magnet polarity.
 *
 * HF injection finds the d-axis modulo pi: the saliency repeats every half electrical period, so
 * the observer locks on theta or theta + pi. The polarity comes from magnetic saturation: a
 * d-axis current along the magnets' flux (+d) saturates the iron further, so its incremental
 * inductance is lower and the same volt-seconds drive a larger current than against it (-d).
 *
 * The sequence (ls_drive's LS_MODE_STARTUP runs it; docs/firmware.md, docs/theory.md):
 *   LS_SU_LOCK    t_lock with zero current references, the HF injection and the HF observer
 *                 running: the estimate converges on the axis (modulo pi). The mover is not held
 *                 (a position loop on an estimate of unknown polarity could push the wrong way)
 *                 and feels no force but the HF current's. It ends after at least t_lock, once the
 *                 demodulated error is valid and within err_lock (LS_SU_FAILED if not by 4 t_lock).
 *   LS_SU_QUIET   t_quiet: the injection ramps down (stopping it at once would leave its HF
 *                 currents to decay with an offset, a force impulse), observer frozen.
 *   LS_SU_PULSE   2 x pairs voltage pulses of +-v_pulse for t_pulse on the estimated d-axis, each
 *                 after t_rest at zero voltage (the current decays freely: no controller
 *                 overshoot), and a last t_rest; the pairs alternate (+-, -+, +-, ...) so that a
 *                 slow drift and the remainder of the previous pulse cancel. Per pulse the change
 *                 of the d-current in the estimated frame from its start to its end, di_+ or di_-
 *                 (signed), is summed: i_diff = sum(di_+ + di_-) / pairs = mean(|di_+| - |di_-|).
 *                 i_diff > 0: the estimate's +d is the magnets' north; i_diff < 0: it is their
 *                 south, flip by pi. |i_diff| < i_min: undecided (LS_SU_FAILED).
 *   LS_SU_SETTLE  t_settle: the injection ramps up again and the observer relocks (on the flipped
 *                 estimate), still with zero currents.
 *   LS_SU_DONE    the caller enters position control with the reference at the estimate.
 * Why pulses and not the second harmonic of the HF current: the second harmonic's amplitude is
 * the saturation's curvature times the HF current squared, i.e. at the 0.5 A of the injection
 * about (0.5 A / 2 A)^2 of the pulse's signal, with the dead time's own harmonics on top; a pulse
 * pair measures the first-order difference directly, in milliseconds, and its amplitude and
 * length can be chosen from the motor's L_d(+I), L_d(-I) data (linsense tune).
 *
 * The module is the sequence only (timing, pulse voltage, accumulation, decision); the drive owns
 * the HF chain, the observer (and its flip) and the current controller. No malloc, no globals.
 */
#ifndef LINSENSE_LS_STARTUP_H
#define LINSENSE_LS_STARTUP_H

#include "linsense/ls_types.h"

#define LS_STARTUP_PAIRS_MAX 1024u      /* -, largest number of pulse pairs */
#define LS_STARTUP_STEPS_MAX 100000000u /* -, largest length of a phase in sampling periods (t_lock:
                                           a quarter of it) */
#define LS_STARTUP_PULSE_STEPS_MIN 2u  /* -, shortest pulse in sampling periods (t_pulse rounded) */
#define LS_STARTUP_REST_STEPS_MIN 3u   /* -, shortest rest in sampling periods (t_rest rounded: a pulse's
                                          end is sampled on the second) */

typedef enum {
    LS_SU_LOCK = 0,   /* HF lock on the axis (modulo pi), zero currents */
    LS_SU_QUIET = 1,  /* injection ramping down, zero currents */
    LS_SU_PULSE = 2,  /* d-axis pulse pairs */
    LS_SU_SETTLE = 3, /* injection back on, observer relocking */
    LS_SU_DONE = 4,   /* polarity resolved: enter position control */
    LS_SU_FAILED = 5  /* no HF lock at the end of t_lock, or |i_diff| < i_min */
} ls_startup_phase;

typedef struct {
    LS_REAL fs;       /* Hz, sampling rate (= PWM frequency), > 0 */
    LS_REAL t_lock;   /* s, shortest HF lock before the pulses (at most 4 t_lock), > 0 */
    LS_REAL err_lock; /* rad, the lock ends once |demodulated error| <= err_lock, > 0 */
    LS_REAL t_quiet;  /* s, injection ramp-down before the pulses (>= its amplitude / ramp rate plus
                         a few L/R), >= 0 */
    LS_REAL v_pulse;  /* V, pulse amplitude on the estimated d-axis, > 0 (the drive also bounds it by
                         the bus: v_pulse <= v_dc_min / sqrt(3)) */
    LS_REAL t_pulse;  /* s, length of one pulse, rounded to whole sampling periods
                         (>= LS_STARTUP_PULSE_STEPS_MIN) */
    LS_REAL t_rest;   /* s, zero voltage before each pulse and after the last, rounded to whole
                         sampling periods (>= LS_STARTUP_REST_STEPS_MIN) */
    uint32_t pairs;   /* -, (+, -) pulse pairs, 1 .. LS_STARTUP_PAIRS_MAX */
    LS_REAL i_min;    /* A, smallest |i_diff| accepted as a decision, > 0 (0 would never leave a
                         start undecided) */
    LS_REAL t_settle; /* s, HF relock after the pulses, >= 0 */
    LS_REAL lock_gain; /* -, ls_drive: the demodulated error's gain into the HF observer while it locks
                          at zero current (no load estimate then: a mechanical observer's gains act as a
                          PLL's, scaled by it to the PLL's lock, docs/tuning.md), in (0, 100]; 1: none */
} ls_startup_cfg;

typedef struct {
    ls_startup_cfg cfg;     /* copy of the configuration */
    uint32_t n_lock;        /* -, t_lock in sampling periods */
    uint32_t n_quiet;       /* -, t_quiet in sampling periods */
    uint32_t n_pulse;       /* -, t_pulse in sampling periods */
    uint32_t n_slot;        /* -, one pulse and its rest, sampling periods */
    uint32_t n_settle;      /* -, t_settle in sampling periods */
    ls_startup_phase phase; /* phase after the last step */
    uint32_t timer;         /* -, steps in the present phase (LS_SU_PULSE: in the present slot) */
    uint32_t pulse;         /* -, pulse in progress, 0 .. 2 pairs - 1 */
    LS_REAL i_start;        /* A, d-current at the start of the pulse in progress */
    LS_REAL sum;            /* A, sum of the pulses' signed d-current changes */
    LS_REAL v_d;            /* V, d-axis voltage of this step (LS_SU_PULSE; pulsing true) */
    bool pulsing;           /* this step applies v_d open loop (else: current control to zero) */
    bool turned;            /* set by the step that ends the pulses (the caller flips then), then
                               false again */
    LS_REAL env;            /* -, the caller's injection envelope, 0 .. 1 (ls_drive: a smoothstep
                               3 u^2 - 2 u^3 of this linear ramp, so that switching the injection
                               on and off leaves no DC current, i.e. no force impulse) */
    /* results (valid from LS_SU_SETTLE on) */
    LS_REAL i_diff;         /* A, mean(|di_+| - |di_-|) over the pairs */
    bool flip;              /* the estimate was turned by pi */
    uint32_t steps;         /* -, sampling periods since the start (saturates) */
} ls_startup;

/* Validate cfg (LS_ERR_NULL, LS_ERR_PARAM) and reset. */
ls_status ls_startup_init(ls_startup *s, const ls_startup_cfg *cfg);
/* Back to the start of LS_SU_LOCK, results cleared, env 0. */
void ls_startup_reset(ls_startup *s);
/* One sampling period. i_d: A, this step's sampled d-current in the estimated frame (raw, not
 * filtered); err: rad, the demodulated error; hf_valid: the demodulator sees enough HF signal.
 * Sets v_d, pulsing and turned for this step and returns the phase after it. */
ls_startup_phase ls_startup_step(ls_startup *s, LS_REAL i_d, LS_REAL err, bool hf_valid);

#endif /* LINSENSE_LS_STARTUP_H */
