/* LS_MODE_COMMISSION: the end-effect table learned without a sensor (docs/tuning.md,
 * "Commissioning without a sensor").
 *
 * The step is the whole-speed-range step of ls_drive_speed.c (cfg.emf_on) with the injection kept on
 * at every speed: the HF chain runs beside the EMF estimate, its demodulator with the table being
 * learned (demod.comp reads cal.table). Where the estimated speed is at least fuse.v_hi the observer
 * follows the EMF error alone, and the demodulator's ratio (~ delta = Psi(theta) - T(theta) + (theta
 * - theta_est) / g, ls_demod.h) says where the table T should be at the estimated angle: the open-loop
 * estimate P = T(theta_est) + ratio. Each step moves the estimate of the present direction towards it
 * by least mean squares on the linear interpolation (the two neighbouring points, weights 1 - f and
 * f, rate cal.k_int), and writes the table at those points as the mean of the forward and backward
 * estimates.
 *
 * The ratio's slope in the table's error is cal.slope (s: 1 for the pulsating injection, less for
 * the elliptical one), so P = T(theta_est) + (ratio + hf_delay omega / gain) / s: the HF path's delay
 * (which the observer adds to the HF error) taken out, the nominal gain's share of it.
 *
 * Why two estimates, not one integrator: what follows the speed's sign (the rest of the HF path's
 * delay, the demodulator's low-pass lag, the EMF estimate's odd errors) moves each direction's
 * equilibrium by +-b; one integrator visited in turns would wander by the rate times each pass's
 * time around the mean, the two estimates settle each at its own equilibrium and their mean is the
 * mean whatever the time spent in each direction. b grows with the speed: the learning runs at the
 * moves' cruise only (|omega| >= LS_DRIVE_LEARN_CRUISE traj.v_max, and above fuse.v_hi: learn_w;
 * the trajectory's acceleration nil for cal.t_settle), one speed both ways. The demodulator reads the mean, so its ratio stays small (the product's
 * sin 2 delta / 2 ~ delta) and the mean is a fixed point even where s is not the motor's.
 *
 * The learning runs every other step, two periods' worth at a time, and the EMF's angle in the steps
 * between (the observer holds the last EMF error for one period): each is a step's work, and the two
 * in one step would leave the commissioning's step over the time budget (docs/firmware.md). The
 * residual of the dead time is the interpolated one here (ls_drive_speed.c). */
#include "ls_drive_internal.h"

void ls_drive_learn_reset_(ls_drive *d)
{
    const uint32_t n = d->cfg.cal.points;
    float *e = d->cfg.cal.learn;
    uint32_t k;
    for (k = 0u; k < n; k++) {
        e[k] = d->cfg.cal.table[k];
        e[n + k] = d->cfg.cal.table[k];
        e[2u * n + k] = 0.0f;
        e[3u * n + k] = 0.0f;
    }
    d->cal_index = 0u;
}

/* One point's share of the step: its estimate moved by a w err, its time by w ts; the point counted
 * when its time in this direction reaches cal.t_hold and the other's has; the table the mean. */
static inline void learn_point(ls_drive *LS_RESTRICT d, uint32_t k, LS_REAL w, LS_REAL a_err, float *LS_RESTRICT est,
                               float *LS_RESTRICT t_dir, const float *LS_RESTRICT t_other, const float *LS_RESTRICT other)
{
    const LS_REAL t0 = (LS_REAL)t_dir[k];
    const LS_REAL t1 = t0 + w * (LS_R(2.0) * d->ts); /* (two periods: it learns every other step) */
    est[k] = (float)((LS_REAL)est[k] + w * a_err);
    t_dir[k] = (float)t1;
    if (t0 < d->cfg.cal.t_hold && !(t1 < d->cfg.cal.t_hold) && !((LS_REAL)t_other[k] < d->cfg.cal.t_hold)) {
        d->cal_index++;
    }
    d->cfg.cal.table[k] = (float)(LS_R(0.5) * ((LS_REAL)est[k] + (LS_REAL)other[k]));
}

void ls_drive_learn_(ls_drive *LS_RESTRICT d)
{
    const uint32_t n = d->cfg.cal.points;
    const LS_REAL omega = d->obs.omega;
    LS_REAL theta = d->obs.pos.theta - d->cfg.hf_delay * omega; /* (see below) */
    float *LS_RESTRICT e = d->cfg.cal.learn;
    float *est, *oth, *t_dir, *t_oth;
    const float *tab = d->cfg.cal.table;
    LS_REAL u, f, p, err;
    uint32_t k, k1;
    /* at the cruise only, cal.t_settle after the acceleration (cal_timer: steps since), above the
     * band (the EMF error alone), with a valid HF signal */
    if (!d->traj.active || LS_FABS(d->traj.a_out) > LS_DRIVE_LEARN_A_CRUISE * d->traj.acc) {
        d->cal_timer = 0u;
        return;
    }
    if (d->cal_timer < d->cal_n_settle) {
        d->cal_timer += 2u; /* (called every other step: two steps since) */
        return;
    }
    if (!d->demod.valid || !(LS_FABS(omega) >= d->learn_w)) {
        return;
    }
    /* the angle the demodulated ratio belongs to: the HF path's delay ago (else each direction's
     * estimate lies shifted by +-omega hf_delay, and their mean is the table smoothed, by 4 % of its
     * 2 theta harmonic at 1 m/s on ecce2010); in [0, 2 pi) again (|omega hf_delay| < 2 pi: omega <=
     * omega_max, hf_delay <= 0.1 s) */
    theta = theta < LS_R(0.0) ? theta + LS_TWO_PI : (theta >= LS_TWO_PI ? theta - LS_TWO_PI : theta);
    u = theta * (LS_REAL)n * (LS_R(1.0) / LS_TWO_PI);
    if (!(u >= LS_R(0.0) && u < (LS_REAL)n)) { /* (u rounded up to n: the first point) */
        u = LS_R(0.0);
    }
    k = (uint32_t)u; /* in range: 0 <= u < n */
    f = u - (LS_REAL)k;
    k1 = k + 1u < n ? k + 1u : 0u;
    est = omega > LS_R(0.0) ? e : e + n;
    oth = omega > LS_R(0.0) ? e + n : e;
    t_dir = omega > LS_R(0.0) ? e + 2u * n : e + 3u * n;
    t_oth = omega > LS_R(0.0) ? e + 3u * n : e + 2u * n;
    /* where the table should be (the open-loop estimate) less where this direction's estimate is */
    p = (LS_REAL)tab[k] + f * ((LS_REAL)tab[k1] - (LS_REAL)tab[k]) +
        (d->demod.ratio + d->learn_kd * omega) * d->learn_inv_s;
    err = p - ((LS_REAL)est[k] + f * ((LS_REAL)est[k1] - (LS_REAL)est[k]));
    err *= d->cfg.cal.k_int * (LS_R(2.0) * d->ts);
    learn_point(d, k, LS_R(1.0) - f, err, est, t_dir, t_oth, oth);
    learn_point(d, k1, f, err, est, t_dir, t_oth, oth);
}

void ls_drive_commission_step_(ls_drive *LS_RESTRICT d, const ls_meas *LS_RESTRICT meas, ls_cmd *LS_RESTRICT cmd)
{
    ls_drive_speed_run_(d, meas, cmd, true);
    cmd->cal_index = d->cal_index;
    cmd->cal_done = cmd->enable && d->cal_index >= d->cfg.cal.points;
}
