/* Periodic linearly interpolated look-up table (see linsense/ls_lut.h). */
#include <math.h>

#include "linsense/ls_lut.h"

ls_status ls_lut_init(ls_lut *lut, const ls_lut_cfg *cfg)
{
    uint32_t k;
    if (lut == NULL || cfg == NULL || cfg->table == NULL) {
        return LS_ERR_NULL;
    }
    if (cfg->len < 4u) {
        return LS_ERR_PARAM;
    }
    for (k = 0u; k < cfg->len; ++k) {
        if (!LS_ISFINITE(cfg->table[k])) {
            return LS_ERR_PARAM;
        }
    }
    lut->table = cfg->table;
    lut->len = cfg->len;
    lut->points_per_rad = (LS_REAL)cfg->len / LS_TWO_PI;
    return LS_OK;
}

void ls_lut_reset(ls_lut *lut)
{
    (void)lut;
}

LS_REAL ls_lut_step(const ls_lut *lut, LS_REAL theta)
{
    const LS_REAL n = (LS_REAL)lut->len;
    LS_REAL u;
    LS_REAL f;
    uint32_t k;
    uint32_t k1;
    if (!LS_ISFINITE(theta)) {
        return LS_R(0.0);
    }
    u = theta * lut->points_per_rad;
    u -= n * LS_FLOOR(u / n); /* wrap into [0, n] */
    k = (uint32_t)u;
    f = u - (LS_REAL)k;
    if (k >= lut->len) { /* u rounded up to n */
        k = 0u;
        f = LS_R(0.0);
    }
    k1 = (k + 1u == lut->len) ? 0u : k + 1u;
    return (LS_R(1.0) - f) * (LS_REAL)lut->table[k] + f * (LS_REAL)lut->table[k1];
}
