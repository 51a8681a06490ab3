/* linsense firmware library: tracking observer giving position and speed from an error signal.
 *
 * Input: eps = theta - theta_est (rad), from the demodulator (sensorless) or from an encoder.
 * LS_OBS_PLL (type-2 tracking loop, paper Fig. 10):
 *   omega += k2 eps Ts;   theta_est += (omega + k1 eps) Ts
 * LS_OBS_MECH (mechanical model: mass, motor force from the current reference, load force):
 *   theta_est += (omega + k1 eps) Ts
 *   omega     += (kx (F_motor - F_load - F_fric) / m + k2 eps) Ts,   kx = 2 pi / tau
 *   F_fric = clamp(fric_c v / fric_band, -fric_c, fric_c) + fric_v v at the estimated speed v (the
 *            friction the motor file gives, its Coulomb part averaged over the injection's dither:
 *            docs/tuning.md, "Friction and thrust ripple"; 0 without)
 *   F_load    -= k3 eps (m / kx) Ts
 * Error dynamics: s^2 + k1 s + k2 (PLL) and s^3 + k1 s^2 + k2 s + k3 (MECH).
 * ls_observer_gains() places all poles at -2 pi f_bw (critically damped); the gains stay
 * explicit configuration fields. The position is an ls_pos (period count + angle).
 */
#ifndef LINSENSE_LS_OBSERVER_H
#define LINSENSE_LS_OBSERVER_H

#include "linsense/ls_pos.h"
#include "linsense/ls_types.h"

typedef enum {
    LS_OBS_PLL = 0,
    LS_OBS_MECH = 1
} ls_observer_type;

/* Per-step gain bounds ls_observer_init enforces (Ts = 1/fs). The observer is a discrete loop: a
 * step that corrects more than the whole error (k1 Ts > 1) overshoots, and with k2 Ts^2 or
 * k3 Ts^3 beyond 1 its poles leave the unit circle; critically damped gains
 * (ls_observer_gains) meet the bounds up to f_bw = fs / (6 pi) (PLL: fs / (4 pi)). */
#define LS_OBS_K1_TS_MAX LS_R(1.0)  /* -, k1 Ts */
#define LS_OBS_K2_TS2_MAX LS_R(1.0) /* -, k2 Ts^2 */
#define LS_OBS_K3_TS3_MAX LS_R(1.0) /* -, k3 Ts^3 */

typedef struct {
    ls_observer_type type;  /* observer structure */
    LS_REAL fs;             /* Hz, sampling rate, > 0 */
    LS_REAL k1;             /* 1/s, error to speed (proportional), > 0, k1 Ts <= LS_OBS_K1_TS_MAX */
    LS_REAL k2;             /* 1/s^2, error to acceleration (integral), > 0, k2 Ts^2 <= LS_OBS_K2_TS2_MAX */
    LS_REAL k3;             /* 1/s^3, error to load-force (MECH only), > 0 for MECH,
                               k3 Ts^3 <= LS_OBS_K3_TS3_MAX */
    LS_REAL pole_pitch;     /* m, one electrical period tau, > 0 (2 pi / tau and tau / (2 pi) finite) */
    LS_REAL mass;           /* kg, moving mass (MECH), > 0; the largest load force moves the estimate
                               by at most half a period per step: force_max (2 pi / tau) Ts^2 / mass <= pi */
    LS_REAL omega_max;      /* rad/s, electrical speed clamp of the estimate, > 0, omega_max Ts <= pi
                               (at most half a period per step: beyond, the angle aliases) */
    LS_REAL force_max;      /* N, clamp of the load-force estimate (MECH), > 0 */
    LS_REAL fric_c;         /**< unit: N, Coulomb friction of the model (MECH), >= 0 (0: none) */
    LS_REAL fric_v;         /**< unit: N s/m, viscous friction of the model (MECH), >= 0 (0: none) */
    LS_REAL fric_band;      /**< unit: m/s, the speed below which the model's Coulomb force is linear
                                 (MECH), > 0 with fric_c > 0 */
} ls_observer_cfg;

typedef struct {
    ls_observer_cfg cfg; /* copy of the configuration */
    ls_pos pos;          /* estimated position */
    LS_REAL omega;       /* rad/s, estimated electrical speed */
    LS_REAL f_load;      /* N, estimated load force (MECH) */
    LS_REAL ts;          /* s, sampling period */
    LS_REAL kx;          /* rad/m, 2 pi / tau */
    LS_REAL inv_kx;      /* m/rad, tau / (2 pi) */
    LS_REAL k1_ts;       /* -, k1 ts */
    LS_REAL k2_ts;       /* 1/s, k2 ts */
    LS_REAL acc_ts;      /* rad/(s N), kx ts / mass (MECH; 0 for PLL) */
    LS_REAL k3_ts;       /* N/rad, k3 (mass / kx) ts (MECH; 0 for PLL) */
    LS_REAL fric_kw;     /* N s/rad, fric_c / fric_band / kx (MECH with Coulomb friction; else 0) */
    LS_REAL fric_vw;     /* N s/rad, fric_v / kx (MECH; else 0) */
    bool fric_on;        /* MECH with fric_c or fric_v > 0 (else the friction costs no cycle) */
} ls_observer;

/* Fill k1, k2, k3 for critically damped poles at -2 pi f_bw (f_bw in Hz). */
void ls_observer_gains(ls_observer_cfg *cfg, LS_REAL f_bw);
ls_status ls_observer_init(ls_observer *o, const ls_observer_cfg *cfg);
/* Zero speed and load force; position set to p (normalised by ls_pos_norm_full: a non-finite
 * theta counts as 0, a position beyond +-LS_POS_PERIOD_MAX periods saturates at that end). */
void ls_observer_reset(ls_observer *o, ls_pos p);
/* ls_observer_step for finite eps and f_motor (the drive's, by construction). */
static inline void ls_observer_step_finite(ls_observer *o, LS_REAL eps, LS_REAL f_motor)
{
    const ls_observer_cfg *c = &o->cfg;
    const LS_REAL dtheta = o->omega * o->ts + o->k1_ts * eps;
    if (c->type == LS_OBS_MECH) {
        LS_REAL f_net = f_motor - o->f_load;
        if (o->fric_on) {
            f_net -= ls_friction(o->omega, o->fric_kw, c->fric_c, o->fric_vw);
        }
        o->omega += o->acc_ts * f_net + o->k2_ts * eps;
        o->f_load = ls_clamp(o->f_load - o->k3_ts * eps, -c->force_max, c->force_max);
    } else {
        o->omega += o->k2_ts * eps;
    }
    o->omega = ls_clamp(o->omega, -c->omega_max, c->omega_max);
    o->pos = ls_pos_add(o->pos, dtheta);
}

/* One step with error eps (rad) and motor force f_motor (N, from the current reference); a
 * non-finite eps or f_motor counts as 0. Inline (called every PWM period). */
static inline void ls_observer_step(ls_observer *o, LS_REAL eps, LS_REAL f_motor)
{
    ls_observer_step_finite(o, LS_ISFINITE(eps) ? eps : LS_R(0.0), LS_ISFINITE(f_motor) ? f_motor : LS_R(0.0));
}

/* Estimated speed in m/s. */
static inline LS_REAL ls_observer_speed(const ls_observer *o)
{
    return o->omega * o->inv_kx;
}

#endif /* LINSENSE_LS_OBSERVER_H */
