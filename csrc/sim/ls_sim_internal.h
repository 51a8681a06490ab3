/* linsense host-side simulator: what its parts share (not an API; the API is ls_sim.h).
 *
 * The parts, one file each:
 *   ls_sim_plant.c     linear plant: L_ab and PM-flux maps, force, the frozen 2x2 electrical system
 *                      and its one-period propagator;
 *   ls_sim_sat.c       saturated plant (ls_sim_sat): co-energy, flux, Newton current solve, RK4 step;
 *   ls_sim_inverter.c  inverter: average and switching models, dead time carried between periods;
 *   ls_sim_sensors.c   current sensors (gain, offset, noise, ADC) and encoder;
 *   ls_sim_mech.c      load and mechanics;
 *   ls_sim_record.c    output arrays, block statistics, position conversions;
 *   ls_sim.c           API: checks, the closed-loop time loop (ls_sim_begin/continue/run), open loop.
 *
 * Two builds of the same sources. The extension (linsense._ctrl) compiles ls_sim_all.c, which
 * defines LS_SIM_UNITY and includes every part: one translation unit, in which the functions below
 * are static and the time loop's helpers (LS_SIM_HOT) always inlined into it, so that its state stays
 * in registers and its arithmetic (with -ffp-contract=fast, fused across the inlined calls) is that
 * of one file. The C tests link the parts' objects: there the functions below are external, so that
 * the internal tests (csrc/tests/itest_*.c) call them. Double precision throughout. */
#ifndef LINSENSE_LS_SIM_INTERNAL_H
#define LINSENSE_LS_SIM_INTERNAL_H

#include <math.h>
#include <string.h>

#include "ls_sim.h"

#define LS_SIM_PI 3.14159265358979323846
#define LS_SIM_SQRT3 1.7320508075688772

/* LS_SIM_INLINE: a helper always inlined into its callers (GCC and Clang), in both builds.
 * LS_SIM_HOT: a part's function called by the time loop: inlined like LS_SIM_INLINE in the unity
 * build, external in the parts' objects. LS_SIM_INTERNAL: a part's function used by another part:
 * static in the unity build (the compiler inlines it or not, as within one file), external in the
 * parts' objects. */
#if defined(__GNUC__)
#define LS_SIM_INLINE static inline __attribute__((always_inline))
#else
#define LS_SIM_INLINE static inline
#endif
#ifdef LS_SIM_UNITY
#define LS_SIM_HOT LS_SIM_INLINE
#define LS_SIM_INTERNAL static
#else
#define LS_SIM_HOT
#define LS_SIM_INTERNAL
#endif

/* ------------------------------------------------------------------------------ Clarke */
/* pole (or phase) voltages -> alpha-beta (amplitude-invariant; the common mode drops out) */
LS_SIM_INLINE void ls_sim_poles_to_ab(const double p[3], double v_ab[2])
{
    v_ab[0] = (2.0 * p[0] - p[1] - p[2]) * (1.0 / 3.0);
    v_ab[1] = (p[1] - p[2]) * (1.0 / LS_SIM_SQRT3);
}

/* alpha-beta currents -> phase currents */
LS_SIM_INLINE void ls_sim_ab_to_abc(const double i[2], double abc[3])
{
    abc[0] = i[0];
    abc[1] = -0.5 * i[0] + 0.5 * LS_SIM_SQRT3 * i[1];
    abc[2] = -0.5 * i[0] - 0.5 * LS_SIM_SQRT3 * i[1];
}

/* ------------------------------------------------------------------------------ plant (ls_sim_plant.c) */
/* Per-run constants of the plant: the L_ab series rearranged order-major for the inner loop (the
 * derivative's coefficients precomputed) and reciprocals kept out of the time loop. */
typedef struct {
    double a[LS_SIM_MAX_ORDER][3];  /* H, cos(k theta) coefficients of L_aa, L_bb, L_ab */
    double b[LS_SIM_MAX_ORDER][3];  /* H, sin(k theta) coefficients */
    double da[LS_SIM_MAX_ORDER][3]; /* H/rad, k b: cos(k theta) coefficients of dL/dtheta */
    double db[LS_SIM_MAX_ORDER][3]; /* H/rad, -k a: sin(k theta) coefficients of dL/dtheta */
    double kf;                      /* 1/m, (3/2) 2 pi/tau: the force factor of the co-energy */
    double inv_mass;                /* 1/kg */
    double d_dead;                  /* -, dead time / PWM period */
    double lsb;                     /* A, current ADC step (0: ideal) */
    /* the end effect on the magnets' flux (ls_sim.h, lambda_pm), phase k's rotation
     * rho_k = pm_shift[k] - 2 pi k/3 and amplitude g_k = psi_pm (1 + pm_dscale[k]) folded in: */
    int32_t pm_unbal;                           /* -, 1: some pm_dscale or pm_shift nonzero */
    double pm_rot[3][2];                        /* Wb, g_k (cos, sin) rho_k */
    double pm_hrot[LS_SIM_MAX_PM][3][2];        /* Wb, g_k a_j (cos, sin)(n_j rho_k + phi_j) */
} ls_sim_coef;

/* the plant's maps at one angle */
typedef struct {
    double l[3];    /* H, L_aa, L_bb, L_ab */
    double dl[3];   /* H/rad */
    double lpm[2];  /* Wb */
    double dlpm[2]; /* Wb/rad */
} ls_sim_maps;

/* The 2x2 system frozen over one period at the mid-period position:
 *   di/dt = M i + b,   M = -L^-1 (R I + omega L'),   b = L^-1 (v - omega lambda_pm')         */
typedef struct {
    double linv[4]; /* 1/H, L^-1 row-major */
    double m[4];    /* 1/s */
    double be[2];   /* A/s, -L^-1 omega lambda_pm' (the EMF part of b) */
} ls_sim_frozen;

/* The propagator of the frozen system over an interval h: i <- Phi i + Gam b (ls_sim_prop_make) */
typedef struct {
    double phi[4]; /* -, row-major */
    double gam[4]; /* s, row-major */
} ls_sim_prop;

LS_SIM_INTERNAL void ls_sim_coef_init(const ls_sim_cfg *c, ls_sim_coef *q);
/* PM flux linkage (alpha-beta, Wb) and its theta derivative (Wb/rad) at theta (c1, s1: cos, sin) */
LS_SIM_HOT void ls_sim_pm_flux(const ls_sim_cfg *c, const ls_sim_coef *q, double theta, double c1, double s1,
                               double lpm[2], double dlpm[2]);
/* the maps at theta, given its cos c1 and sin s1 (ls_sim_maps_at: computed here) */
LS_SIM_HOT void ls_sim_maps_cs(const ls_sim_cfg *c, const ls_sim_coef *q, double theta, double c1, double s1,
                               ls_sim_maps *m);
LS_SIM_INTERNAL void ls_sim_maps_at(const ls_sim_cfg *c, const ls_sim_coef *q, double theta, ls_sim_maps *m);
/* the linear plant's force (N) at currents i */
LS_SIM_HOT double ls_sim_force_of(const ls_sim_coef *q, const ls_sim_maps *m, const double i[2]);
/* the force (N) at theta, either plant (the records outside the time loop) */
LS_SIM_INTERNAL double ls_sim_force_at(const ls_sim_cfg *c, const ls_sim_coef *q, double theta, const double i[2]);
/* the frozen system at speed omega (rad/s); false when L is not positive definite */
LS_SIM_HOT bool ls_sim_freeze(const ls_sim_cfg *c, const ls_sim_maps *pm, double omega, ls_sim_frozen *f);
LS_SIM_HOT void ls_sim_prop_make(const ls_sim_frozen *f, double h, ls_sim_prop *pp);
/* i <- Phi i + Gam b, b = L^-1 v_ab + be */
LS_SIM_HOT void ls_sim_prop_apply(const ls_sim_prop *pp, double b0, double b1, double i[2]);
/* one interval h of the frozen system with constant alpha-beta voltage v_ab */
LS_SIM_INTERNAL void ls_sim_propagate(const ls_sim_frozen *f, const double v_ab[2], double h, double i[2]);

/* ------------------------------------------------------------------------------ saturation (ls_sim_sat.c) */
/* The saturated plant's position-dependent values frozen at one angle th */
typedef struct {
    double th, c, s;              /* rad, -, -: the angle, its cos and sin */
    double v[LS_SIM_SAT_POW][3];  /* H/A^p, A_p, B_p, C_p at th */
    double dv[LS_SIM_SAT_POW][3]; /* H/A^p/rad, their theta derivatives */
    double lpm[2], dlpm[2];       /* Wb, Wb/rad: PM flux (alpha-beta) and its theta derivative */
    double kf;                    /* 1/m, (3/2) 2 pi/tau */
} ls_sim_sat_frame;

/* the saturated plant at one point (currents and angle) */
typedef struct {
    double lam[2];  /* Wb, flux linkage (alpha-beta, with the PM flux) */
    double l[3];    /* H, incremental inductance d lambda/d i: aa, bb, ab */
    double dlam[2]; /* Wb/rad, d lambda/d theta at constant alpha-beta currents */
    double force;   /* N */
} ls_sim_sat_point;

LS_SIM_INTERNAL void ls_sim_sat_frame_at(const ls_sim_cfg *c, const ls_sim_coef *q, double theta,
                                         ls_sim_sat_frame *f);
/* the saturated plant at alpha-beta currents i and the frame's angle */
LS_SIM_INTERNAL void ls_sim_sat_at(const ls_sim_cfg *c, const ls_sim_sat_frame *f, const double i[2],
                                   ls_sim_sat_point *pt);
/* one interval h with constant alpha-beta voltage v, the angle th + dth0 + omega t; pt: the plant at
 * the end. False: the plant left its valid range (diverged). */
LS_SIM_INTERNAL bool ls_sim_sat_step(const ls_sim_cfg *c, const ls_sim_sat_frame *f, const double v[2], double h,
                                     double dth0, double omega, double i[2], ls_sim_sat_point *pt);

/* ------------------------------------------------------------------------------ inverter (ls_sim_inverter.c) */
/* What the dead time carries from one period into the next: a turn-off delayed past the period
 * end (only with a duty within the dead time of 1 and the current flowing in) keeps the pole high
 * into the next period. The switching model carries the pending edge, the average model the
 * excess duty. Nothing is carried into a period whose duty is 1 (the pole stays high anyway). */
typedef struct {
    double t[3];      /* s, switching: time into the next period of leg j's pending edge; < 0: none */
    int on[3];        /* -, switching: pole state that edge sets (1 high, 0 low) */
    double excess[3]; /* -, average: duty beyond 1 carried into the next period */
    bool any_excess;  /* -, average: some excess[j] != 0 */
} ls_sim_carry;

static const ls_sim_carry ls_sim_no_carry = {{-1.0, -1.0, -1.0}, {0, 0, 0}, {0.0, 0.0, 0.0}, false};

/* One period h of the linear plant with the duties (average model), i updated */
LS_SIM_HOT void ls_sim_period_average(const ls_sim_cfg *c, const ls_sim_coef *q, const ls_sim_frozen *f,
                                      const double duty[3], double h, double i[2], ls_sim_carry *carry);
/* the same on the saturated plant; f_end: the force at the period end; false: diverged */
LS_SIM_INTERNAL bool ls_sim_period_average_sat(const ls_sim_cfg *c, const ls_sim_coef *q, const ls_sim_frozen *f,
                                               const ls_sim_sat_frame *sf, double omega, const double duty[3],
                                               double h, double i[2], ls_sim_carry *carry, double *f_end);
/* One period of the switching model, the linear plant; f_int: the force integral over it (N s) */
LS_SIM_INTERNAL void ls_sim_period_switching(const ls_sim_cfg *c, const ls_sim_coef *q, const ls_sim_frozen *f,
                                             const ls_sim_maps *pm, const double duty[3], double h, double i[2],
                                             double *f_int, ls_sim_carry *carry);
/* the same on the saturated plant (bad: it diverged) */
LS_SIM_INTERNAL void ls_sim_period_switching_sat(const ls_sim_cfg *c, const ls_sim_coef *q, const ls_sim_frozen *f,
                                                 const double duty[3], double h, double i[2], double *f_int,
                                                 ls_sim_carry *carry, const ls_sim_sat_frame *sf, double omega,
                                                 bool *bad);

/* ------------------------------------------------------------------------------ sensors (ls_sim_sensors.c) */
/* the drive's measurement of currents i_ab and position x (the encoder only when asked) */
LS_SIM_HOT void ls_sim_measure(const ls_sim_cfg *c, const ls_sim_coef *q, const double i_ab[2], double x,
                               bool encoder, uint64_t *rng, ls_meas *m);

/* ------------------------------------------------------------------------------ mechanics (ls_sim_mech.c) */
/* advance x, v over h from time t with the motor force average f_avg */
LS_SIM_HOT void ls_sim_mechanics(const ls_sim_cfg *c, const ls_sim_coef *q, double t, double h, double f_avg,
                                 double *x, double *v);

/* ------------------------------------------------------------------------------ recording (ls_sim_record.c) */
/* Block statistics of the samples being recorded (ls_sim_out x_min ... i_abc_max) */
typedef struct {
    int64_t r;                   /* -, local index of the sample whose block is open; < 0: none */
    int32_t n;                   /* -, periods in it so far */
    double x_lo, x_hi, x_sum;    /* m */
    double e_lo, e_hi, e_sum;    /* rad */
    double i_lo[3], i_hi[3];     /* A */
} ls_sim_block;

/* the drive position of x (m) */
LS_SIM_INTERNAL ls_pos ls_sim_pos_of_m(double x, double tau);
/* theta_err of the drive's estimate against the true position x (rad, wrapped) */
LS_SIM_INTERNAL double ls_sim_est_err(const ls_cmd *cmd, double x, double tau, double kx);
/* sample r of the outputs (cmd NULL: the open loop, no drive) */
LS_SIM_INTERNAL void ls_sim_record(const ls_sim_out *o, int64_t r, double t, double x, double v, const double i[2],
                                   double cth, double sth, const double u[3], double force, const ls_cmd *cmd,
                                   double tau, double kx, uint32_t fault);
LS_SIM_INTERNAL void ls_sim_block_open(ls_sim_block *b, int64_t r, double x, double e, const double i[2]);
LS_SIM_INTERNAL void ls_sim_block_add(ls_sim_block *b, double x, double e, const double i[2]);
LS_SIM_INTERNAL void ls_sim_block_write(const ls_sim_out *o, const ls_sim_block *b);

#endif /* LINSENSE_LS_SIM_INTERNAL_H */
