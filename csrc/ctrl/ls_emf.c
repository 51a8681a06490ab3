/* The extended-EMF position error in the estimated frame (see linsense/ls_emf.h). */
#include "linsense/ls_emf.h"
#include "linsense/ls_dtres.h"
#include "linsense/ls_math.h"

/* The flux harmonics' fields: each order 0 (none) or n mod 3 != 0 up to LS_EMF_HARM_ORDER_MAX,
 * its coefficient finite and at most LS_EMF_HARM_MAX psi_pm (0 without an order). */
static bool harmonics_ok(const ls_emf_cfg *cfg)
{
    int k;
    for (k = 0; k < LS_EMF_HARM_N; ++k) {
        const uint32_t n = cfg->harm_order[k];
        const LS_REAL re = cfg->harm_re[k], im = cfg->harm_im[k];
        const LS_REAL lim = LS_EMF_HARM_MAX * cfg->psi_pm;
        if (!LS_ISFINITE2(re, im) || n > LS_EMF_HARM_ORDER_MAX || (n != 0u && (n % 3u == 0u || n == 1u)) ||
            (n == 0u && (re != LS_R(0.0) || im != LS_R(0.0))) || !(re * re + im * im <= lim * lim)) {
            return false;
        }
    }
    return true;
}

/* z^n for the unit complex z = (c, s), n >= 1 (n - 1 products). */
static void unit_power(LS_REAL c, LS_REAL s, uint32_t n, LS_REAL *pc, LS_REAL *ps)
{
    LS_REAL a = c, b = s;
    uint32_t k;
    for (k = 1u; k < n; ++k) {
        const LS_REAL t = a * c - b * s;
        b = a * s + b * c;
        a = t;
    }
    *pc = a;
    *ps = b;
}

ls_status ls_emf_init(ls_emf *e, const ls_emf_cfg *cfg)
{
    LS_REAL ts, a, q;
    if (e == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!LS_ISFINITE4(cfg->fs, cfg->r_s, cfg->l_d, cfg->l_q) ||
        !LS_ISFINITE3(cfg->f_lpf, cfg->omega_max, cfg->err_r) ||
        !LS_ISFINITE3(cfg->err_l, cfg->u_err, cfg->i_noise) || !(cfg->fs > LS_R(0.0)) ||
        cfg->r_s < LS_R(0.0) || !(cfg->l_d > LS_R(0.0)) || !(cfg->l_q > LS_R(0.0)) ||
        !(cfg->f_lpf > LS_R(0.0)) || !(cfg->f_lpf <= LS_EMF_FLPF_FS_MAX * cfg->fs) ||
        !(cfg->omega_max > LS_R(0.0)) || !(cfg->omega_max <= LS_EMF_OMEGA_TS_MAX * cfg->fs) ||
        cfg->err_r < LS_R(0.0) || cfg->err_r > LS_EMF_ERR_REL_MAX || cfg->err_l < LS_R(0.0) ||
        cfg->err_l > LS_EMF_ERR_REL_MAX || cfg->u_err < LS_R(0.0) || cfg->i_noise < LS_R(0.0)) {
        return LS_ERR_PARAM;
    }
    /* the magnets' imbalance: a finite flux, a ratio below LS_EMF_NEG_MAX with a flux to scale it, a
     * bounded phase (the two comparisons refuse NaN and infinities themselves; k_neg below is then
     * at most psi_pm LS_EMF_NEG_MAX: finite) */
    if (!LS_ISFINITE(cfg->psi_pm) || cfg->psi_pm < LS_R(0.0) || !(LS_FABS(cfg->pm_shift) <= LS_EMF_PM_SHIFT_MAX) ||
        !(cfg->neg_re * cfg->neg_re + cfg->neg_im * cfg->neg_im < LS_EMF_NEG_MAX * LS_EMF_NEG_MAX) ||
        ((cfg->neg_re != LS_R(0.0) || cfg->neg_im != LS_R(0.0)) && !(cfg->psi_pm > LS_R(0.0)))) {
        return LS_ERR_PARAM;
    }
    if (!harmonics_ok(cfg)) {
        return LS_ERR_PARAM;
    }
    ts = LS_R(1.0) / cfg->fs;
    a = LS_R(1.0) - ls_exp(-(LS_TWO_PI * cfg->f_lpf * ts));
    /* the low-passed EMF's noise from a white current noise sigma per sample and axis: the
     * inductive drop l_d fs (i1 - i0) through the low-pass, sum of its squared impulse response
     * a^2 + a^3 / (2 - a), and the resistive drop r_s (i0 + i1) / 2, sum (a^2 + a (2 - a)) / 4 =
     * a / 2 (the sums' square roots added: a bound) */
    q = a / (LS_R(2.0) - a);
    e->cfg = *cfg;
    e->alpha = a;
    e->l_fs = cfg->l_d * cfg->fs;
    e->half_ts = LS_R(0.5) * ts;
    e->w_c = LS_TWO_PI * cfg->f_lpf;
    e->w_rip = LS_R(0.5) * LS_R(1.41421356237) * e->w_c;
    e->b_noise = LS_R(3.0) * cfg->i_noise *
                 (e->l_fs * a * LS_SQRT(LS_R(1.0) + q) + cfg->r_s * LS_SQRT(LS_R(0.5) * a));
    /* the negative sequence's flux psi_pm e^{j pm_shift} n (docs/theory.md section 10) */
    ls_sincos_full(cfg->pm_shift, &e->c_pm, &e->s_pm);
    e->k_neg[0] = cfg->psi_pm * (e->c_pm * cfg->neg_re - e->s_pm * cfg->neg_im);
    e->k_neg[1] = cfg->psi_pm * (e->c_pm * cfg->neg_im + e->s_pm * cfg->neg_re);
    e->pm_comp = cfg->pm_shift != LS_R(0.0) || cfg->neg_re != LS_R(0.0) || cfg->neg_im != LS_R(0.0);
    e->harm_on = false;
    {
        int k;
        for (k = 0; k < LS_EMF_HARM_N; ++k) {
            const uint32_t n = cfg->harm_order[k];
            e->harm_m[k] = n == 0u ? LS_R(0.0) : (n % 3u == 1u ? (LS_REAL)n : -(LS_REAL)n);
            e->harm_on = e->harm_on || n != 0u;
        }
    }
    if (!LS_ISFINITE4(e->alpha, e->l_fs, e->half_ts, e->b_noise) || !LS_ISFINITE2(e->w_c, e->w_rip) ||
        !(a > LS_R(0.0))) {
        return LS_ERR_PARAM; /* (an inductance or a noise so large that the products overflow) */
    }
    ls_emf_reset(e);
    return LS_OK;
}

void ls_emf_reset(ls_emf *e)
{
    e->i0[0] = LS_R(0.0);
    e->i0[1] = LS_R(0.0);
    e->primed = false;
    e->e_d = LS_R(0.0);
    e->e_q = LS_R(0.0);
    e->i_d = LS_R(0.0);
    e->i_q = LS_R(0.0);
    e->mag = LS_R(0.0);
    e->eps = LS_R(0.0);
    e->bound = LS_R(0.5) * LS_PI;
}

LS_REAL ls_emf_bound(const ls_emf *e, LS_REAL mag, LS_REAL i_par, LS_REAL i_perp, LS_REAL omega, LS_REAL k_r)
{
    const ls_emf_cfg *c = &e->cfg;
    /* (k_r within ls_dtres's range: a negative scale would make the bound negative) */
    const LS_REAL ra = c->err_r * ls_clamp(k_r, LS_DTRES_KR_MIN, LS_DTRES_KR_MAX) * c->r_s, xb = c->err_l * c->l_q * LS_FABS(omega);
    const LS_REAL i_mag = LS_SQRT(i_par * i_par + i_perp * i_perp);
    /* the inverter's error follows the current (all of it across e without a current) */
    const LS_REAL share = i_mag > LS_R(1e-9) ? i_perp / i_mag : LS_R(1.0);
    const LS_REAL rip = e->w_rip / (e->w_c + LS_R(6.0) * LS_FABS(omega));
    const LS_REAL par = ra * i_par + xb * i_perp + c->u_err + e->b_noise;
    const LS_REAL perp = ra * i_perp + xb * i_par + c->u_err * (share + rip) + e->b_noise;
    const LS_REAL y = perp / (mag - par);
    /* atan(y) <= y: rounded up; |e| <= par, or not finite: no trust */
    return (mag > par && y < LS_R(0.5) * LS_PI) ? y : LS_R(0.5) * LS_PI;
}

LS_REAL ls_emf_omega_min(const ls_emf *e, LS_REAL i_mag, LS_REAL psi, LS_REAL eps_max, LS_REAL k_r)
{
    LS_REAL lo = LS_R(0.0), hi = e->cfg.omega_max;
    int k;
    if (!LS_ISFINITE4(i_mag, psi, eps_max, k_r) || !(eps_max > LS_R(0.0)) || !(eps_max < LS_R(0.5) * LS_PI) ||
        !(psi > LS_R(0.0)) || !(k_r > LS_R(0.0)) || i_mag < LS_R(0.0)) {
        return LS_REAL_MAX;
    }
    if (!(ls_emf_bound(e, hi * psi, i_mag, LS_R(0.0), hi, k_r) <= eps_max)) {
        return LS_REAL_MAX;
    }
    /* the bound falls with the speed (its numerator's speed term over psi is less than the
     * denominator's slope): bisection on [0, omega_max] to 1e-4 relative */
    for (k = 0; k < 60 && hi - lo > LS_R(1e-4) * hi; ++k) {
        const LS_REAL mid = LS_R(0.5) * (lo + hi);
        if (ls_emf_bound(e, mid * psi, i_mag, LS_R(0.0), mid, k_r) <= eps_max) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    return hi;
}

bool ls_emf_update(ls_emf *e, const LS_REAL v_ab[2], const LS_REAL i_ab[2], LS_REAL c, LS_REAL s, LS_REAL omega,
                   LS_REAL k_r)
{
    if (!LS_ISFINITE4(v_ab[0], v_ab[1], i_ab[0], i_ab[1]) || !LS_ISFINITE4(c, s, omega, k_r)) {
        e->primed = false;
        return false;
    }
    return ls_emf_update_finite(e, v_ab, i_ab, c, s, omega, k_r);
}

bool ls_emf_update_finite(ls_emf *e, const LS_REAL v_ab[2], const LS_REAL i_ab[2], LS_REAL c, LS_REAL s,
                          LS_REAL omega, LS_REAL k_r)
{
    const ls_emf_cfg *g = &e->cfg;
    LS_REAL w, r, ima, imb, ea, eb, d, cd, sd, cm, sm, ed, eq, id, iq;
    if (!e->primed) {
        e->i0[0] = i_ab[0];
        e->i0[1] = i_ab[1];
        e->primed = true;
        return false;
    }
    w = ls_clamp(omega, -g->omega_max, g->omega_max);
    k_r = ls_clamp(k_r, LS_DTRES_KR_MIN, LS_DTRES_KR_MAX);
    r = k_r * g->r_s;
    ima = LS_R(0.5) * (e->i0[0] + i_ab[0]);
    imb = LS_R(0.5) * (e->i0[1] + i_ab[1]);
    /* e_ab = v - R i_m - l_d (i1 - i0) fs - omega (l_q - l_d) J i_m,  J i = (-i_b, i_a) */
    {
        const LS_REAL wl = w * (g->l_q - g->l_d);
        ea = v_ab[0] - r * ima - e->l_fs * (i_ab[0] - e->i0[0]) + wl * imb;
        eb = v_ab[1] - r * imb - e->l_fs * (i_ab[1] - e->i0[1]) - wl * ima;
    }
    e->i0[0] = i_ab[0];
    e->i0[1] = i_ab[1];
    /* the estimated frame at the period's middle, theta_est - d, d = omega Ts / 2 (|d| <=
     * LS_EMF_OMEGA_TS_MAX / 2: cos and sin by their series to d^4) */
    d = w * e->half_ts;
    cd = LS_R(1.0) - LS_R(0.5) * d * d;
    sd = d * (LS_R(1.0) - d * d * LS_R(0.166666667));
    cm = c * cd + s * sd;
    sm = s * cd - c * sd;
    if (e->pm_comp) {
        /* the magnets' negative sequence, predicted at the period's middle and taken out:
         * e_ab += j w k_neg e^{-j theta_m},  k_neg e^{-j theta_m} = (kr cm + ki sm) + j (ki cm - kr sm) */
        const LS_REAL kr = e->k_neg[0], ki = e->k_neg[1];
        ea += w * (kr * sm - ki * cm);
        eb += w * (kr * cm + ki * sm);
    }
    if (e->harm_on) {
        /* the magnets' flux harmonics, predicted at the period's middle and taken out:
         * e_ab -= j w m c e^{j m theta_m}, m = s n */
        int k;
        for (k = 0; k < LS_EMF_HARM_N; ++k) {
            const LS_REAL m = e->harm_m[k];
            if (m != LS_R(0.0)) {
                LS_REAL pc, ps, qr, qi;
                unit_power(cm, sm, g->harm_order[k], &pc, &ps);
                ps = m < LS_R(0.0) ? -ps : ps;
                qr = g->harm_re[k] * pc - g->harm_im[k] * ps;
                qi = g->harm_re[k] * ps + g->harm_im[k] * pc;
                ea += w * m * qi;
                eb -= w * m * qr;
            }
        }
    }
    /* (x + (-s) y is x - s y bit for bit; written so, GCC 12's x86-64 SLP vectoriser does not pair
     * the two rows into an add-subtract it then fuses with the products into vfmsubadd, despite
     * -ffp-contract=off: the extension would round otherwise than the firmware) */
    ed = cm * ea + sm * eb;
    eq = cm * eb + (-sm) * ea;
    id = cm * ima + sm * imb;
    iq = cm * imb + (-sm) * ima;
    e->e_d += e->alpha * (ed - e->e_d);
    e->e_q += e->alpha * (eq - e->e_q);
    e->i_d += e->alpha * (id - e->i_d);
    e->i_q += e->alpha * (iq - e->i_q);
    return true;
}

LS_REAL ls_emf_angle(ls_emf *e, LS_REAL omega)
{
    /* (the sign of the clamped speed is omega's) */
    const LS_REAL sg = omega < LS_R(0.0) ? LS_R(-1.0) : LS_R(1.0);
    e->mag = LS_SQRT(e->e_d * e->e_d + e->e_q * e->e_q);
    /* (no EMF, or filters overflowed by hostile inputs until the caller resets: no angle, no trust) */
    if (!(e->mag > LS_R(0.0) && e->mag <= LS_REAL_MAX)) {
        e->eps = LS_R(0.0);
        return e->eps;
    }
    if (e->pm_comp) {
        /* the positive sequence's axis leads by pm_shift: (x, y) turned by -pm_shift */
        const LS_REAL x = sg * e->e_q, y = -sg * e->e_d;
        e->eps = ls_atan2(y * e->c_pm - x * e->s_pm, x * e->c_pm + y * e->s_pm);
    } else {
        e->eps = ls_atan2(-sg * e->e_d, sg * e->e_q);
    }
    return e->eps;
}

LS_REAL ls_emf_step_eps(ls_emf *e, const LS_REAL v_ab[2], const LS_REAL i_ab[2], LS_REAL c, LS_REAL s,
                        LS_REAL omega, LS_REAL k_r)
{
    return ls_emf_update(e, v_ab, i_ab, c, s, omega, k_r) ? ls_emf_angle(e, omega) : e->eps;
}

LS_REAL ls_emf_step(ls_emf *e, const LS_REAL v_ab[2], const LS_REAL i_ab[2], LS_REAL c, LS_REAL s,
                    LS_REAL omega, LS_REAL k_r)
{
    const bool primed0 = e->primed;
    const LS_REAL eps = ls_emf_step_eps(e, v_ab, i_ab, c, s, omega, k_r);
    /* (the filters moved: a step of a primed block with finite inputs; else the bound stays) */
    if (!primed0 || !e->primed) {
        return eps;
    }
    if (!(e->mag > LS_R(0.0) && e->mag <= LS_REAL_MAX)) {
        e->bound = LS_R(0.5) * LS_PI;
    } else {
        /* the current's parts along and across the EMF, at the step's clamped speed and scale */
        const LS_REAL um = LS_R(1.0) / e->mag;
        const LS_REAL ipar = LS_FABS(e->i_d * e->e_d + e->i_q * e->e_q) * um;
        const LS_REAL iperp = LS_FABS(e->i_q * e->e_d - e->i_d * e->e_q) * um;
        e->bound = ls_emf_bound(e, e->mag, ipar, iperp, ls_clamp(omega, -e->cfg.omega_max, e->cfg.omega_max),
                                k_r);
    }
    return eps;
}
