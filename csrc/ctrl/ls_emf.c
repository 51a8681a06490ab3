/* The extended-EMF position error in the estimated frame (see linsense/ls_emf.h). */
#include "linsense/ls_emf.h"
#include "linsense/ls_math.h"

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
    ts = LS_R(1.0) / cfg->fs;
    a = LS_R(1.0) - ls_exp(-(LS_TWO_PI * cfg->f_lpf * ts));
    /* the low-passed EMF's noise from a white current noise sigma per sample and axis: the
     * inductive drop l_d fs (i1 - i0) through the low-pass, sum of its squared impulse response
     * a^2 + a^3 / (2 - a), and the resistive drop r_s (i0 + i1) / 2, sum a / (2 - a) / 2 (the sums'
     * square roots added: a bound) */
    q = a / (LS_R(2.0) - a);
    e->cfg = *cfg;
    e->alpha = a;
    e->l_fs = cfg->l_d * cfg->fs;
    e->half_ts = LS_R(0.5) * ts;
    e->b_noise = LS_R(3.0) * cfg->i_noise *
                 (e->l_fs * a * LS_SQRT(LS_R(1.0) + q) + cfg->r_s * LS_SQRT(LS_R(0.5) * q));
    if (!LS_ISFINITE4(e->alpha, e->l_fs, e->half_ts, e->b_noise) || !(a > LS_R(0.0))) {
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

LS_REAL ls_emf_bound(LS_REAL x)
{
    /* tan(asin x) >= asin x: the largest angle a perpendicular error of x |e| turns the vector by,
     * rounded up; not finite or beyond LS_EMF_X_MAX: no trust */
    if (!(x < LS_EMF_X_MAX)) {
        return LS_R(0.5) * LS_PI;
    }
    x = x > LS_R(0.0) ? x : LS_R(0.0);
    return ls_clamp(x / LS_SQRT(LS_R(1.0) - x * x), LS_R(0.0), LS_R(0.5) * LS_PI);
}

LS_REAL ls_emf_error_v(const ls_emf *e, LS_REAL i_mag, LS_REAL omega, LS_REAL k_r)
{
    const ls_emf_cfg *c = &e->cfg;
    return (c->err_r * k_r * c->r_s + c->err_l * c->l_q * LS_FABS(omega)) * LS_FABS(i_mag) + c->u_err + e->b_noise;
}

LS_REAL ls_emf_omega_min(const ls_emf *e, LS_REAL i_mag, LS_REAL psi, LS_REAL eps_max, LS_REAL k_r)
{
    const ls_emf_cfg *c = &e->cfg;
    LS_REAL x_max, den, w;
    if (!LS_ISFINITE4(i_mag, psi, eps_max, k_r) || !(eps_max > LS_R(0.0)) || !(eps_max < LS_R(0.5) * LS_PI) ||
        !(psi > LS_R(0.0)) || !(k_r > LS_R(0.0))) {
        return LS_REAL_MAX;
    }
    x_max = eps_max / LS_SQRT(LS_R(1.0) + eps_max * eps_max);
    if (!(x_max < LS_EMF_X_MAX)) {
        x_max = LS_EMF_X_MAX; /* (the bound is pi / 2 from there on) */
    }
    den = psi * x_max - c->err_l * c->l_q * LS_FABS(i_mag);
    if (!(den > LS_R(0.0))) {
        return LS_REAL_MAX;
    }
    w = ls_emf_error_v(e, i_mag, LS_R(0.0), k_r) / den;
    return LS_ISFINITE(w) ? w : LS_REAL_MAX;
}

LS_REAL ls_emf_step(ls_emf *e, const LS_REAL v_ab[2], const LS_REAL i_ab[2], LS_REAL c, LS_REAL s,
                    LS_REAL omega, LS_REAL k_r)
{
    const ls_emf_cfg *g = &e->cfg;
    LS_REAL w, r, ima, imb, ea, eb, d, cd, sd, cm, sm, ed, eq, id, iq, sg, x;
    if (!LS_ISFINITE4(v_ab[0], v_ab[1], i_ab[0], i_ab[1]) || !LS_ISFINITE4(c, s, omega, k_r)) {
        e->primed = false;
        return e->eps;
    }
    if (!e->primed) {
        e->i0[0] = i_ab[0];
        e->i0[1] = i_ab[1];
        e->primed = true;
        return e->eps;
    }
    w = ls_clamp(omega, -g->omega_max, g->omega_max);
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
    sd = d * (LS_R(1.0) - d * d / LS_R(6.0));
    cm = c * cd + s * sd;
    sm = s * cd - c * sd;
    ed = cm * ea + sm * eb;
    eq = cm * eb - sm * ea;
    id = cm * ima + sm * imb;
    iq = cm * imb - sm * ima;
    e->e_d += e->alpha * (ed - e->e_d);
    e->e_q += e->alpha * (eq - e->e_q);
    e->i_d += e->alpha * (id - e->i_d);
    e->i_q += e->alpha * (iq - e->i_q);
    e->mag = LS_SQRT(e->e_d * e->e_d + e->e_q * e->e_q);
    sg = w < LS_R(0.0) ? LS_R(-1.0) : LS_R(1.0);
    e->eps = e->mag > LS_R(0.0) ? LS_ATAN2(-sg * e->e_d, sg * e->e_q) : LS_R(0.0);
    x = ls_emf_error_v(e, LS_SQRT(e->i_d * e->i_d + e->i_q * e->i_q), w, k_r);
    e->bound = e->mag > LS_R(0.0) ? ls_emf_bound(x / e->mag) : LS_R(0.5) * LS_PI;
    return e->eps;
}
