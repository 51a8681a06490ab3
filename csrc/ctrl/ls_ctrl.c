/* PI, current and position controllers (see linsense/ls_ctrl.h). */
#include <math.h>

#include "linsense/ls_ctrl.h"

static bool finite_pos(LS_REAL x)
{
    return LS_ISFINITE(x) && x > LS_R(0.0);
}

static bool finite_nonneg(LS_REAL x)
{
    return LS_ISFINITE(x) && x >= LS_R(0.0);
}

/* ------------------------------------------------------------------------------- PI */
ls_status ls_pi_init(ls_pi *pi, const ls_pi_cfg *cfg)
{
    if (pi == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!finite_pos(cfg->kp) || !finite_nonneg(cfg->ki) || !finite_pos(cfg->fs) ||
        !LS_ISFINITE(cfg->out_min) || !LS_ISFINITE(cfg->out_max) || !(cfg->out_min < cfg->out_max)) {
        return LS_ERR_PARAM;
    }
    pi->cfg = *cfg;
    pi->ts = LS_R(1.0) / cfg->fs;
    ls_pi_reset(pi);
    return LS_OK;
}

void ls_pi_reset(ls_pi *pi)
{
    pi->integ = LS_R(0.0);
    pi->saturated = false;
}

LS_REAL ls_pi_step(ls_pi *pi, LS_REAL err, LS_REAL ff)
{
    LS_REAL integ, u, u_lim;
    if (!LS_ISFINITE(err)) {
        err = LS_R(0.0);
    }
    if (!LS_ISFINITE(ff)) {
        ff = LS_R(0.0);
    }
    integ = pi->integ + pi->cfg.ki * err * pi->ts;
    u = pi->cfg.kp * err + integ + ff;
    u_lim = ls_clamp(u, pi->cfg.out_min, pi->cfg.out_max);
    pi->saturated = u_lim != u;
    /* conditional integration: no integration that would push further into the limit */
    if (!(pi->saturated && (u > pi->cfg.out_max) == (err > LS_R(0.0)))) {
        pi->integ = ls_clamp(integ, pi->cfg.out_min, pi->cfg.out_max);
    }
    return u_lim;
}

/* ------------------------------------------------------------------------------- current */
ls_status ls_current_init(ls_current *c, const ls_current_cfg *cfg)
{
    if (c == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!finite_pos(cfg->kp) || !finite_nonneg(cfg->ki) || !finite_nonneg(cfg->l_d) ||
        !finite_nonneg(cfg->l_q) || !finite_nonneg(cfg->psi_pm) || !finite_pos(cfg->fs)) {
        return LS_ERR_PARAM;
    }
    c->cfg = *cfg;
    c->ts = LS_R(1.0) / cfg->fs;
    ls_current_reset(c);
    return LS_OK;
}

void ls_current_reset(ls_current *c)
{
    c->integ_d = LS_R(0.0);
    c->integ_q = LS_R(0.0);
    c->saturated = false;
}

void ls_current_step(ls_current *c, LS_REAL i_d, LS_REAL i_q, LS_REAL i_d_ref, LS_REAL i_q_ref,
                     LS_REAL omega, LS_REAL v_max, LS_REAL *v_d, LS_REAL *v_q)
{
    const ls_current_cfg *k = &c->cfg;
    LS_REAL e_d = i_d_ref - i_d;
    LS_REAL e_q = i_q_ref - i_q;
    LS_REAL ff_d = LS_R(0.0), ff_q = LS_R(0.0);
    LS_REAL ud, uq, mag2, vmax2;
    if (!LS_ISFINITE(e_d) || !LS_ISFINITE(e_q) || !LS_ISFINITE(omega) || !(v_max > LS_R(0.0))) {
        *v_d = LS_R(0.0);
        *v_q = LS_R(0.0);
        return;
    }
    if (k->decouple) {
        ff_d = -omega * k->l_q * i_q;
        ff_q = omega * (k->l_d * i_d + k->psi_pm);
    }
    ud = k->kp * e_d + c->integ_d + k->ki * e_d * c->ts + ff_d;
    uq = k->kp * e_q + c->integ_q + k->ki * e_q * c->ts + ff_q;
    mag2 = ud * ud + uq * uq;
    vmax2 = v_max * v_max;
    c->saturated = mag2 > vmax2;
    /* conditional integration: an axis integrates unless the vector is limited and that axis'
     * error pushes its voltage further out */
    if (!c->saturated || (e_d > LS_R(0.0)) != (ud > LS_R(0.0))) {
        c->integ_d = ls_clamp(c->integ_d + k->ki * e_d * c->ts, -v_max, v_max);
    }
    if (!c->saturated || (e_q > LS_R(0.0)) != (uq > LS_R(0.0))) {
        c->integ_q = ls_clamp(c->integ_q + k->ki * e_q * c->ts, -v_max, v_max);
    }
    if (c->saturated) {
        LS_REAL scale = v_max / LS_SQRT(mag2);
        ud *= scale;
        uq *= scale;
    }
    *v_d = ud;
    *v_q = uq;
}

/* ------------------------------------------------------------------------------- position */
ls_status ls_posctrl_init(ls_posctrl *p, const ls_posctrl_cfg *cfg)
{
    ls_pi_cfg sp;
    if (p == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!finite_pos(cfg->kp_x) || !finite_nonneg(cfg->kd_x) || !finite_pos(cfg->v_max) ||
        !finite_nonneg(cfg->mass) || !finite_pos(cfg->force_max) ||
        (cfg->type != LS_POSCTRL_P && cfg->type != LS_POSCTRL_PD)) {
        return LS_ERR_PARAM;
    }
    sp = cfg->speed;
    sp.out_min = -cfg->force_max;
    sp.out_max = cfg->force_max;
    if (cfg->type == LS_POSCTRL_P && ls_pi_init(&p->speed, &sp) != LS_OK) {
        return LS_ERR_PARAM;
    }
    p->cfg = *cfg;
    ls_posctrl_reset(p);
    return LS_OK;
}

void ls_posctrl_reset(ls_posctrl *p)
{
    if (p->cfg.type == LS_POSCTRL_P) {
        ls_pi_reset(&p->speed);
    }
    p->v_ref = LS_R(0.0);
}

LS_REAL ls_posctrl_step(ls_posctrl *p, LS_REAL x_err, LS_REAL v, LS_REAL v_ff, LS_REAL a_ff)
{
    const ls_posctrl_cfg *k = &p->cfg;
    LS_REAL f_ff = k->mass * a_ff;
    LS_REAL f;
    if (!LS_ISFINITE(x_err) || !LS_ISFINITE(v) || !LS_ISFINITE(v_ff) || !LS_ISFINITE(f_ff)) {
        return LS_R(0.0);
    }
    if (k->type == LS_POSCTRL_P) {
        p->v_ref = ls_clamp(k->kp_x * x_err + v_ff, -k->v_max, k->v_max);
        return ls_pi_step(&p->speed, p->v_ref - v, f_ff);
    }
    f = k->kp_x * x_err + k->kd_x * (v_ff - v) + f_ff;
    return ls_clamp(f, -k->force_max, k->force_max);
}
