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
    LS_REAL inv_band;  /* 1/A, 1 / i_band */
    LS_REAL hist_d[2][3]; /* -, duties of the last two steps as applied ([newest] and [newest ^ 1]) */
    LS_REAL hist_c[2][3]; /* -, the dead-time compensation they contain */
    uint32_t newest;      /* -, index of the last step's entry (0 or 1) */
    uint32_t n_hist;      /* -, valid history entries (0 to 2) */
} ls_mod;

ls_status ls_mod_init(ls_mod *m, const ls_mod_cfg *cfg);
void ls_mod_reset(ls_mod *m);
/* The step is inline (called every PWM period). ls_mod_step_finite is ls_mod_step for finite
 * v_a, v_b, v_dc and i_abc (the drive checks them), without those guards; ls_mod_step_impl is
 * the implementation of both. */
static inline bool ls_mod_step_impl(ls_mod *m, LS_REAL v_a, LS_REAL v_b, LS_REAL v_dc,
                                    const LS_REAL i_abc[3], LS_REAL duty[3], bool check)
{
    LS_REAL v[3], dt[3], vmax, vmin, off, inv;
    const bool dtc = m->cfg.dtc && i_abc != NULL;
    bool clipped = false;
    int k;
    if (check && (!LS_ISFINITE3(v_a, v_b, v_dc) || !(v_dc > LS_R(0.0)))) {
        duty[0] = duty[1] = duty[2] = LS_R(0.5);
        return true;
    }
    if (!check && !(v_dc > LS_R(0.0))) {
        duty[0] = duty[1] = duty[2] = LS_R(0.5);
        return true;
    }
    /* dead-time compensation: the duty correction of each leg from its predicted current
     * (computed first: it does not depend on the voltage) */
    dt[0] = dt[1] = dt[2] = LS_R(0.0);
    if (dtc) {
        if (m->have_prev && (!check || LS_ISFINITE3(i_abc[0], i_abc[1], i_abc[2]))) {
            /* x = i_pred / i_band with i_pred = i + lead (i - i_prev); the three legs written out on
             * local copies (stores to i_prev would otherwise make the compiler reload i_abc) */
            const LS_REAL ka = (LS_R(1.0) + m->cfg.dtc_lead) * m->inv_band, kb = m->cfg.dtc_lead * m->inv_band;
            const LS_REAL i0 = i_abc[0], i1 = i_abc[1], i2 = i_abc[2];
            const LS_REAL x0 = ka * i0 - kb * m->i_prev[0];
            const LS_REAL x1 = ka * i1 - kb * m->i_prev[1];
            const LS_REAL x2 = ka * i2 - kb * m->i_prev[2];
            /* = ls_clamp(x, -1, 1), in a form compilers select without branching (the HF current
             * crosses zero twice per injection period: a branch on it mispredicts) */
            const LS_REAL y0 = x0 > LS_R(1.0) ? LS_R(1.0) : x0, y1 = x1 > LS_R(1.0) ? LS_R(1.0) : x1;
            const LS_REAL y2 = x2 > LS_R(1.0) ? LS_R(1.0) : x2;
            dt[0] = m->d_dead * (x0 < LS_R(-1.0) ? LS_R(-1.0) : y0);
            dt[1] = m->d_dead * (x1 < LS_R(-1.0) ? LS_R(-1.0) : y1);
            dt[2] = m->d_dead * (x2 < LS_R(-1.0) ? LS_R(-1.0) : y2);
            m->i_prev[0] = i0;
            m->i_prev[1] = i1;
            m->i_prev[2] = i2;
        } else {
            for (k = 0; k < 3; ++k) {
                if (LS_ISFINITE(i_abc[k])) { /* none for a non-finite current */
                    LS_REAL i_pred = i_abc[k];
                    if (m->have_prev) {
                        i_pred += m->cfg.dtc_lead * (i_abc[k] - m->i_prev[k]);
                    }
                    m->i_prev[k] = i_abc[k];
                    dt[k] = m->d_dead * ls_clamp(i_pred * m->inv_band, LS_R(-1.0), LS_R(1.0));
                }
            }
        }
    }
    if (!dtc && i_abc != NULL) { /* the residual estimate needs them too */
        for (k = 0; k < 3; ++k) {
            if (LS_ISFINITE(i_abc[k])) {
                m->i_prev[k] = i_abc[k];
            }
        }
    }
    m->have_prev = i_abc != NULL;
    v[0] = v_a;
    v[1] = LS_R(-0.5) * v_a + LS_R(0.5) * LS_SQRT3 * v_b;
    v[2] = LS_R(-0.5) * v_a - LS_R(0.5) * LS_SQRT3 * v_b;
    vmax = v[0] > v[1] ? v[0] : v[1];
    vmax = vmax > v[2] ? vmax : v[2];
    vmin = v[0] < v[1] ? v[0] : v[1];
    vmin = vmin < v[2] ? vmin : v[2];
    off = LS_R(-0.5) * (vmax + vmin);
    inv = LS_R(1.0) / v_dc;
    m->newest ^= 1u; /* this step's entry replaces the one of two steps ago */
    for (k = 0; k < 3; ++k) {
        LS_REAL d = LS_R(0.5) + (v[k] + off) * inv;
        if (dtc) {
            d += dt[k]; /* (+ 0, exact, for a non-finite current) */
        }
        clipped = clipped || d > LS_R(1.0) || d < LS_R(0.0);
        duty[k] = ls_clamp(d, LS_R(0.0), LS_R(1.0));
        m->hist_d[m->newest][k] = duty[k];
        m->hist_c[m->newest][k] = dt[k]; /* (0 without compensation) */
    }
    m->n_hist = m->n_hist < 2u ? m->n_hist + 1u : 2u;
    return clipped;
}

/* The dead-time voltage error, net of the compensation, that the inverter left in the PWM period
 * that has just ended: call with the currents sampled at its end, before ls_mod_step. Its duties
 * were computed two steps ago; each leg switches at (1 -+ d)/2 of the period, loses the dead time
 * at turn-on when its current flows out and gains it at turn-off when it flows in (duty error
 * -(t_dead f_pwm)(sign i_on + sign i_off)/2), with i_on and i_off interpolated between the
 * period's start current (i_prev) and end current (i_abc) plus the PWM ripple at the edges
 * (k_rip = T / L in 1/(H Hz), the phase inductance seen by the ripple; 0 ignores it). A leg that
 * does not switch (d = 0 or 1) has no error. Writes the alpha-beta voltage error (V) and returns
 * true, or writes 0 and returns false while the history is not complete. i_abc and v_dc must be
 * finite. (Used by ls_drive with hf_dtres; see linsense/ls_dtres.h.) */
static inline LS_REAL ls_mod_leg_error_(LS_REAL d, LS_REAL c, LS_REAL i0, LS_REAL i1, LS_REAL rip,
                                        LS_REAL d_dead)
{
    /* the edge currents are i_mid -+ s (s: half the edges' distance times the slope plus the ripple
     * at the edges); the two signs add to 2 sign(i_mid) when |i_mid| > |s|, else cancel; a leg at
     * 0 or 1 does not switch: no error, and no compensation reached it */
    const LS_REAL i_mid = LS_R(0.5) * (i0 + i1);
    const LS_REAL sp = LS_R(0.5) * d * (i1 - i0) + rip;
    const LS_REAL lost = LS_FABS(i_mid) > LS_FABS(sp) ? (i_mid > LS_R(0.0) ? d_dead : -d_dead) : LS_R(0.0);
    return d * (LS_R(1.0) - d) > LS_R(0.0) ? c - lost : LS_R(0.0);
}

static inline bool ls_mod_residual(const ls_mod *m, const LS_REAL i_abc[3], LS_REAL v_dc, LS_REAL k_rip,
                                   LS_REAL v_ab[2])
{
    const uint32_t old = m->newest ^ 1u; /* the entry of two steps ago (this step has not pushed yet) */
    /* (local copies: the loads are not repeated for fear of aliasing) */
    const LS_REAL d0 = m->hist_d[old][0], d1 = m->hist_d[old][1], d2 = m->hist_d[old][2];
    const LS_REAL kv = k_rip * v_dc, dm = (d0 + d1 + d2) * (LS_R(1.0) / LS_R(3.0));
    const LS_REAL k6 = kv * (LS_R(1.0) / LS_R(6.0)), kh = LS_R(0.5) * kv, dd = m->d_dead;
    LS_REAL e0, e1, e2;
    if (m->n_hist < 2u || !m->have_prev) {
        v_ab[0] = v_ab[1] = LS_R(0.0);
        return false;
    }
    /* the PWM ripple at leg k's edges: (V_dc T / L)(acc_k / 6 + (1 - d_k)(d_k - d_mean) / 2), acc_k the
     * sum over the other legs of max(0, d_j - d_k) (how long they are high before leg k rises) */
    {
        const LS_REAL p01 = d1 > d0 ? d1 - d0 : LS_R(0.0), p10 = d0 > d1 ? d0 - d1 : LS_R(0.0);
        const LS_REAL p02 = d2 > d0 ? d2 - d0 : LS_R(0.0), p20 = d0 > d2 ? d0 - d2 : LS_R(0.0);
        const LS_REAL p12 = d2 > d1 ? d2 - d1 : LS_R(0.0), p21 = d1 > d2 ? d1 - d2 : LS_R(0.0);
        const LS_REAL r0 = k6 * (p01 + p02) + kh * (LS_R(1.0) - d0) * (d0 - dm);
        const LS_REAL r1 = k6 * (p10 + p12) + kh * (LS_R(1.0) - d1) * (d1 - dm);
        const LS_REAL r2 = k6 * (p20 + p21) + kh * (LS_R(1.0) - d2) * (d2 - dm);
        e0 = ls_mod_leg_error_(d0, m->hist_c[old][0], m->i_prev[0], i_abc[0], r0, dd);
        e1 = ls_mod_leg_error_(d1, m->hist_c[old][1], m->i_prev[1], i_abc[1], r1, dd);
        e2 = ls_mod_leg_error_(d2, m->hist_c[old][2], m->i_prev[2], i_abc[2], r2, dd);
    }
    /* pole-voltage errors to alpha-beta (the common mode does not reach a floating star) */
    v_ab[0] = v_dc * (LS_R(2.0) * e0 - e1 - e2) * (LS_R(1.0) / LS_R(3.0));
    v_ab[1] = v_dc * (e1 - e2) * (LS_R(1.0) / LS_SQRT3);
    return true;
}

/* v_a, v_b: alpha-beta voltage reference (V); v_dc (V); i_abc: phase currents (A) for the
 * dead-time compensation (may be NULL when off). Writes duty[3] in [0, 1]. Returns true when
 * the reference was beyond the linear range (over-modulation clipped). */
static inline bool ls_mod_step(ls_mod *m, LS_REAL v_a, LS_REAL v_b, LS_REAL v_dc, const LS_REAL i_abc[3],
                               LS_REAL duty[3])
{
    return ls_mod_step_impl(m, v_a, v_b, v_dc, i_abc, duty, true);
}

/* ls_mod_step for finite v_a, v_b, v_dc and i_abc. */
static inline bool ls_mod_step_finite(ls_mod *m, LS_REAL v_a, LS_REAL v_b, LS_REAL v_dc,
                                      const LS_REAL i_abc[3], LS_REAL duty[3])
{
    return ls_mod_step_impl(m, v_a, v_b, v_dc, i_abc, duty, false);
}

#endif /* LINSENSE_LS_MODULATOR_H */
