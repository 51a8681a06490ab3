/* linsense firmware library: the HF current the inverter's dead-time error drove, to be taken out
 * of the current the HF estimator sees.
 *
 * The modulator's dead-time compensation predicts each leg's current 1.5 periods ahead; where a
 * phase current is small or crosses zero near an edge, the prediction misses, and the residual
 * error voltage, in step with the injection, biases the demodulated position error by degrees
 * (docs/simulator.md, "Dead time and the closed loop"). After the period its start and end currents
 * are known: ls_mod_residual runs a forward model of the period through this module's inductance
 * model at the estimated angle (ls_dtres_phase_g: the saliency and the end effect's stationary
 * anisotropy) and returns the voltage error the inverter left. This module passes that voltage
 * through the R-L model in the estimated frame and returns the alpha-beta current it drove, which
 * the drive subtracts before the HF band-pass:
 *   i_dq[k+1] = a (.) i_dq[k] + k_l diag(b_d L_d, b_q L_q) L_dq^-1 v_dq[k]   (forward model),
 *   i_dq[k+1] = a (.) i_dq[k] + diag(b_d, b_q) v_dq[k]   (the interpolation: the former model),
 *   a_d = exp(-R T / L_d),  b_d = (1 - a_d) / R  (T / L_d for R = 0), likewise on q (ls_exp),
 * L_dq the model's inductance in the estimated frame. k_l, the scale of the model's inverse
 * inductance, is measured from every period (ls_dtres_adapt: the current change the model predicted
 * against the measured one), so that an inductance off by 10 % (a tolerance, a warm motor) does not
 * bring the dead time's bias back; with cfg.adapt_r the resistance scale k_r too (the period's
 * resistive drop against the measured change: a hot winding), which the drive passes to the
 * forward model's drop and to the demodulator's table (ls_demod.h, comp_r).
 */
#ifndef LINSENSE_LS_DTRES_H
#define LINSENSE_LS_DTRES_H

#include "linsense/ls_types.h"

typedef struct {
    LS_REAL fs;   /**< unit: Hz, sampling rate, > 0 */
    LS_REAL r_s;  /**< unit: ohm, phase resistance of the model, >= 0 */
    LS_REAL l_d;  /**< unit: H, d-axis HF inductance of the model, > 0 */
    LS_REAL l_q;  /**< unit: H, q-axis HF inductance of the model, > 0 */
    bool forward; /**< unit: -, the forward model of the period (ls_mod_residual, with l_ea, l_eb and
                       adapt); false: the cheaper interpolation between the period's end samples
                       (ls_mod_residual_interp), which needs no angle (docs/firmware.md) */
    bool adapt;   /**< unit: -, measure the model's inductance scale k_l online (false: k_l = 1) */
    bool adapt_r; /**< unit: -, with adapt: measure the resistance scale k_r online too (false: k_r = 1) */
    LS_REAL l_ea; /**< unit: H, the stationary anisotropy of the alpha-beta inductance (the end
                       effect): L_ab = (L_d + L_q)/2 I + (L_d - L_q)/2 [c2 s2; s2 -c2]
                       + [l_ea l_eb; l_eb -l_ea] (c2, s2: cos and sin of twice the angle) */
    LS_REAL l_eb; /**< unit: H, its off-diagonal part; L_ab positive definite at every angle:
                       |(l_ea, l_eb)| < min(L_d, L_q) */
} ls_dtres_cfg;

typedef struct {
    ls_dtres_cfg cfg;     /**< unit: -, copy of the configuration */
    LS_REAL a_d, a_q;     /**< unit: -, per-step decay exp(-R T / L) */
    LS_REAL b_d, b_q;     /**< unit: A/V, per-step input gain (1 - a) / R (T / L for R = 0) */
    LS_REAL i_d, i_q;     /**< unit: A, modelled current in the estimated frame */
    LS_REAL k_rip;        /**< unit: s/H, T / L of the PWM ripple at the edges (the interpolation) */
    LS_REAL k_l;          /**< unit: -, the measured scale of the model's inverse inductance (1: as
                               configured), in [LS_DTRES_KL_MIN, LS_DTRES_KL_MAX] */
    LS_REAL k_r;          /**< unit: -, the measured scale of the model's phase resistance (1: as
                               configured; cfg.adapt_r), in [LS_DTRES_KR_MIN, LS_DTRES_KR_MAX] */
    LS_REAL s[7];         /**< unit: A^2, low-passed products of the period's changes (ls_dtres_adapt):
                               <a,a>, <a,b>, <b,b>, <m,a>, <m,b> (high-passed), <m,c>, <c,c> */
    LS_REAL hp[6];        /**< unit: A, the slow parts of m, a and b (alpha-beta), taken out of them */
    uint32_t n_solve;     /**< unit: -, periods since k_r was last solved for (0: just now) */
    LS_REAL k_r_resp;     /**< unit: -, the k_r that a_d, b_d, a_q, b_q are computed for (or, while
                               resp_stage is not 0, are being computed for) */
    LS_REAL x_d, x_q;     /**< unit: -, r_s T / L_d and r_s T / L_q (the exponents at k_r = 1) */
    LS_REAL ts_l_d, ts_l_q; /**< unit: s/H, T / L_d and T / L_q */
    LS_REAL a_next[2];    /**< unit: -, a_d and a_q being computed for k_r_resp */
    LS_REAL b_next;       /**< unit: A/V, b_d being computed for k_r_resp */
    uint32_t resp_stage;  /**< unit: -, the response's recomputation after a solve moved k_r: 0 none,
                               1 to 4 the part the next period computes (a_d, b_d, a_q, b_q; after
                               the fourth all four apply) */
} ls_dtres;

ls_status ls_dtres_init(ls_dtres *r, const ls_dtres_cfg *cfg);
/* The state and both scales back to the start (k_l = k_r = 1). */
void ls_dtres_reset(ls_dtres *r);
/* The state, k_l and the fits' sums back to the start, k_r kept (the winding's resistance does not
 * change with the drive's mode: ls_drive_set_mode). */
void ls_dtres_restart(ls_dtres *r);
/* The response's per-step decay and gain (a_d, b_d, a_q, b_q) for the resistance k_r r_s, at once
 * (ls_dtres_reset: the four parts of ls_dtres_response_step_ in one call). */
void ls_dtres_resistance_(ls_dtres *r);
/* The same for k_r_resp, one part per call (ls_dtres_adapt, in the four periods after a solve that
 * moved k_r by more than LS_DTRES_KR_RESP: one exponential or one division per period, not two of
 * each with the solve; the four apply together, four periods after the solve). */
void ls_dtres_response_step_(ls_dtres *r);

/* v_ab: the voltage error of the period that has just ended (V, alpha-beta); (c, s): cos and sin
 * of the estimated angle; li: with the forward model, the model's inverse inductance L_ab^-1 at
 * that angle (1/H, [aa, bb, ab]: ls_dtres_phase_g; scaled here by k_l as this period's
 * ls_dtres_adapt left it); NULL with the interpolated one (the voltage turned into the frame).
 * Writes the modelled current at this sample into i_ab (A, alpha-beta). Inline (called every PWM
 * period). */
static inline void ls_dtres_step(ls_dtres *r, const LS_REAL v_ab[2], LS_REAL c, LS_REAL s, const LS_REAL li[3],
                                 LS_REAL i_ab[2])
{
    LS_REAL v_d, v_q;
    if (li != NULL) {
        /* the input through the inverse inductance (the saliency and the end effect's anisotropy),
         * turned into the frame and scaled per axis as b_d L_d and b_q L_q (the exact first-order
         * step without the end effect): v_dq <- diag(L_d, L_q) R' k_l L_ab^-1 v_ab (R' L_ab^-1 R =
         * L_dq^-1) */
        const LS_REAL u0 = li[0] * v_ab[0] + li[2] * v_ab[1], u1 = li[2] * v_ab[0] + li[1] * v_ab[1];
        v_d = (c * u0 + s * u1) * (r->k_l * r->cfg.l_d); /* (k_l as this period's ls_dtres_adapt left it) */
        v_q = (c * u1 - s * u0) * (r->k_l * r->cfg.l_q);
    } else {
        v_d = c * v_ab[0] + s * v_ab[1];
        v_q = -s * v_ab[0] + c * v_ab[1];
    }
    r->i_d = r->a_d * r->i_d + r->b_d * v_d;
    r->i_q = r->a_q * r->i_q + r->b_q * v_q;
    i_ab[0] = c * r->i_d - s * r->i_q;
    i_ab[1] = s * r->i_d + c * r->i_q;
}

/* The model's inverse inductance at the angle (c, s) = (cos, sin) of its d-axis: li = L_ab^-1
 * (1/H, [aa, bb, ab]; L_ab as in ls_dtres_cfg, the saliency and the end effect; for ls_dtres_step,
 * which scales it by k_l), and times k_l as the phase matrix G_kj = k_l r_k' li r_j (r_k the unit vector of phase k in
 * alpha-beta), written [aa, bb, cc, ab, ac, bc] for ls_mod_residual (its rows sum to 0: r_a + r_b
 * + r_c = 0). And the rate at which a back-EMF of emf (V, omega psi_pm, on the q-axis: e_ab =
 * emf (-s, c)) changes each phase current, taken as a drop: ge_k = k_l r_k' li e_ab (A/s; ge_a + ge_b
 * + ge_c = 0). */
static inline void ls_dtres_phase_g(const ls_dtres *r, LS_REAL c, LS_REAL s, LS_REAL emf, LS_REAL li[3],
                                    LS_REAL g[6], LS_REAL ge[3])
{
    const LS_REAL hs = LS_R(0.5) * (r->cfg.l_d + r->cfg.l_q), hd = LS_R(0.5) * (r->cfg.l_d - r->cfg.l_q);
    const LS_REAL c2 = c * c - s * s, s2 = LS_R(2.0) * c * s;
    /* L_ab = [p + m, o; o, p - m] and its inverse [p - m, -o; -o, p + m] / det */
    const LS_REAL m = hd * c2 + r->cfg.l_ea, o = hd * s2 + r->cfg.l_eb;
    const LS_REAL idet = LS_R(1.0) / (hs * hs - m * m - o * o);
    const LS_REAL x00 = (hs - m) * idet, x11 = (hs + m) * idet, x01 = -o * idet;
    const LS_REAL h3 = LS_R(0.5) * LS_SQRT3;
    /* r_a = (1, 0), r_b = (-1/2, sqrt3/2), r_c = (-1/2, -sqrt3/2) */
    const LS_REAL q0 = LS_R(0.25) * x00 + LS_R(0.75) * x11;
    const LS_REAL q1 = h3 * x01;
    const LS_REAL k = r->k_l;
    /* k_l li e_ab, e_ab = emf (-s, c) */
    const LS_REAL ke = k * emf;
    const LS_REAL ua = ke * (x01 * c - x00 * s), ub = ke * (x11 * c - x01 * s);
    li[0] = x00;
    li[1] = x11;
    li[2] = x01;
    g[0] = k * x00;
    g[1] = k * (q0 - q1);
    g[2] = k * (q0 + q1);
    g[3] = k * (LS_R(-0.5) * x00 + h3 * x01);
    g[4] = k * (LS_R(-0.5) * x00 - h3 * x01);
    g[5] = k * (LS_R(0.25) * x00 - LS_R(0.75) * x11);
    ge[0] = ua;
    ge[1] = LS_R(-0.5) * ua + h3 * ub;
    ge[2] = LS_R(-0.5) * ua - h3 * ub;
}

/* The inverse-inductance scale k_l and (cfg.adapt_r) the resistance scale k_r from one period
 * (cfg.adapt): i0, the period's start currents, i1 its end, i_pred the end the model predicted and
 * i_drop the resistive drop in that prediction (ls_mod_residual), A, phases. The model's change is
 * p - i0 = k_l (a - k_r b) with a = (p - i0 + drop) / k_l (the volt-seconds through the
 * inductance, per unit of k_l) and b = drop / (k_l k_r) (the drop per unit of k_l k_r); m = i1 - i0
 * the measured change. k_l <- <m, c> / <c, c> with c = a - k_r b (the products over the phases,
 * weighted by k_l^2, low-passed over 1 / LS_DTRES_KL_RATE periods), every period (spread: with each
 * solve of k_r where k_r is fitted). k_r: m fitted
 * as x a - y b by least squares (k_r = y / x) on the products in alpha-beta, low-passed over
 * 1 / LS_DTRES_KR_RATE periods, after each of m, a and b has lost its slow part (a first-order
 * high-pass at LS_DTRES_HP_RATE per period): the fit reads the injection's changes, not the
 * fundamental's, whose back-EMF the model knows only as well as the speed estimate and psi_pm
 * (the rest would read as a resistance while the mover moves under load); solved every LS_DTRES_SOLVE_EVERY periods, moving by at most
 * LS_DTRES_KR_STEP each time; once it has moved by LS_DTRES_KR_RESP, the response (a, b) follows
 * over the next four periods (ls_dtres_response_step_). Each within its bounds. fit_r false holds
 * k_r (the drive's start-up, whose angle is not known yet: the model's drop is then read on the
 * wrong axes). Inline (called every PWM period). */
#define LS_DTRES_KL_RATE LS_R(0.002)
#define LS_DTRES_KR_RATE LS_R(0.002)
#define LS_DTRES_HP_RATE LS_R(0.05)
#define LS_DTRES_SOLVE_EVERY 16u
/* the largest change of k_r per solve (a hot winding's +30 % in 15 solves, 240 periods: about
 * the sums' time constant), and the normal equations' conditioning below which k_r is not solved
 * for (det < LS_DTRES_KR_COND <a,a><b,b>: the drop and the volt-seconds too alike, e.g. no
 * current to drop) */
#define LS_DTRES_KR_STEP LS_R(0.02)
#define LS_DTRES_KR_COND LS_R(1e-3)
#define LS_DTRES_KR_RESP LS_R(0.002) /* -, the k_r change that recomputes the response (a, b) */
#define LS_DTRES_KL_MIN LS_R(0.5)
#define LS_DTRES_KL_MAX LS_R(2.0)
/* a copper winding's resistance from -40 to +180 degC is 0.76-1.78 of its 20 degC value: the scale
 * stays within that (an estimate pinned at a bound says the forward model does not fit the plant:
 * a PWM update other than one period after the sample, a current-sensing gain error) */
#define LS_DTRES_KR_MIN LS_R(0.7)
#define LS_DTRES_KR_MAX LS_R(1.8)
/* x less its slow part: the state hp moves towards x by LS_DTRES_HP_RATE of the way (a first-order
 * high-pass); ls_dtres_adapt's. */
static inline LS_REAL ls_dtres_hp_(LS_REAL *hp, LS_REAL x)
{
    *hp += LS_DTRES_HP_RATE * (x - *hp);
    return x - *hp;
}

/* k_l from its sums (ls_dtres_adapt's: every period without the k_r fit, else with each solve). */
static inline void ls_dtres_kl_(ls_dtres *r)
{
    if (r->s[6] > LS_R(1e-12)) { /* (A^2: below, no current has changed yet) */
        const LS_REAL kl = r->s[5] / r->s[6];
        /* (NaN goes to the lower bound) */
        r->k_l = kl > LS_DTRES_KL_MIN ? (kl < LS_DTRES_KL_MAX ? kl : LS_DTRES_KL_MAX) : LS_DTRES_KL_MIN;
    }
}

/* ls_dtres_adapt's periodic solve for k_r from the sums (n_solve back to 0). */
static inline void ls_dtres_solve_(ls_dtres *r)
{
    const LS_REAL saa = r->s[0], sab = r->s[1], sbb = r->s[2], sma = r->s[3], smb = r->s[4];
    const LS_REAL det = saa * sbb - sab * sab;
    LS_REAL kr = r->k_r;
    r->n_solve = 0u;
    if (det > LS_DTRES_KR_COND * saa * sbb && saa > LS_R(1e-12)) {
        /* min |m - x a + y b|^2: [saa -sab; -sab sbb] [x; y] = [sma; -smb], k_r = y / x */
        const LS_REAL xs = sbb * sma - sab * smb, ys = sab * sma - saa * smb;
        if (xs > LS_R(0.0)) {
            kr = ys / xs; /* (NaN goes to the lower bound) */
        }
    }
    /* at most LS_DTRES_KR_STEP per solve: the tables and the PI follow a ramp, not the first solves'
     * scatter (NaN stays NaN: the bounds below) */
    kr = kr > r->k_r + LS_DTRES_KR_STEP ? r->k_r + LS_DTRES_KR_STEP
                                          : (kr < r->k_r - LS_DTRES_KR_STEP ? r->k_r - LS_DTRES_KR_STEP : kr);
    r->k_r = kr > LS_DTRES_KR_MIN ? (kr < LS_DTRES_KR_MAX ? kr : LS_DTRES_KR_MAX) : LS_DTRES_KR_MIN;
    if (LS_FABS(r->k_r - r->k_r_resp) > LS_DTRES_KR_RESP) {
        r->k_r_resp = r->k_r; /* (the response follows over the next four periods) */
        r->resp_stage = 1u;
    }
}

static inline void ls_dtres_adapt(ls_dtres *r, const LS_REAL i0[3], const LS_REAL i1[3], const LS_REAL i_pred[3],
                                  const LS_REAL i_drop[3], bool fit_r, bool spread)
{
    LS_REAL k3, ul, ub;
    fit_r = fit_r && r->cfg.adapt_r;
    /* spread: a period that solves for k_r (and takes k_l) or moves the response on adds nothing to
     * the sums, and k_l waits for the solve (each is a step's work: the SPEED step's time budget; the
     * sums lose 1 period in 16, 5 while the response follows) */
    if (spread && fit_r && r->n_solve + 1u >= LS_DTRES_SOLVE_EVERY) {
        ls_dtres_kl_(r);
        ls_dtres_solve_(r);
        return;
    }
    if (spread && r->resp_stage != 0u) {
        r->n_solve += fit_r ? 1u : 0u;
        ls_dtres_response_step_(r);
        return;
    }
    k3 = LS_R(0.57735026919);
    ul = LS_R(1.0) / r->k_l;
    ub = ul / r->k_r;
    {
        /* k_l: <m, p - i0> k_l and <p - i0, p - i0> = <m, c> k_l^2 and <c, c> k_l^2 (each period
         * weighted by the change the model predicted), over the phases */
        const LS_REAL m0 = i1[0] - i0[0], m1 = i1[1] - i0[1], m2 = i1[2] - i0[2];
        const LS_REAL p0 = i_pred[0] - i0[0], p1 = i_pred[1] - i0[1], p2 = i_pred[2] - i0[2];
        r->s[5] += LS_DTRES_KL_RATE * ((m0 * p0 + m1 * p1 + m2 * p2) * r->k_l - r->s[5]);
        r->s[6] += LS_DTRES_KL_RATE * ((p0 * p0 + p1 * p1 + p2 * p2) - r->s[6]);
    }
    if (fit_r) {
        /* m, a and b in alpha-beta: alpha = x_a, beta = (x_b - x_c) / sqrt 3, each less its slow
         * part (written out in scalars: a loop over an array kept it in memory, 80 cycles on a
         * Cortex-M4F) */
        const LS_REAL m_a = ls_dtres_hp_(&r->hp[0], i1[0] - i0[0]);
        const LS_REAL m_b = ls_dtres_hp_(&r->hp[1], (i1[1] - i0[1] - i1[2] + i0[2]) * k3);
        const LS_REAL a_a = ls_dtres_hp_(&r->hp[2], (i_pred[0] - i0[0] + i_drop[0]) * ul);
        const LS_REAL a_b = ls_dtres_hp_(
            &r->hp[3], (i_pred[1] - i0[1] + i_drop[1] - i_pred[2] + i0[2] - i_drop[2]) * (k3 * ul));
        const LS_REAL b_a = ls_dtres_hp_(&r->hp[4], i_drop[0] * ub);
        const LS_REAL b_b = ls_dtres_hp_(&r->hp[5], (i_drop[1] - i_drop[2]) * (k3 * ub));
        /* <a,a>, <a,b>, <b,b>, <m,a>, <m,b> */
        r->s[0] += LS_DTRES_KR_RATE * (a_a * a_a + a_b * a_b - r->s[0]);
        r->s[1] += LS_DTRES_KR_RATE * (a_a * b_a + a_b * b_b - r->s[1]);
        r->s[2] += LS_DTRES_KR_RATE * (b_a * b_a + b_b * b_b - r->s[2]);
        r->s[3] += LS_DTRES_KR_RATE * (m_a * a_a + m_b * a_b - r->s[3]);
        r->s[4] += LS_DTRES_KR_RATE * (m_a * b_a + m_b * b_b - r->s[4]);
    }
    if (spread && fit_r) {
        r->n_solve++;
        return;
    }
    ls_dtres_kl_(r);
    if (fit_r && ++r->n_solve >= LS_DTRES_SOLVE_EVERY) { /* (the sums move over 1 / KR_RATE) */
        ls_dtres_solve_(r);
    } else if (r->resp_stage != 0u) {
        ls_dtres_response_step_(r);
    }
}
#endif /* LINSENSE_LS_DTRES_H */
