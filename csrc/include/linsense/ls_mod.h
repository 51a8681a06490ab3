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
 * position estimate by several degrees (measured with the simulator). ls_mod_step_ripple_finite
 * also puts each leg's two edges apart by the PWM ripple (cfg.l_ripple): a small current that
 * straddles zero between them loses no dead time (the square wave's relay band, docs/theory.md).
 */
#ifndef LINSENSE_LS_MOD_H
#define LINSENSE_LS_MOD_H

#include "linsense/ls_types.h"

typedef struct {
    LS_REAL f_pwm;     /* Hz, switching frequency, > 0 */
    LS_REAL dead_time; /* s, inverter dead time, >= 0 and < 0.1 / f_pwm */
    bool dtc;          /* dead-time compensation on */
    LS_REAL i_band;    /* A, current band of the smooth sign used by the compensation, > 0 */
    LS_REAL dtc_lead;  /* -, periods of current extrapolation for the compensation sign, [-1, 4]
                          (-0.5 with the square wave at fs/2, whose current change reverses every
                          period: the middle of the next period is then i - (i - i_prev)/2) */
    LS_REAL l_ripple;  /* H, >= 0: the phase inductance of the PWM current ripple that
                          ls_mod_step_ripple_finite puts on each leg's two edges (0: both edges at
                          the predicted current; ls_mod_step and ls_mod_step_finite ignore it) */
} ls_mod_cfg;

/* One step's duties as the inverter applies them, and the compensation they contain. */
typedef struct {
    LS_REAL d[3]; /* -, duties */
    LS_REAL c[3]; /* -, their dead-time compensation (0 without) */
} ls_mod_hist;

typedef struct {
    ls_mod_cfg cfg;    /* copy of the configuration */
    LS_REAL d_dead;    /* -, duty equivalent of the dead time */
    LS_REAL t_pwm;     /* s, the period 1 / f_pwm */
    LS_REAL i_prev[3]; /* A, phase currents of the previous step (for the extrapolation) */
    bool have_prev;    /* i_prev is valid */
    LS_REAL inv_band;  /* 1/A, 1 / i_band */
    LS_REAL k_now;     /* 1/A, (1 + dtc_lead) / i_band: i_pred / i_band = k_now i - k_prev i_prev */
    LS_REAL k_prev;    /* 1/A, dtc_lead / i_band */
    LS_REAL k_rip;     /* 1/(A V), T / (l_ripple i_band): the ripple in bands per volt of bus (0: none) */
    ls_mod_hist hist[2]; /* the last two steps ([newest] and [newest ^ 1]); after a reset, legs
                          * that did not switch (d = 0) */
    uint32_t newest;     /* -, index of the last step's entry (0 or 1) */
} ls_mod;

ls_status ls_mod_init(ls_mod *m, const ls_mod_cfg *cfg);
void ls_mod_reset(ls_mod *m);
/* The step is inline (called every PWM period). ls_mod_step_finite is ls_mod_step for finite
 * v_a, v_b, v_dc and i_abc (the drive checks them), without those guards; ls_mod_step_impl is
 * the implementation of both. */
/* The compensation of leg k on the general path (no previous current, or a check of it): none for
 * a non-finite current. */
static inline LS_REAL ls_mod_dtc_leg_(ls_mod *m, int k, LS_REAL i)
{
    LS_REAL i_pred = i;
    if (!LS_ISFINITE(i)) {
        return LS_R(0.0);
    }
    if (m->have_prev) {
        i_pred += m->cfg.dtc_lead * (i - m->i_prev[k]);
    }
    m->i_prev[k] = i;
    return m->d_dead * ls_clamp(i_pred * m->inv_band, LS_R(-1.0), LS_R(1.0));
}

static inline bool ls_mod_step_impl(ls_mod *m, LS_REAL v_a, LS_REAL v_b, LS_REAL v_dc,
                                    const LS_REAL i_abc[3], LS_REAL duty[3], bool check)
{
    LS_REAL v[3], vmax, vmin, off, inv;
    LS_REAL dt0 = LS_R(0.0), dt1 = LS_R(0.0), dt2 = LS_R(0.0); /* (scalars: an array would live in memory) */
    const bool dtc = m->cfg.dtc && i_abc != NULL;
    bool clipped;
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
    if (dtc) {
        if (m->have_prev && (!check || LS_ISFINITE3(i_abc[0], i_abc[1], i_abc[2]))) {
            /* x = i_pred / i_band with i_pred = i + lead (i - i_prev); the three legs written out on
             * local copies (stores to i_prev would otherwise make the compiler reload i_abc) */
            const LS_REAL ka = m->k_now, kb = m->k_prev;
            const LS_REAL i0 = i_abc[0], i1 = i_abc[1], i2 = i_abc[2];
            const LS_REAL x0 = ka * i0 - kb * m->i_prev[0];
            const LS_REAL x1 = ka * i1 - kb * m->i_prev[1];
            const LS_REAL x2 = ka * i2 - kb * m->i_prev[2];
            /* = ls_clamp(x, -1, 1), in a form compilers select without branching (the HF current
             * crosses zero twice per injection period: a branch on it mispredicts) */
            const LS_REAL y0 = x0 > LS_R(1.0) ? LS_R(1.0) : x0, y1 = x1 > LS_R(1.0) ? LS_R(1.0) : x1;
            const LS_REAL y2 = x2 > LS_R(1.0) ? LS_R(1.0) : x2;
            dt0 = m->d_dead * (x0 < LS_R(-1.0) ? LS_R(-1.0) : y0);
            dt1 = m->d_dead * (x1 < LS_R(-1.0) ? LS_R(-1.0) : y1);
            dt2 = m->d_dead * (x2 < LS_R(-1.0) ? LS_R(-1.0) : y2);
            m->i_prev[0] = i0;
            m->i_prev[1] = i1;
            m->i_prev[2] = i2;
        } else {
            dt0 = ls_mod_dtc_leg_(m, 0, i_abc[0]);
            dt1 = ls_mod_dtc_leg_(m, 1, i_abc[1]);
            dt2 = ls_mod_dtc_leg_(m, 2, i_abc[2]);
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
    {
        /* this step's entry replaces the one of two steps ago */
        ls_mod_hist *h = &m->hist[m->newest ^= 1u];
        const LS_REAL d0 = LS_R(0.5) + (v[0] + off) * inv + dt0; /* (+ 0, exact, without compensation) */
        const LS_REAL d1 = LS_R(0.5) + (v[1] + off) * inv + dt1;
        const LS_REAL d2 = LS_R(0.5) + (v[2] + off) * inv + dt2;
        clipped = d0 > LS_R(1.0) || d0 < LS_R(0.0) || d1 > LS_R(1.0) || d1 < LS_R(0.0) || d2 > LS_R(1.0) ||
                  d2 < LS_R(0.0);
        h->d[0] = duty[0] = ls_clamp(d0, LS_R(0.0), LS_R(1.0));
        h->d[1] = duty[1] = ls_clamp(d1, LS_R(0.0), LS_R(1.0));
        h->d[2] = duty[2] = ls_clamp(d2, LS_R(0.0), LS_R(1.0));
        h->c[0] = dt0;
        h->c[1] = dt1;
        h->c[2] = dt2;
    }
    return clipped;
}

/* Both residual models' last step: the legs' net duty errors e0..e2 of the period whose duties h
 * holds to the alpha-beta voltage error (V) in v_ab. A leg at 0 or 1 does not switch: no error, and
 * no compensation reached it (one test for the usual case, every leg switching; the duties are
 * finite: ls_drive trips and resets the modulator on a non-finite one). The common mode does not
 * reach a floating star. */
static inline void ls_mod_error_ab_(const ls_mod_hist *h, LS_REAL e0, LS_REAL e1, LS_REAL e2, LS_REAL v_dc,
                                    LS_REAL v_ab[2])
{
    const LS_REAL d0 = h->d[0], d1 = h->d[1], d2 = h->d[2];
    const LS_REAL lo01 = d0 < d1 ? d0 : d1, hi01 = d0 > d1 ? d0 : d1;
    const LS_REAL lo = lo01 < d2 ? lo01 : d2, hi = hi01 > d2 ? hi01 : d2;
    if (!((lo > LS_R(0.0)) & (hi < LS_R(1.0)))) { /* (&: one branch, on both) */
        e0 = d0 * (LS_R(1.0) - d0) > LS_R(0.0) ? e0 : LS_R(0.0);
        e1 = d1 * (LS_R(1.0) - d1) > LS_R(0.0) ? e1 : LS_R(0.0);
        e2 = d2 * (LS_R(1.0) - d2) > LS_R(0.0) ? e2 : LS_R(0.0);
    }
    v_ab[0] = v_dc * (LS_R(2.0) * e0 - e1 - e2) * (LS_R(1.0) / LS_R(3.0));
    v_ab[1] = v_dc * (e1 - e2) * (LS_R(1.0) / LS_SQRT3);
}

/* ls_mod_residual's inputs with the legs in the order of their duties (a the largest: the legs o0, o1,
 * o2 of the period) and its outputs in that order. */
typedef struct {
    LS_REAL gaa, gbb, gcc, gab, gac, gbc; /* 1/H, G's entries */
    LS_REAL ia, ib, ic;                   /* A, the start currents */
    LS_REAL ja, jb, jc;                   /* A, their change over the period */
    LS_REAL ea, eb, ec;                   /* A/s, the back-EMF's share */
    LS_REAL da, db, dc;                   /* -, the duties */
} ls_mod_fwd_in_;

/* The legs' order by duty (o0 the largest; ties as ls_mod_residual has always sorted them) as one of
 * six: 0 (0 1 2), 1 (0 2 1), 2 (2 0 1), 3 (1 0 2), 4 (1 2 0), 5 (2 1 0). */
static inline unsigned ls_mod_order_(LS_REAL d0, LS_REAL d1, LS_REAL d2)
{
    if (d1 > d0) {
        return d2 > d0 ? (d2 > d1 ? 5u : 4u) : 3u;
    }
    return d2 > d1 ? (d2 > d0 ? 2u : 1u) : 0u;
}

/* The sorted inputs of the order (o0, o1, o2). */
#define LS_MOD_GATHER_(x, A, B, C)                                                                             \
    do {                                                                                                       \
        (x).gaa = g[A];                                                                                        \
        (x).gbb = g[B];                                                                                        \
        (x).gcc = g[C];                                                                                        \
        (x).gab = g[(A) + (B) + 2];                                                                            \
        (x).gac = g[(A) + (C) + 2];                                                                            \
        (x).gbc = g[(B) + (C) + 2];                                                                            \
        (x).ia = m->i_prev[A];                                                                                 \
        (x).ib = m->i_prev[B];                                                                                 \
        (x).ic = m->i_prev[C];                                                                                 \
        (x).ja = i_abc[A] - (x).ia;                                                                            \
        (x).jb = i_abc[B] - (x).ib;                                                                            \
        (x).jc = i_abc[C] - (x).ic;                                                                            \
        (x).ea = ge[A];                                                                                        \
        (x).eb = ge[B];                                                                                        \
        (x).ec = ge[C];                                                                                        \
        (x).da = h->d[A];                                                                                      \
        (x).db = h->d[B];                                                                                      \
        (x).dc = h->d[C];                                                                                      \
    } while (0)

/* The dead-time voltage error, net of the compensation, that the inverter left in the PWM period
 * that has just ended, by a forward model of that period: call with the currents sampled at its
 * end (i_abc), before ls_mod_step (i_prev is then the period's start current; its duties are the
 * entry of two steps ago). From the start currents the six edges run in their order (the legs
 * sorted by duty; centre-aligned: turn-on from the largest duty down, turn-off back up), the phase
 * currents advanced between them by the poles' voltage through g, the phase inverse-inductance
 * matrix G_kj = r_k' L^-1 r_j (1/H, [aa, bb, cc, ab, ac, bc]: ls_dtres_phase_g; its rows sum to 0),
 * less the resistive drop (2/3) R_s G i with the current taken as linear between the two samples
 * and less the back-EMF's share ge (A/s, phases: r_k' L^-1 e, ls_dtres_phase_g; constant over the
 * period: without it the model's currents drift from the measured ones by e T / L per period at
 * speed and mispredict the edges where a current is small).
 * At each edge both switches of the leg are off for the dead time and the diode the current picks
 * holds the pole: a turn-on loses the dead time when the leg's current flows out (i > 0), a
 * turn-off gains it when the current flows in; the volt-seconds act on all three currents from
 * there, so that each edge's current carries the losses of the edges before it and the PWM ripple
 * with the motor's saliency and end effect (docs/simulator.md, "Dead time and the closed loop").
 * The leg's duty error is c - t_dead f_pwm (L_on + L_off - 1), L = 1 where the current at the edge
 * flows out (c: the compensation it carried); a leg that does not switch (d = 0 or 1) has none.
 * Writes the alpha-beta voltage error (V) and, where i_end is not NULL, the end currents the model
 * predicts and the resistive drop within that prediction (A, phases; for ls_dtres_adapt; the
 * back-EMF's share is in i_end, not in i_drop), and returns true, or writes 0 and returns false
 * without the previous step's currents. i_abc, v_dc, g and ge must be finite. (Used by ls_drive with
 * hf_dtres; see linsense/ls_dtres.h.) The build for speed gathers the legs in their order from
 * constant places (one of six orders: no address computed per value); the build for size by index:
 * the same values, so the same numbers. */
static inline bool ls_mod_residual(const ls_mod *m, const LS_REAL i_abc[3], LS_REAL v_dc, const LS_REAL g[6],
                                   const LS_REAL ge[3], LS_REAL r_s, LS_REAL v_ab[2], LS_REAL i_end[3],
                                   LS_REAL i_drop[3])
{
    const ls_mod_hist *h = &m->hist[m->newest ^ 1u];
    ls_mod_fwd_in_ x;
    LS_REAL e[3];
    int o0, o1, o2;
    if (!m->have_prev) {
        v_ab[0] = v_ab[1] = LS_R(0.0);
        if (i_end != NULL) {
            i_end[0] = i_end[1] = i_end[2] = LS_R(0.0);
            i_drop[0] = i_drop[1] = i_drop[2] = LS_R(0.0);
        }
        return false;
    }
    const unsigned order = ls_mod_order_(h->d[0], h->d[1], h->d[2]); /* o0 the largest duty, o2 the smallest */
    o0 = order == 2u || order == 5u ? 2 : (order >= 3u ? 1 : 0);
    o2 = order == 4u || order == 5u ? 0 : (order == 1u || order == 2u ? 1 : 2);
    o1 = 3 - o0 - o2;
#ifdef __OPTIMIZE_SIZE__
    LS_MOD_GATHER_(x, o0, o1, o2);
#else
    switch (order) {
    case 0u: LS_MOD_GATHER_(x, 0, 1, 2); break;
    case 1u: LS_MOD_GATHER_(x, 0, 2, 1); break;
    case 2u: LS_MOD_GATHER_(x, 2, 0, 1); break;
    case 3u: LS_MOD_GATHER_(x, 1, 0, 2); break;
    case 4u: LS_MOD_GATHER_(x, 1, 2, 0); break;
    default: LS_MOD_GATHER_(x, 2, 1, 0); break;
    }
#endif
    {
        /* in the sorted order (a = o0, b = o1, c = o2) */
        const LS_REAL T = m->t_pwm;
        const LS_REAL kv = LS_R(2.0) / LS_R(3.0) * v_dc, kr = LS_R(2.0) / LS_R(3.0) * r_s;
        const LS_REAL kd = kv * m->cfg.dead_time; /* a whole dead time's volt-seconds, per unit of G */
        const LS_REAL gaa = x.gaa, gbb = x.gbb, gcc = x.gcc, gab = x.gab, gac = x.gac, gbc = x.gbc;
        const LS_REAL ia = x.ia, ib = x.ib, ic = x.ic, ja = x.ja, jb = x.jb, jc = x.jc;
        /* the resistive drop (A) to time t: (r_k + s_k t) t, the current linear between the samples */
        const LS_REAL kh = LS_R(0.5) * kr * m->cfg.f_pwm;
        const LS_REAL ra = kr * (gaa * ia + gab * ib + gac * ic), rb = kr * (gab * ia + gbb * ib + gbc * ic);
        const LS_REAL rc = kr * (gac * ia + gbc * ib + gcc * ic);
        /* with the back-EMF's share (A/s) */
        const LS_REAL qa = ra + x.ea, qb = rb + x.eb, qc = rc + x.ec;
        const LS_REAL sa = kh * (gaa * ja + gab * jb + gac * jc), sb = kh * (gab * ja + gbb * jb + gbc * jc);
        const LS_REAL sc = kh * (gac * ja + gbc * jb + gcc * jc);
        const LS_REAL da = x.da, db = x.db, dc = x.dc;
        /* the segments: all low before the first edge and after the last ((1 - da) T / 2 each), a
         * alone high (u1, twice), a and b high (u2, twice), all high (u3); the edges at t1 .. t6 */
        const LS_REAL u1 = LS_R(0.5) * (da - db) * T, u2 = LS_R(0.5) * (db - dc) * T, u3 = dc * T;
        const LS_REAL t1 = LS_R(0.5) * (LS_R(1.0) - da) * T, t2 = t1 + u1, t3 = t2 + u2, t5 = t3 + u3 + u2;
        const LS_REAL t6 = t5 + u1;
        /* the current gained over u1 (a high: G_ka) and over u2 (a and b high: -G_kc) */
        const LS_REAL ka = kv * u1, kb = -kv * u2;
        LS_REAL l1, l2, l3, l4, l5, l6, i3, la, lb, lc;
        /* a on (the others low): the dead time lost with its current flowing out */
        l1 = ia - (qa + sa * t1) * t1 > LS_R(0.0) ? LS_R(1.0) : LS_R(0.0);
        /* b on (a high), after a's loss */
        l2 = ib - (qb + sb * t2) * t2 + gab * (ka - kd * l1) > LS_R(0.0) ? LS_R(1.0) : LS_R(0.0);
        /* c on and off (a and b high); the turn-off after the turn-on's own loss (the turn-off keeps
         * the pole low with the current flowing out: l = 1, high for the dead time otherwise) */
        i3 = ic - (qc + sc * t3) * t3 + gac * (ka - kd * l1) + gcc * kb - gbc * kd * l2;
        l3 = i3 > LS_R(0.0) ? LS_R(1.0) : LS_R(0.0);
        l4 = i3 - (qc + sc * (LS_R(2.0) * t3 + u3)) * u3 - gcc * kd * l3 > LS_R(0.0) ? LS_R(1.0) : LS_R(0.0);
        lc = l3 + l4 - LS_R(1.0); /* c's lost high time, in dead times (-1: gained) */
        /* b off (a high): two u2 segments, c's edges between */
        l5 = ib - (qb + sb * t5) * t5 + gab * (ka - kd * l1) + LS_R(2.0) * kb * gbc - kd * (gbb * l2 + gbc * lc) >
                     LS_R(0.0)
                 ? LS_R(1.0)
                 : LS_R(0.0);
        lb = l2 + l5 - LS_R(1.0);
        /* a off (the others low) */
        l6 = ia - (qa + sa * t6) * t6 + LS_R(2.0) * (ka * gaa + kb * gac) - kd * (gaa * l1 + gab * lb + gac * lc) >
                     LS_R(0.0)
                 ? LS_R(1.0)
                 : LS_R(0.0);
        la = l1 + l6 - LS_R(1.0);
        if (i_end != NULL) { /* the end currents the model predicts (ls_dtres_adapt) */
            i_end[o0] = ia - (qa + sa * T) * T + LS_R(2.0) * (ka * gaa + kb * gac) -
                        kd * (gaa * la + gab * lb + gac * lc);
            i_end[o1] = ib - (qb + sb * T) * T + LS_R(2.0) * (ka * gab + kb * gbc) -
                        kd * (gab * la + gbb * lb + gbc * lc);
            i_end[o2] = ic - (qc + sc * T) * T + LS_R(2.0) * (ka * gac + kb * gcc) -
                        kd * (gac * la + gbc * lb + gcc * lc);
            i_drop[o0] = (ra + sa * T) * T;
            i_drop[o1] = (rb + sb * T) * T;
            i_drop[o2] = (rc + sc * T) * T;
        }
        e[o0] = la;
        e[o1] = lb;
        e[o2] = lc;
    }
    /* each leg's duty error: its compensation less the high time lost */
    ls_mod_error_ab_(h, h->c[0] - m->d_dead * e[0], h->c[1] - m->d_dead * e[1], h->c[2] - m->d_dead * e[2], v_dc,
                     v_ab);
    return true;
}

/* ls_mod_residual by interpolation (the cheaper model, dtres.forward = false): the dead-time
 * voltage error, net of the compensation, that the inverter left in the PWM period that has just
 * ended: call with the currents sampled at its end, before ls_mod_step. Its duties
 * were computed two steps ago; each leg switches at (1 -+ d)/2 of the period, loses the dead time
 * at turn-on when its current flows out and gains it at turn-off when it flows in (duty error
 * -(t_dead f_pwm)(sign i_on + sign i_off)/2), with i_on and i_off interpolated between the
 * period's start current (i_prev) and end current (i_abc) plus the PWM ripple at the edges
 * (k_rip = T / L in 1/(H Hz), the phase inductance seen by the ripple; 0 ignores it). A leg that
 * does not switch (d = 0 or 1) has no error (after a reset, the history holds legs that did not
 * switch). Writes the alpha-beta voltage error (V) and returns true, or writes 0 and returns false
 * without the previous step's currents. i_abc and v_dc must be
 * finite. (Used by ls_drive with hf_dtres; see linsense/ls_dtres.h.) */
static inline LS_REAL ls_mod_lost_(LS_REAL d, LS_REAL i0, LS_REAL i1, LS_REAL rip2, LS_REAL d_dead)
{
    /* the duty the dead time took from a switching leg: the edge currents are i_mid -+ s (s: half
     * the edges' distance times the slope plus the ripple at the edges); the two signs add to
     * 2 sign(i_mid) when |i_mid| > |s|, else cancel (here on twice the currents: i_sum = 2 i_mid,
     * s2 = 2 s) */
    const LS_REAL i_sum = i0 + i1;
    const LS_REAL s2 = d * (i1 - i0) + rip2;
    return LS_FABS(i_sum) > LS_FABS(s2) ? (i_sum > LS_R(0.0) ? d_dead : -d_dead) : LS_R(0.0);
}

static inline bool ls_mod_residual_interp(const ls_mod *m, const LS_REAL i_abc[3], LS_REAL v_dc, LS_REAL k_rip,
                                          LS_REAL v_ab[2])
{
    /* the entry of two steps ago (this step has not pushed yet); local copies: the loads are not
     * repeated for fear of aliasing */
    const ls_mod_hist *h = &m->hist[m->newest ^ 1u];
    const LS_REAL d0 = h->d[0], d1 = h->d[1], d2 = h->d[2];
    LS_REAL e0, e1, e2;
    if (!m->have_prev) {
        v_ab[0] = v_ab[1] = LS_R(0.0);
        return false;
    }
    /* twice the PWM ripple at leg k's edges: with V_dc T / L = k_rip v_dc and d_mean the mean duty,
     *   r_k = (V_dc T / L)(acc_k / 6 + (1 - d_k)(d_k - d_mean) / 2),
     * acc_k the sum over the other legs of max(0, d_j - d_k) (how long they are high before leg k
     * rises); with max(0, x) = (x + |x|) / 2 this is
     *   2 r_k = (V_dc T / L)((d_mean - d_k)(d_k - 1/2) + A_k / 6),  A_k = sum_j |d_j - d_k| */
    {
        const LS_REAL kv = k_rip * v_dc;
        const LS_REAL dm = (d0 + d1 + d2) * (LS_R(1.0) / LS_R(3.0));
        const LS_REAL a01 = LS_FABS(d0 - d1) * (LS_R(1.0) / LS_R(6.0));
        const LS_REAL a02 = LS_FABS(d0 - d2) * (LS_R(1.0) / LS_R(6.0));
        const LS_REAL a12 = LS_FABS(d1 - d2) * (LS_R(1.0) / LS_R(6.0));
        const LS_REAL r0 = kv * ((dm - d0) * (d0 - LS_R(0.5)) + (a01 + a02));
        const LS_REAL r1 = kv * ((dm - d1) * (d1 - LS_R(0.5)) + (a01 + a12));
        const LS_REAL r2 = kv * ((dm - d2) * (d2 - LS_R(0.5)) + (a02 + a12));
        const LS_REAL dd = m->d_dead;
        e0 = h->c[0] - ls_mod_lost_(d0, m->i_prev[0], i_abc[0], r0, dd);
        e1 = h->c[1] - ls_mod_lost_(d1, m->i_prev[1], i_abc[1], r1, dd);
        e2 = h->c[2] - ls_mod_lost_(d2, m->i_prev[2], i_abc[2], r2, dd);
    }
    ls_mod_error_ab_(h, e0, e1, e2, v_dc, v_ab);
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

/* ls_mod_step_finite with each leg's two edges apart by the PWM ripple in the dead-time
 * compensation (cfg.l_ripple; with 0 it is ls_mod_step_finite): the current at leg k's turn-on
 * edge (1 - d_k) T/2 lies s_k = (V_dc T / L)((d_k - d_mean)/4 + A_k/12) below the predicted
 * mid-period current i_pred and the turn-off edge as far above (the average ramp and the PWM
 * ripple; d the duties before the compensation, d_mean their mean, A_k = sum_j |d_j - d_k|, as in
 * the residual's first-order ripple), and each edge loses or gains the dead time by its own sign. A phase current
 * within s_k of zero loses nothing at either edge; where s_k differs between the square wave's two
 * half periods, a current between the two loses the dead time in one of them only, in step with
 * the carrier (docs/theory.md, "The dead time and the square wave"). The compensation is then
 * t_dead f_pwm (sat((i_pred - s_k)/i_band) + sat((i_pred + s_k)/i_band))/2 instead of
 * t_dead f_pwm sat(i_pred/i_band); it replaces the one ls_mod_step_finite added (a clamped leg
 * keeps it). Separate from ls_mod_step_finite so that its callers compile without it. */
static inline bool ls_mod_step_ripple_finite(ls_mod *m, LS_REAL v_a, LS_REAL v_b, LS_REAL v_dc,
                                             const LS_REAL i_abc[3], LS_REAL duty[3])
{
    const bool rip = m->cfg.dtc && m->have_prev && m->k_rip > LS_R(0.0);
    /* the predicted currents in bands, before the step replaces i_prev */
    const LS_REAL x0 = m->k_now * i_abc[0] - m->k_prev * m->i_prev[0];
    const LS_REAL x1 = m->k_now * i_abc[1] - m->k_prev * m->i_prev[1];
    const LS_REAL x2 = m->k_now * i_abc[2] - m->k_prev * m->i_prev[2];
    bool clipped = ls_mod_step_impl(m, v_a, v_b, v_dc, i_abc, duty, false);
    ls_mod_hist *h = &m->hist[m->newest]; /* the entry the step has just written */
    const LS_REAL c0 = h->c[0], c1 = h->c[1], c2 = h->c[2];
    const LS_REAL d0 = duty[0], d1 = duty[1], d2 = duty[2];
    if (rip && d0 > LS_R(0.0) && d0 < LS_R(1.0) && d1 > LS_R(0.0) && d1 < LS_R(1.0) && d2 > LS_R(0.0) &&
        d2 < LS_R(1.0)) { /* (a leg clamped at 0 or 1 keeps what the step gave it: rare) */
        const LS_REAL b0 = d0 - c0, b1 = d1 - c1, b2 = d2 - c2; /* the duties without compensation */
        const LS_REAL kv = m->k_rip * v_dc;
        const LS_REAL dm = (b0 + b1 + b2) * (LS_R(1.0) / LS_R(3.0));
        const LS_REAL a01 = LS_FABS(b0 - b1) * (LS_R(1.0) / LS_R(12.0));
        const LS_REAL a02 = LS_FABS(b0 - b2) * (LS_R(1.0) / LS_R(12.0));
        const LS_REAL a12 = LS_FABS(b1 - b2) * (LS_R(1.0) / LS_R(12.0));
        const LS_REAL s0 = kv * ((b0 - dm) * LS_R(0.25) + a01 + a02);
        const LS_REAL s1 = kv * ((b1 - dm) * LS_R(0.25) + a01 + a12);
        const LS_REAL s2 = kv * ((b2 - dm) * LS_R(0.25) + a02 + a12);
        const LS_REAL hd = LS_R(0.5) * m->d_dead;
        const LS_REAL n0 = hd * (ls_clamp(x0 - s0, LS_R(-1.0), LS_R(1.0)) + ls_clamp(x0 + s0, LS_R(-1.0), LS_R(1.0)));
        const LS_REAL n1 = hd * (ls_clamp(x1 - s1, LS_R(-1.0), LS_R(1.0)) + ls_clamp(x1 + s1, LS_R(-1.0), LS_R(1.0)));
        const LS_REAL n2 = hd * (ls_clamp(x2 - s2, LS_R(-1.0), LS_R(1.0)) + ls_clamp(x2 + s2, LS_R(-1.0), LS_R(1.0)));
        const LS_REAL e0 = b0 + n0, e1 = b1 + n1, e2 = b2 + n2;
        clipped = clipped || e0 > LS_R(1.0) || e0 < LS_R(0.0) || e1 > LS_R(1.0) || e1 < LS_R(0.0) ||
                  e2 > LS_R(1.0) || e2 < LS_R(0.0);
        h->d[0] = duty[0] = ls_clamp(e0, LS_R(0.0), LS_R(1.0));
        h->d[1] = duty[1] = ls_clamp(e1, LS_R(0.0), LS_R(1.0));
        h->d[2] = duty[2] = ls_clamp(e2, LS_R(0.0), LS_R(1.0));
        h->c[0] = n0;
        h->c[1] = n1;
        h->c[2] = n2;
    }
    return clipped;
}

#endif /* LINSENSE_LS_MOD_H */
