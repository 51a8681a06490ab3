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

LS_REAL ls_lut_step_wide(const ls_lut *lut, LS_REAL theta)
{
    LS_REAL th;
    if (!LS_ISFINITE(theta)) {
        return LS_R(0.0);
    }
    th = theta - LS_TWO_PI * LS_FLOOR(theta / LS_TWO_PI); /* wrap into [0, 2 pi] */
    if (!(th >= LS_R(0.0) && th < LS_TWO_PI)) { /* rounded up to 2 pi, or |theta| so large that no
                                                   * fraction of a period is left: the angle 0 */
        th = LS_R(0.0);
    }
    return ls_lut_step(lut, th);
}

void ls_lut_reset(ls_lut *lut)
{
    (void)lut;
}
