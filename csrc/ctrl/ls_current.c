/* d/q current controller (see linsense/ls_current.h). */
#include <math.h>

#include "linsense/ls_current.h"

static bool finite_pos(LS_REAL x)
{
    return LS_ISFINITE(x) && x > LS_R(0.0);
}

static bool finite_nonneg(LS_REAL x)
{
    return LS_ISFINITE(x) && x >= LS_R(0.0);
}

ls_status ls_current_init(ls_current *c, const ls_current_cfg *cfg)
{
    if (c == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!finite_pos(cfg->kp) || !finite_nonneg(cfg->ki) || !finite_nonneg(cfg->l_d) ||
        !finite_nonneg(cfg->l_q) || !finite_nonneg(cfg->psi_pm) || !finite_pos(cfg->fs) ||
        cfg->kp > LS_CURRENT_KP_MAX || !(cfg->ki / cfg->fs <= LS_CURRENT_KP_MAX) || cfg->l_d > LS_CURRENT_L_MAX ||
        cfg->l_q > LS_CURRENT_L_MAX || cfg->psi_pm > LS_CURRENT_PSI_MAX) {
        return LS_ERR_PARAM;
    }
    c->cfg = *cfg;
    c->ts = LS_R(1.0) / cfg->fs;
    c->ki_ts = cfg->ki * c->ts;
    ls_current_reset(c);
    return LS_OK;
}

void ls_current_limit_wide(LS_REAL v_max, LS_REAL *v_d, LS_REAL *v_q)
{
    /* scaled before squaring: a, b in [-1, 1], a^2 + b^2 in [1, 2] */
    const LS_REAL ad = LS_FABS(*v_d), aq = LS_FABS(*v_q);
    const LS_REAL m = ad > aq ? ad : aq;
    LS_REAL a, b, r;
    if (!(m > LS_R(0.0))) { /* 0, or NaN: nothing to scale */
        return;
    }
    if (LS_ISFINITE(m)) {
        a = *v_d / m;
        b = *v_q / m;
    } else { /* a component overflowed to +-Inf: the direction of the infinite ones */
        a = LS_ISFINITE(*v_d) ? LS_R(0.0) : (*v_d > LS_R(0.0) ? LS_R(1.0) : LS_R(-1.0));
        b = LS_ISFINITE(*v_q) ? LS_R(0.0) : (*v_q > LS_R(0.0) ? LS_R(1.0) : LS_R(-1.0));
    }
    r = v_max / LS_SQRT(a * a + b * b);
    *v_d = a * r;
    *v_q = b * r;
}

void ls_current_reset(ls_current *c)
{
    c->integ_d = LS_R(0.0);
    c->integ_q = LS_R(0.0);
    c->saturated = false;
}
