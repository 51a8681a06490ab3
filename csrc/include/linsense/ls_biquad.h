/* linsense firmware library: second-order (biquad) IIR filters.
 *
 * Designed by the bilinear transform with pre-warping at f0 (R. Bristow-Johnson's audio-EQ
 * cookbook): low-pass, band-pass (0 dB and zero phase at f0) and notch (zero gain at f0); and the
 * first difference (LS_BIQUAD_DIFF).
 * Transposed direct form II. Used for signal separation (band-pass around the injected
 * frequency, notch for the current loop) and for the demodulator's low-pass filters.
 */
#ifndef LINSENSE_LS_BIQUAD_H
#define LINSENSE_LS_BIQUAD_H

#include "linsense/ls_types.h"

typedef enum {
    LS_BIQUAD_LOWPASS = 0,
    LS_BIQUAD_BANDPASS = 1,
    LS_BIQUAD_NOTCH = 2,
    LS_BIQUAD_DIFF = 3 /* y[k] = x[k] - x[k-1] (f0 and q unused): the square-wave injection's
                          current change over one period */
} ls_biquad_type;

/* Bounds on q (ls_biquad_init): a low-pass resonates by q at f0, and its poles approach the unit
 * circle as q grows; 1000 is far beyond any filter here (0.7 ... 2) */
#define LS_BIQUAD_Q_MIN LS_R(1.0e-3) /* - */
#define LS_BIQUAD_Q_MAX LS_R(1.0e3)  /* - */

typedef struct {
    ls_biquad_type type; /* filter type */
    LS_REAL f0;          /* Hz, corner (low-pass) or centre (band-pass, notch) frequency, < fs/2 */
    LS_REAL q;           /* -, quality factor (0.7071 gives a Butterworth low-pass),
                            [LS_BIQUAD_Q_MIN, LS_BIQUAD_Q_MAX] */
    LS_REAL fs;          /* Hz, sampling rate, > 0 */
} ls_biquad_cfg;

typedef struct {
    LS_REAL b0, b1, b2; /* -, numerator coefficients (a0 normalised to 1) */
    LS_REAL a1, a2;     /* -, denominator coefficients */
    LS_REAL z1, z2;     /* state of the transposed direct form II, unit of the input */
} ls_biquad;

/* Design the filter. LS_ERR_PARAM for f0 <= 0, f0 >= fs/2, q <= 0, fs <= 0 or non-finite. */
ls_status ls_biquad_init(ls_biquad *f, const ls_biquad_cfg *cfg);
/* Clear the state (coefficients kept). */
void ls_biquad_reset(ls_biquad *f);
/* Filter one sample. */
static inline LS_REAL ls_biquad_step(ls_biquad *f, LS_REAL x)
{
    LS_REAL y = f->b0 * x + f->z1;
    f->z1 = f->b1 * x - f->a1 * y + f->z2;
    f->z2 = f->b2 * x - f->a2 * y;
    return y;
}

/* ls_biquad_step for a band-pass (LS_BIQUAD_BANDPASS: b1 = 0, b2 = -b0 by design), the same
 * operations less those on the zero and the negated coefficient. */
static inline LS_REAL ls_biquad_step_bp(ls_biquad *f, LS_REAL x)
{
    const LS_REAL bx = f->b0 * x;
    LS_REAL y = bx + f->z1;
    f->z1 = f->z2 - f->a1 * y;
    f->z2 = -bx - f->a2 * y;
    return y;
}

/* ls_biquad_step for a symmetric numerator (b2 = b0: LS_BIQUAD_LOWPASS, and ls_demod's low-pass
 * with its zeros at f_notch), likewise. */
static inline LS_REAL ls_biquad_step_sym(ls_biquad *f, LS_REAL x)
{
    const LS_REAL bx = f->b0 * x;
    LS_REAL y = bx + f->z1;
    f->z1 = f->b1 * x - f->a1 * y + f->z2;
    f->z2 = bx - f->a2 * y;
    return y;
}

/* ls_biquad_step for a notch (LS_BIQUAD_NOTCH: b2 = b0, b1 = a1 by design), likewise. */
static inline LS_REAL ls_biquad_step_notch(ls_biquad *f, LS_REAL x)
{
    const LS_REAL bx = f->b0 * x;
    LS_REAL y = bx + f->z1;
    f->z1 = f->a1 * x - f->a1 * y + f->z2;
    f->z2 = bx - f->a2 * y;
    return y;
}

#endif /* LINSENSE_LS_BIQUAD_H */
