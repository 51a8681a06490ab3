/* Min-max modulator (see linsense/ls_mod.h). */
#include <math.h>

#include "linsense/ls_mod.h"

ls_status ls_mod_init(ls_mod *m, const ls_mod_cfg *cfg)
{
    if (m == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!LS_ISFINITE(cfg->f_pwm) || !LS_ISFINITE(cfg->dead_time) || !LS_ISFINITE(cfg->i_band) ||
        !(cfg->f_pwm > LS_R(0.0)) || cfg->dead_time < LS_R(0.0) ||
        cfg->dead_time * cfg->f_pwm >= LS_R(0.1) || !(cfg->i_band > LS_R(0.0)) || !LS_ISFINITE(cfg->dtc_lead) ||
        cfg->dtc_lead < LS_R(-1.0) || cfg->dtc_lead > LS_R(4.0) || !LS_ISFINITE(cfg->l_ripple) ||
        cfg->l_ripple < LS_R(0.0)) {
        return LS_ERR_PARAM;
    }
    m->cfg = *cfg;
    m->d_dead = cfg->dead_time * cfg->f_pwm;
    m->t_pwm = LS_R(1.0) / cfg->f_pwm;
    m->inv_band = LS_R(1.0) / cfg->i_band;
    m->k_now = (LS_R(1.0) + cfg->dtc_lead) * m->inv_band;
    m->k_prev = cfg->dtc_lead * m->inv_band;
    m->k_rip = cfg->l_ripple > LS_R(0.0) ? m->inv_band / (cfg->f_pwm * cfg->l_ripple) : LS_R(0.0);
    ls_mod_reset(m);
    return LS_OK;
}

void ls_mod_reset(ls_mod *m)
{
    int k;
    for (k = 0; k < 3; ++k) {
        m->i_prev[k] = LS_R(0.0);
        /* no leg switched (the inverter was off): the residual is 0 until two steps are known */
        m->hist[0].d[k] = m->hist[1].d[k] = LS_R(0.0);
        m->hist[0].c[k] = m->hist[1].c[k] = LS_R(0.0);
    }
    m->have_prev = false;
    m->newest = 0u;
}
