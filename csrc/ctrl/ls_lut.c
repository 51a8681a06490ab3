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
