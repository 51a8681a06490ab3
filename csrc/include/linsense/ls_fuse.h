/* linsense firmware library: the hand-over between the HF estimate and the EMF estimate, for the
 * whole speed range (docs/theory.md, "The hand-over").
 *
 * One mechanical observer (ls_observer) takes one error eps = theta - theta_est; this block makes it
 * from the HF error (the demodulator's) and the EMF error (ls_emf's), weighted on the estimated
 * speed |v| (m/s):
 *   w = clamp((|v| - v_lo) / (v_hi - v_lo), 0, 1),   eps = (1 - w) eps_hf + w eps_emf,
 * HF alone up to v_lo, EMF alone from v_hi, a straight blend between: the estimate settles where the
 * blend of the two errors is zero, so it moves from the HF estimate's offset to the EMF's
 * continuously (no jump: the two offsets differ by less than the hand-over bound at the band's
 * ends, the design's rule). The weight is a continuous function of the speed: a speed hovering in
 * the band moves it smoothly, never to and fro between two values.
 * The injection: off above v_off, on again below v_on (v_hi <= v_on < v_off: hysteresis, both
 * above the band, where the HF error already weighs nothing). Once back at its full amplitude, the
 * HF error counts again after t_settle (the demodulator's filters refilled); until then, and
 * whenever the injection is not at full amplitude, the EMF error alone is used above v_lo, and no
 * error (the observer runs on its model) below it. At a reset the HF error counts as soon as the
 * injection is at full amplitude (the drive's start, as without this block).
 * Where the EMF estimate runs at all (ls_fuse_emf_run): from LS_FUSE_EMF_ON v_lo up, until the speed
 * falls below LS_FUSE_EMF_OFF v_lo (hysteresis). Below, its filters are idle (nothing weighs them
 * there: the step's time, where the HF chain measures the dead-time model's scales); from there up,
 * they settle before v_lo, where the EMF error starts to count (docs/theory.md, "What the SPEED step
 * computes where"; the design checks that they have the time: linsense.tune.handover).
 */
#ifndef LINSENSE_LS_FUSE_H
#define LINSENSE_LS_FUSE_H

#include "linsense/ls_math.h"
#include "linsense/ls_types.h"

/* The EMF estimate runs from LS_FUSE_EMF_ON v_lo up and stops below LS_FUSE_EMF_OFF v_lo (-). */
#define LS_FUSE_EMF_ON LS_R(0.5)
#define LS_FUSE_EMF_OFF LS_R(0.4)

typedef struct {
    LS_REAL fs;         /**< unit: Hz, sampling rate, > 0 */
    LS_REAL pole_pitch; /**< unit: m, one electrical period tau, > 0 */
    LS_REAL v_lo;       /**< unit: m/s, the speed up to which the HF error alone drives the observer, > 0 */
    LS_REAL v_hi;       /**< unit: m/s, the speed from which the EMF error alone does, > v_lo */
    LS_REAL v_off;      /**< unit: m/s, the speed above which the injection fades out, > v_on */
    LS_REAL v_on;       /**< unit: m/s, the speed below which it fades back in, >= v_hi */
    LS_REAL t_settle;   /**< unit: s, time at full injection amplitude before the HF error counts
                             again after a fade, >= 0, < 1 */
} ls_fuse_cfg;

typedef struct {
    ls_fuse_cfg cfg;    /**< unit: -, copy of the configuration */
    LS_REAL w_lo;       /**< unit: rad/s, v_lo as an electrical speed */
    LS_REAL inv_band;   /**< unit: s/rad, 1 / (w_hi - w_lo) */
    LS_REAL w_off;      /**< unit: rad/s, v_off as an electrical speed */
    LS_REAL w_on;       /**< unit: rad/s, v_on as an electrical speed */
    LS_REAL w_emf_on;   /**< unit: rad/s, LS_FUSE_EMF_ON v_lo as an electrical speed */
    LS_REAL w_emf_off;  /**< unit: rad/s, LS_FUSE_EMF_OFF v_lo as an electrical speed */
    uint32_t n_settle;  /**< unit: steps, t_settle fs (rounded up) */
    uint32_t n_full;    /**< unit: steps, at full injection amplitude since the last fade (n_settle
                             after a reset; saturates at n_settle) */
    bool inject;        /**< unit: -, the injection requested (the hysteresis' state) */
    LS_REAL w;          /**< unit: -, the EMF error's weight of the last step, [0, 1] */
    bool hf_used;       /**< unit: -, the HF error counted in the last step */
    bool emf_run;       /**< unit: -, the EMF estimate runs (the hysteresis' state of ls_fuse_emf_run;
                             false after a reset) */
} ls_fuse;

ls_status ls_fuse_init(ls_fuse *f, const ls_fuse_cfg *cfg);
/* The injection requested, the HF error counted as soon as the injection is at full amplitude. */
void ls_fuse_reset(ls_fuse *f);

/* Whether the EMF estimate runs this step, at the estimated electrical speed omega (rad/s): on
 * above w_emf_on, off again below w_emf_off; call before the EMF's and ls_fuse_step. */
static inline bool ls_fuse_emf_run(ls_fuse *f, LS_REAL omega)
{
    const LS_REAL a = LS_FABS(omega);
    f->emf_run = f->emf_run ? !(a < f->w_emf_off) : a > f->w_emf_on;
    return f->emf_run;
}

/* One step: the estimated electrical speed omega (rad/s), whether the injection is at its full
 * amplitude (hf_full), the HF error and the EMF error (rad, finite); returns the observer's error
 * (rad) and updates w, hf_used and inject (read it after the step: ls_inject_enable). */
static inline LS_REAL ls_fuse_step(ls_fuse *f, LS_REAL omega, bool hf_full, LS_REAL eps_hf, LS_REAL eps_emf)
{
    const LS_REAL a = LS_FABS(omega);
    LS_REAL w;
    if (hf_full && f->n_full < f->n_settle) {
        f->n_full++;
    }
#ifndef __OPTIMIZE_SIZE__ /* (the build for speed: the time budget; the same numbers) */
    if (f->inject && a <= f->w_lo) { /* below the band, injecting (w_off > w_lo): the HF error alone,
                                        as the general path below computes it (NaN takes that path) */
        f->hf_used = hf_full && f->n_full >= f->n_settle;
        f->w = LS_R(0.0);
        return f->hf_used ? eps_hf : LS_R(0.0);
    }
#endif
    w = ls_clamp((a - f->w_lo) * f->inv_band, LS_R(0.0), LS_R(1.0));
    if (f->inject) {
        if (a > f->w_off) {
            /* faded: the HF error waits t_settle at full amplitude again, counted from the next step
             * (this one, still at full amplitude, does not count) */
            f->inject = false;
            f->n_full = 0u;
        }
    } else {
        f->inject = a < f->w_on;
    }
    f->hf_used = hf_full && f->n_full >= f->n_settle;
    if (!f->hf_used) {
        w = a > f->w_lo ? LS_R(1.0) : LS_R(0.0); /* (the EMF alone in the band; nothing below it) */
        f->w = w;
        return w > LS_R(0.0) ? eps_emf : LS_R(0.0);
    }
    f->w = w;
    if (w <= LS_R(0.0)) {
        return eps_hf; /* (exactly: below the band the drive is the HF drive) */
    }
    return eps_hf + w * (eps_emf - eps_hf);
}

#endif /* LINSENSE_LS_FUSE_H */
