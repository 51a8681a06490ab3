/* Min-max modulator (see linsense/ls_modulator.h). */
#include <math.h>

#include "linsense/ls_modulator.h"

ls_status ls_mod_init(ls_mod *m, const ls_mod_cfg *cfg)
{
    if (m == NULL || cfg == NULL) {
        return LS_ERR_NULL;
    }
    if (!LS_ISFINITE(cfg->f_pwm) || !LS_ISFINITE(cfg->dead_time) || !LS_ISFINITE(cfg->i_band) ||
        !(cfg->f_pwm > LS_R(0.0)) || cfg->dead_time < LS_R(0.0) ||
        cfg->dead_time * cfg->f_pwm >= LS_R(0.1) || !(cfg->i_band > LS_R(0.0)) || !LS_ISFINITE(cfg->dtc_lead) ||
        cfg->dtc_lead < LS_R(0.0) || cfg->dtc_lead > LS_R(4.0)) {
        return LS_ERR_PARAM;
    }
    m->cfg = *cfg;
    m->d_dead = cfg->dead_time * cfg->f_pwm;
    ls_mod_reset(m);
    return LS_OK;
}

void ls_mod_reset(ls_mod *m)
{
    m->i_prev[0] = m->i_prev[1] = m->i_prev[2] = LS_R(0.0);
    m->have_prev = false;
}

bool ls_mod_step(ls_mod *m, LS_REAL v_a, LS_REAL v_b, LS_REAL v_dc, const LS_REAL i_abc[3],
                 LS_REAL duty[3])
{
    LS_REAL v[3], vmax, vmin, off, inv;
    bool clipped = false;
    int k;
    if (!LS_ISFINITE(v_a) || !LS_ISFINITE(v_b) || !LS_ISFINITE(v_dc) || !(v_dc > LS_R(0.0))) {
        duty[0] = duty[1] = duty[2] = LS_R(0.5);
        return true;
    }
    v[0] = v_a;
    v[1] = LS_R(-0.5) * v_a + LS_R(0.5) * LS_SQRT3 * v_b;
    v[2] = LS_R(-0.5) * v_a - LS_R(0.5) * LS_SQRT3 * v_b;
    vmax = v[0] > v[1] ? v[0] : v[1];
    vmax = vmax > v[2] ? vmax : v[2];
    vmin = v[0] < v[1] ? v[0] : v[1];
    vmin = vmin < v[2] ? vmin : v[2];
    off = LS_R(-0.5) * (vmax + vmin);
    inv = LS_R(1.0) / v_dc;
    for (k = 0; k < 3; ++k) {
        LS_REAL d = LS_R(0.5) + (v[k] + off) * inv;
        if (m->cfg.dtc && i_abc != NULL && LS_ISFINITE(i_abc[k])) {
            LS_REAL i_pred = i_abc[k];
            if (m->have_prev) {
                i_pred += m->cfg.dtc_lead * (i_abc[k] - m->i_prev[k]);
            }
            m->i_prev[k] = i_abc[k];
            d += m->d_dead * ls_clamp(i_pred / m->cfg.i_band, LS_R(-1.0), LS_R(1.0));
        }
        if (d > LS_R(1.0) || d < LS_R(0.0)) {
            clipped = true;
        }
        duty[k] = ls_clamp(d, LS_R(0.0), LS_R(1.0));
    }
    m->have_prev = m->cfg.dtc && i_abc != NULL;
    return clipped;
}
