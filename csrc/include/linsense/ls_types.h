/* linsense firmware library: common types.
 *
 * LS_REAL selects the arithmetic: float (default, as on an MCU with a single-precision FPU)
 * or double (define LS_REAL_DOUBLE). Angles are electrical radians.
 */
#ifndef LINSENSE_LS_TYPES_H
#define LINSENSE_LS_TYPES_H

#include <stdint.h>
#include <stdbool.h>
#include <stddef.h> /* NULL, size_t: a freestanding compiler header, not libc */

#ifdef LS_REAL_DOUBLE
typedef double LS_REAL;
#define LS_R(x) (x)
#define LS_FLOOR floor
#define LS_ISFINITE(x) (((x) - (x)) == ((x) - (x)))
#else
typedef float LS_REAL;
#define LS_R(x) (x##f)
#define LS_FLOOR floorf
#define LS_ISFINITE(x) (((x) - (x)) == ((x) - (x)))
#endif

#define LS_PI LS_R(3.14159265358979323846)
#define LS_TWO_PI LS_R(6.28318530717958647692)

/* Status codes returned by every ls_<module>_init. */
typedef enum {
    LS_OK = 0,
    LS_ERR_NULL = 1,  /* a required pointer is NULL */
    LS_ERR_PARAM = 2  /* a configuration value is out of its allowed range */
} ls_status;

#endif /* LINSENSE_LS_TYPES_H */
