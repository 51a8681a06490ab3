/* linsense firmware library: common types, math macros and status codes.
 *
 * LS_REAL selects the arithmetic: float (default, as on an MCU with a single-precision FPU)
 * or double (compile with -DLS_REAL_DOUBLE). Angles are electrical radians, positions metres,
 * everything else SI. No dynamic memory, no globals: every module keeps its state in a struct
 * owned by the caller.
 */
#ifndef LINSENSE_LS_TYPES_H
#define LINSENSE_LS_TYPES_H

#include <stdint.h>
#include <stdbool.h>
#include <float.h>  /* FLT_MAX, DBL_MAX: a freestanding compiler header */
#include <stddef.h> /* NULL, size_t: a freestanding compiler header, not libc */
#include <math.h>   /* the LS_SIN ... macros and the inline helpers use it */

/* The library's version (semantic: major for an API change, minor for an addition); released with
 * the Python package of the same number (`linsense --version` shows both; a test keeps them equal). */
#define LS_VERSION_MAJOR 0
#define LS_VERSION_MINOR 1
#define LS_VERSION_PATCH 0
/* The version as one number, 0xMMmmpp (LS_VERSION_OF(0, 1, 0) = 0x000100): what a configuration
 * records as made for (ls_drive_cfg.lib_version, set by ls_drive_default_cfg and by every generated
 * ls_cfg_*.h) and ls_drive_init compares. */
#define LS_VERSION_OF(major, minor, patch) ((uint32_t)(((major) << 16) | ((minor) << 8) | (patch)))
#define LS_VERSION LS_VERSION_OF(LS_VERSION_MAJOR, LS_VERSION_MINOR, LS_VERSION_PATCH)

#ifdef LS_REAL_DOUBLE
typedef double LS_REAL;
#define LS_R(x) (x)
#define LS_REAL_MAX DBL_MAX /* the largest finite LS_REAL */
#define LS_FLOOR floor
#define LS_SIN sin
#define LS_COS cos
#define LS_SQRT sqrt
#define LS_FABS fabs
#define LS_EXP exp
#define LS_TAN tan
#define LS_ATAN2 atan2
#else
typedef float LS_REAL;
#define LS_R(x) (x##f)
#define LS_REAL_MAX FLT_MAX /* the largest finite LS_REAL */
#define LS_FLOOR floorf
#define LS_SIN sinf
#define LS_COS cosf
#define LS_SQRT sqrtf
#define LS_FABS fabsf
#define LS_EXP expf
#define LS_TAN tanf
#define LS_ATAN2 atan2f
#endif

/* True for a finite number (false for NaN and +-Inf), without isfinite's double promotion. */
#define LS_ISFINITE(x) (((x) - (x)) == ((x) - (x)))
/* True when both are finite: x - x is exactly 0 for every finite x and NaN otherwise, so one
 * comparison checks several values (exactly LS_ISFINITE(a) && LS_ISFINITE(b)). */
#define LS_ISFINITE2(a, b) ((((a) - (a)) + ((b) - (b))) == LS_R(0.0))
#define LS_ISFINITE3(a, b, c) ((((a) - (a)) + ((b) - (b)) + ((c) - (c))) == LS_R(0.0))
#define LS_ISFINITE4(a, b, c, d) ((((a) - (a)) + ((b) - (b)) + ((c) - (c)) + ((d) - (d))) == LS_R(0.0))

#define LS_PI LS_R(3.14159265358979323846)
#define LS_TWO_PI LS_R(6.28318530717958647692)
#define LS_SQRT3 LS_R(1.73205080756887729353)

/* Status codes returned by every ls_<module>_init. */
typedef enum {
    LS_OK = 0,
    LS_ERR_NULL = 1,  /* a required pointer is NULL */
    LS_ERR_PARAM = 2, /* a configuration value is out of its allowed range (or not finite) */
    LS_ERR_VERSION = 3 /* ls_drive_init: a configuration made for another library version
                          (ls_drive_cfg.lib_version is not LS_VERSION; regenerate its header) */
} ls_status;

/* Clamp x into [lo, hi] (lo <= hi; NaN stays NaN). Written as min then max, each a form compilers
 * map onto one min/max instruction without branching. */
static inline LS_REAL ls_clamp(LS_REAL x, LS_REAL lo, LS_REAL hi)
{
    const LS_REAL t = hi < x ? hi : x;
    return lo > t ? lo : t;
}

/* A friction force (N) at speed v: Coulomb c linear below c / k (its slope k) plus viscous b v;
 * with k = c = b = 0 an exact 0 (ls_posctrl, ls_observer: docs/tuning.md, "Friction and thrust
 * ripple"). */
static inline LS_REAL ls_friction(LS_REAL v, LS_REAL k, LS_REAL c, LS_REAL b)
{
    return ls_clamp(k * v, -c, c) + b * v;
}

#endif /* LINSENSE_LS_TYPES_H */
