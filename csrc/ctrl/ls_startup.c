/* Start-up with the magnet polarity (see linsense/ls_startup.h). */
#include <math.h>
#include <string.h>

#include "linsense/ls_startup.h"

/* t (s) in whole sampling periods, rounded; false when out of [lo, LS_STARTUP_STEPS_MAX] */
static bool steps_of(LS_REAL t, LS_REAL fs, uint32_t lo, uint32_t *n)
{
    LS_REAL x;
    if (!LS_ISFINITE(t) || t < LS_R(0.0)) {
        return false;
    }
    x = LS_FLOOR(t * fs + LS_R(0.5));
    if (!(x >= (LS_REAL)lo) || !(x <= (LS_REAL)LS_STARTUP_STEPS_MAX)) {
        return false;
    }
    *n = (uint32_t)x;
    return true;
}

ls_status ls_startup_init(ls_startup *s, const ls_startup_cfg *cfg)
{
    uint32_t n_rest = 0u;
    if (s == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    memset(s, 0, sizeof *s);
    if (!LS_ISFINITE(cfg->fs) || !(cfg->fs > LS_R(0.0)) || !LS_ISFINITE(cfg->v_pulse) ||
        !(cfg->v_pulse > LS_R(0.0)) || !LS_ISFINITE(cfg->i_min) || !(cfg->i_min > LS_R(0.0)) ||
        !LS_ISFINITE(cfg->err_lock) || !(cfg->err_lock > LS_R(0.0)) || cfg->pairs < 1u ||
        !(cfg->lock_gain > LS_R(0.0)) || !(cfg->lock_gain <= LS_R(100.0)) ||
        !(cfg->t_lock * cfg->fs <= LS_R(0.25) * (LS_REAL)LS_STARTUP_STEPS_MAX) ||
        cfg->pairs > LS_STARTUP_PAIRS_MAX || !steps_of(cfg->t_lock, cfg->fs, 1u, &s->n_lock) ||
        !steps_of(cfg->t_quiet, cfg->fs, 0u, &s->n_quiet) ||
        !steps_of(cfg->t_pulse, cfg->fs, LS_STARTUP_PULSE_STEPS_MIN, &s->n_pulse) ||
        !steps_of(cfg->t_rest, cfg->fs, LS_STARTUP_REST_STEPS_MIN, &n_rest) ||
        !steps_of(cfg->t_settle, cfg->fs, 0u, &s->n_settle) ||
        s->n_pulse > LS_STARTUP_STEPS_MAX - n_rest) {
        memset(s, 0, sizeof *s);
        return LS_ERR_PARAM;
    }
    s->cfg = *cfg;
    s->n_slot = s->n_pulse + n_rest;
    ls_startup_reset(s);
    return LS_OK;
}

void ls_startup_reset(ls_startup *s)
{
    s->phase = LS_SU_LOCK;
    s->timer = 0u;
    s->pulse = 0u;
    s->i_start = LS_R(0.0);
    s->sum = LS_R(0.0);
    s->v_d = LS_R(0.0);
    s->pulsing = false;
    s->turned = false;
    s->env = LS_R(0.0);
    s->i_diff = LS_R(0.0);
    s->flip = false;
    s->steps = 0u;
}

/* the sign of pulse k: pairs +-, -+, +-, ... (k = 0, 1 | 2, 3 | ...) */
static LS_REAL pulse_sign(uint32_t k)
{
    return ((k ^ (k >> 1)) & 1u) != 0u ? LS_R(-1.0) : LS_R(1.0);
}

ls_startup_phase ls_startup_step(ls_startup *s, LS_REAL i_d, LS_REAL err, bool hf_valid)
{
    s->pulsing = false;
    s->turned = false;
    s->v_d = LS_R(0.0);
    if (s->cfg.pairs == 0u) { /* a state that ls_startup_init did not fill (zeroed): no sequence */
        s->phase = LS_SU_FAILED;
        return s->phase;
    }
    if (s->steps < LS_STARTUP_STEPS_MAX) {
        s->steps++;
    }
    switch (s->phase) {
    case LS_SU_LOCK:
        /* at least n_lock steps; then as soon as the error is within err_lock (a start near the
         * unstable equilibrium, 90 deg off, takes longer); failed after 4 n_lock */
        if (++s->timer >= s->n_lock) {
            if (hf_valid && LS_FABS(err) <= s->cfg.err_lock) {
                s->timer = 0u;
                s->phase = LS_SU_QUIET;
            } else if (s->timer >= 4u * s->n_lock) {
                s->phase = LS_SU_FAILED;
            }
        }
        break;
    case LS_SU_QUIET:
        if (++s->timer >= s->n_quiet) {
            s->timer = 0u;
            s->phase = LS_SU_PULSE;
        }
        break;
    case LS_SU_PULSE: {
        /* slot k (k < 2 pairs): n_r = n_slot - n_pulse steps of rest, then pulse k for n_pulse
         * steps; the voltage of a step acts during the next PWM period, so pulse k starts from the
         * sample of step n_r + 1 and ends at the sample of step 1 of slot k + 1; a last slot of
         * rest only, then the decision */
        const uint32_t n_pulses = 2u * s->cfg.pairs;
        if (s->timer == 1u && s->pulse > 0u) {
            s->sum += i_d - s->i_start;
        }
        if (s->timer == s->n_slot - s->n_pulse + 1u) {
            s->i_start = i_d;
        }
        if (s->timer >= s->n_slot - s->n_pulse && s->pulse < n_pulses) {
            s->pulsing = true;
            s->v_d = pulse_sign(s->pulse) * s->cfg.v_pulse;
        }
        s->timer++;
        if (s->pulse >= n_pulses) {
            if (s->timer >= s->n_slot - s->n_pulse) {
                s->timer = 0u;
                s->i_diff = s->sum / (LS_REAL)s->cfg.pairs;
                if (!(LS_FABS(s->i_diff) >= s->cfg.i_min) || !LS_ISFINITE(s->i_diff)) {
                    s->phase = LS_SU_FAILED;
                } else {
                    s->flip = s->i_diff < LS_R(0.0);
                    s->turned = true;
                    s->phase = s->n_settle > 0u ? LS_SU_SETTLE : LS_SU_DONE;
                }
            }
        } else if (s->timer >= s->n_slot) {
            s->timer = 0u;
            s->pulse++;
        }
        break;
    }
    case LS_SU_SETTLE:
        if (++s->timer >= s->n_settle) {
            s->timer = 0u;
            s->phase = LS_SU_DONE;
        }
        break;
    case LS_SU_DONE:
    case LS_SU_FAILED:
    default:
        break;
    }
    return s->phase;
}
