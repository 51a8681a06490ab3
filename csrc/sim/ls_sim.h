/* linsense host-side simulator: plant, inverter and sensors around the unchanged controller.
 *
 * Not firmware: double precision, host only. One call runs a whole scenario in C and writes
 * numpy-ready arrays; Python (linsense.sim) only configures it and reads the results.
 *
 * Plant (moving-armature linear motor, floating star point), state: alpha-beta currents i,
 * position x, speed v. Flux linkage lambda = L_ab(theta) i + lambda_pm(theta), theta = 2 pi x/tau
 * (the linear plant, the default; with sat.on the saturated plant replaces L_ab(theta) i, see
 * ls_sim_sat below):
 *   L_ab(theta): Fourier series of the three alpha-beta entries (L_aa, L_bb, L_ab), computed by
 *                linsense from the motor's inductance model (eq. 3, harmonics or a table);
 *   lambda_pm:   psi_pm (cos theta, sin theta) plus relative harmonics of order n with phase
 *                phi_n: psi_pm a_n (cos(n theta + phi_n) ... ) as (alpha, beta) of the
 *                three-phase set (see ls_sim_plant_eval); with the end effect on the magnets'
 *                flux (pm_dscale, pm_shift not all 0) phase k's whole PM flux waveform is scaled
 *                by 1 + pm_dscale[k] and advanced by pm_shift[k], psi_k = (1 + ds_k) psi_pm
 *                f(theta - 2 pi k/3 + shift_k) with f(u) = cos u + sum_n a_n cos(n u + phi_n),
 *                and lambda_pm is the amplitude-invariant Clarke transform of (psi_a, psi_b,
 *                psi_c) (its zero sequence drives no current with the floating star point);
 *   voltage:     v = R i + d lambda/dt   (amplitude-invariant alpha-beta)
 *   force:       co-energy, F = (3/2) (2 pi/tau) [ i' d lambda_pm/d theta + 1/2 i' dL_ab/d theta i ]
 *   mechanics:   m dv/dt = F - F_load(t, x) - b v - F_c sign(v) (stiction: v held at 0 while
 *                |F - F_load| <= F_c), travel limits -> LS_SIM_FAULT_TRAVEL.
 * Each PWM period (or switching segment) the 2x2 electrical system is frozen at the mid-period
 * position and speed and propagated with the 4th-order Taylor polynomial of its matrix (error ~1e-6
 * per period at 16 kHz), the mechanics with the trapezoidal force average. In the closed loop the
 * mid-period position and speed are extrapolated from the two previous periods (exact for a
 * constant acceleration; otherwise off by h^2 times the change of acceleration, nanometres), so
 * that a period's matrices do not wait for the previous period's force.
 *
 * Inverter, 2-level, centre-aligned PWM, period starting at the carrier peak (where currents are
 * sampled); duties computed from sample k act during period k+1 (one-period computation delay):
 *   LS_SIM_AVERAGE:   pole voltage (d - (t_dead f_pwm / 2)(sign i_on + sign i_off)) V_dc over the
 *                     whole period, i_on/i_off the phase current predicted at the leg's turn-on
 *                     and turn-off instants from the period-start current and slope (a duty
 *                     pushed beyond 1 carries the excess into the next period);
 *   LS_SIM_SWITCHING: each period integrated segment by segment between switching instants; the
 *                     upper switch of a leg is commanded on for |t - T/2| < d T/2, turn-on edges
 *                     are delayed by the dead time, and during it the freewheeling diode chosen by
 *                     the current sign fixes the pole voltage (i > 0: low, i < 0: high); a new
 *                     command cancels an edge still pending in its dead time, and an edge
 *                     delayed past the period end happens in the next period.
 * Sensors: current gain, offset, Gaussian noise and ADC quantisation (bits over +-full scale);
 * incremental encoder (counts per electrical period). */
#ifndef LINSENSE_LS_SIM_H
#define LINSENSE_LS_SIM_H

#include <stdint.h>

#include "linsense/ls_drive.h"

#define LS_SIM_MAX_ORDER 64 /* highest harmonic order of L_ab(theta) */
#define LS_SIM_MAX_PM 8     /* PM-flux harmonics */
#define LS_SIM_SAT_POW 4    /* powers 0..3 of i_q in the saturated plant's inductances */

/* The saturated plant (docs/simulator.md, "Saturation"; docs/theory.md). With on = 1 it replaces
 * the linear L_ab(theta) i of the flux linkage (lab_* then only serve ls_sim_plant_eval); the PM
 * flux is the same. In the true dq frame (i_d, i_q = Park(theta) of the alpha-beta currents) the
 * magnetic co-energy (per 3/2, like the force formula) is
 *   W(i_d, i_q, theta) = a(theta, i_q) S(i_d) + i_d B(theta, i_q) + C(theta, i_q),
 *   a = sum_p A_p(theta) i_q^p,  B = sum_p B_p(theta) i_q^(p+1)/(p+1),
 *   C = sum_p C_p(theta) i_q^(p+2)/((p+1)(p+2)),
 * A_p, B_p, C_p Fourier series in theta (dq_cos, dq_sin, entries 0, 1, 2), so that at i_d = 0 the
 * incremental inductances d2W/di2 are exactly L_d = a, L_dq = sum_p B_p i_q^p, L_q = sum_p C_p i_q^p
 * (e.g. FEA tables at several q currents, fitted by a polynomial in i_q). S is the d-axis
 * saturation: S'' = k(i_d) = f(i_d + i_m) / f(i_m), f(u) = 1/(1 + (u/i_sat_d)^2), S(0) = S'(0) = 0
 * (i_sat_d = 0: S = i_d^2/2, no d-axis saturation): a current along the magnets' flux (+d) lowers
 * the incremental L_d, one against it raises it (the magnet-polarity signal). The flux linkage is
 * lambda = dW/di + lambda_pm, the voltage v = R i + d lambda/dt is integrated with lambda as the
 * state (RK4; i from lambda by Newton's method), and the force is (3/2)(2 pi/tau) dW/dtheta at
 * constant alpha-beta currents (plus the PM term). */
typedef struct {
    int32_t on;                                          /* -, 1: saturated plant, 0: linear (lab_*) */
    int32_t n_order;                                     /* -, harmonic orders 0..n_order-1 of dq_* (<= LS_SIM_MAX_ORDER) */
    int32_t n_pow;                                       /* -, powers 0..n_pow-1 of i_q (1..LS_SIM_SAT_POW) */
    double dq_cos[LS_SIM_SAT_POW][3][LS_SIM_MAX_ORDER];  /* H/A^p, cos(k theta) coefficients of A_p, B_p, C_p */
    double dq_sin[LS_SIM_SAT_POW][3][LS_SIM_MAX_ORDER];  /* H/A^p, sin(k theta) coefficients */
    double i_m;                                          /* A, magnet-equivalent d current (>= 0) */
    double i_sat_d;                                      /* A, d-axis saturation current (0: none) */
} ls_sim_sat;

typedef enum {
    LS_SIM_AVERAGE = 0,
    LS_SIM_SWITCHING = 1
} ls_sim_fidelity;

typedef enum {
    LS_SIM_FREE = 0,       /* mechanics integrated (closed loop) */
    LS_SIM_HELD = 1,       /* mover held at x0 */
    LS_SIM_PRESCRIBED = 2  /* mover at constant speed v0 from x0 */
} ls_sim_motion;

typedef enum {
    LS_SIM_LOAD_CONSTANT = 0, /* F = load_f0 */
    LS_SIM_LOAD_STEP = 1,     /* F = load_f0 before load_t, load_f1 after */
    LS_SIM_LOAD_INCLINE = 2   /* F = load_f0 + mass * 9.81 * sin(load_incline) (gravity) */
} ls_sim_load;

/* faults of the simulation itself (the drive's own faults are reported separately) */
#define LS_SIM_FAULT_NONE 0u
#define LS_SIM_FAULT_TRAVEL 0x100u     /* the mover left [x_min, x_max] */
#define LS_SIM_FAULT_DIVERGED 0x200u   /* a plant state became non-finite or absurd */
#define LS_SIM_FAULT_STOPPED 0x400u    /* stopped from outside (ls_sim_out.stop) */
#define LS_SIM_STOP_POLL 4096          /* periods between two polls of ls_sim_out.stop */

typedef struct {
    /* motor */
    double r_s;                          /* ohm, phase resistance */
    double pole_pitch;                   /* m, one electrical period tau */
    double psi_pm;                       /* Wb, PM flux-linkage amplitude */
    int32_t n_order;                     /* -, harmonic orders 0..n_order-1 used in lab_* (<= LS_SIM_MAX_ORDER) */
    double lab_cos[3][LS_SIM_MAX_ORDER]; /* H, cos(k theta) coefficients of L_aa, L_bb, L_ab */
    double lab_sin[3][LS_SIM_MAX_ORDER]; /* H, sin(k theta) coefficients of L_aa, L_bb, L_ab */
    int32_t n_pm;                        /* -, number of PM-flux harmonics (<= LS_SIM_MAX_PM) */
    int32_t pm_order[LS_SIM_MAX_PM];     /* -, harmonic order (odd, >= 3 in practice) */
    double pm_amp[LS_SIM_MAX_PM];        /* -, amplitude relative to psi_pm */
    double pm_phase[LS_SIM_MAX_PM];      /* rad, phase */
    double pm_dscale[3];                 /* -, per-phase PM flux amplitude (phases a, b, c) relative to
                                            psi_pm, minus one (0: balanced; the end effect on the magnets' flux) */
    double pm_shift[3];                  /* rad, per-phase PM flux phase advance (a, b, c; 0: balanced) */
    double mass;                         /* kg, moving mass */
    double visc;                         /* N s/m, viscous friction */
    double coulomb;                      /* N, Coulomb friction */
    double x_min, x_max;                 /* m, travel limits */
    /* load */
    ls_sim_load load;                    /* load model */
    double load_f0;                      /* N, constant (or initial) load, opposing positive motion when > 0 */
    double load_f1;                      /* N, load after the step */
    double load_t;                       /* s, time of the step */
    double load_incline;                 /* rad, axis inclination (gravity load) */
    /* inverter */
    ls_sim_fidelity fidelity;            /* average or switching */
    double v_dc;                         /* V, DC bus */
    double f_pwm;                        /* Hz, PWM = control rate */
    double dead_time;                    /* s */
    /* sensors */
    double i_gain[3];                    /* -, current-sensor gains */
    double i_offset[3];                  /* A, current-sensor offsets */
    double i_noise;                      /* A rms, Gaussian current-sensor noise */
    int32_t adc_bits;                    /* -, ADC resolution (0: ideal) */
    double adc_range;                    /* A, full scale (+-) of the current ADC */
    int32_t enc_counts;                  /* -, encoder counts per electrical period */
    uint64_t seed;                       /* -, noise seed */
    /* run */
    ls_sim_motion motion;                /* free, held or prescribed speed */
    double x0;                           /* m, initial position */
    double v0;                           /* m/s, initial (or prescribed) speed */
    int32_t decimate;                    /* -, record every decimate-th period (>= 1) */
    double i_abort;                      /* A, |phase current| beyond which the run is stopped as diverged */
    /* saturation (sat.on = 0: the linear plant, the fast path) */
    ls_sim_sat sat;
} ls_sim_cfg;

/* A reference command issued at time t (s): move (minimum-time) or step to x (m). */
typedef struct {
    double t;     /* s */
    double x;     /* m */
    int32_t move; /* 1: ls_drive_move_to, 0: ls_drive_step_to */
} ls_sim_cmd;

/* Output arrays, each of n_rec = ceil(n_steps / decimate) samples (caller-allocated; any
 * pointer may be NULL to skip that signal). Recorded at the start of each recorded period.
 *
 * Block statistics (the *_min, *_max, *_mean arrays; NULL: not kept, and then not computed): the
 * minimum, maximum and mean over the block of `decimate` PWM periods that sample r opens (periods
 * r decimate .. r decimate + decimate - 1), of the same quantity the point array holds, taken at the
 * start of each period of the block. With decimate = 1 they equal the sample itself. A block cut
 * short by the end of the run covers the periods run; the sample that tripped a fault (recorded
 * after the last period) is a block of its own. Unlike the point values, they cannot alias: a
 * component at the decimated rate shows its whole envelope in min and max. */
typedef struct {
    double *t;         /* s */
    double *x;         /* m, true position */
    double *v;         /* m/s, true speed */
    double *x_est;     /* m, HF observer estimate */
    double *v_est;     /* m/s, HF observer speed */
    double *x_ref;     /* m, position reference */
    double *theta_err; /* rad, theta_est - theta wrapped to [-pi, pi) */
    double *i_abc;     /* A, true phase currents, 3 per sample */
    double *i_dq;      /* A, true currents in the true dq frame, 2 per sample */
    double *duty;      /* -, duties applied during the period, 3 per sample (open loop: v_abc, V) */
    double *force;     /* N, motor force (period average) */
    double *err_sig;   /* rad, demodulated error */
    uint32_t *fault;   /* drive fault bits | LS_SIM_FAULT_* */
    /* block statistics (closed loop only; ls_sim_open_loop ignores them) */
    double *x_min, *x_max, *x_mean;       /* m, true position over the block */
    double *err_min, *err_max, *err_mean; /* rad, theta_err over the block (computed every period
                                             only when one of these is requested) */
    double *i_abc_min, *i_abc_max;        /* A, true phase currents over the block, 3 per sample
                                             (the envelope of the HF and PWM ripple) */
    /* not an output: polled every LS_SIM_STOP_POLL periods by ls_sim_run; nonzero ends the run
     * there with LS_SIM_FAULT_STOPPED (another thread sets it, e.g. on Ctrl-C; NULL: never) */
    const volatile int32_t *stop;
} ls_sim_out;

typedef struct {
    int64_t steps_done;  /* -, PWM periods simulated (< n_steps when stopped early: a fault, or the end of
                            the drive's calibration in LS_MODE_CALIBRATION); ls_sim_continue: since
                            ls_sim_begin */
    int64_t n_rec;       /* -, samples written (ls_sim_continue: by this call, from out[0]) */
    uint32_t fault;      /* drive fault bits | LS_SIM_FAULT_* at the end */
    double x_end;        /* m */
    double v_end;        /* m/s */
} ls_sim_result;

/* The state of a closed-loop run between two ls_sim_continue calls (caller-allocated, filled by
 * ls_sim_begin; read-only to the caller). A run split into calls gives bit for bit the samples of
 * one ls_sim_run call of the total length. */
typedef struct {
    int64_t k;              /* -, PWM periods simulated since ls_sim_begin */
    int64_t n_rec;          /* -, samples recorded since ls_sim_begin */
    uint32_t fault;         /* drive fault bits | LS_SIM_FAULT_* so far */
    int32_t ended;          /* -, 1: a fault, a stop or the end of the calibration ended the run */
    int32_t next;           /* -, index of the next command */
    int32_t rec_count;      /* -, periods until the next recorded one (1: the next period) */
    uint64_t rng;           /* -, sensor-noise generator */
    double x, v;            /* m, m/s, plant position and speed */
    double i[2];            /* A, alpha-beta currents */
    double x_lag, v_lag, v_lag2; /* m, m/s: x and v one period back, v two back */
    double duty[3];         /* -, duties computed for the next period */
    double carry_t[3];      /* s, dead time carried into the next period (see ls_sim_inverter.c) */
    int32_t carry_on[3];    /* - */
    double carry_excess[3]; /* - */
    int32_t carry_any;      /* - */
    int32_t ang_left;       /* -, cos/sin tracker of the mid-period angle */
    double ang_th, ang_c, ang_s; /* rad, - , - */
    ls_pos est_pos;         /* -, the drive's estimate for the next sample (the last step's cmd.pos_est) */
    LS_REAL est_v;          /* m/s, its speed (the last step's cmd.v_est) */
    int32_t est_have;       /* -, 1: est_pos holds a step's estimate (0 before the first step) */
} ls_sim_state;

/* Validate the configuration (LS_ERR_PARAM names nothing; linsense.sim validates first). */
ls_status ls_sim_check(const ls_sim_cfg *cfg);

/* Closed loop: drive (initialised, mode set by the caller) around the plant for n_steps PWM
 * periods, issuing the commands at their times (sorted by t). ls_sim_begin then one
 * ls_sim_continue of n_steps. */
ls_status ls_sim_run(const ls_sim_cfg *cfg, ls_drive *drive, const ls_sim_cmd *cmds, int32_t n_cmds,
                     int64_t n_steps, const ls_sim_out *out, ls_sim_result *res);

/* The same run in chunks, so that a long run reuses small output buffers: ls_sim_begin sets the
 * plant to the configuration's initial state (t = 0), then each ls_sim_continue runs n_more_steps
 * PWM periods more (fewer when the run ends: res->fault, state->ended) with the same cfg, drive and
 * commands (times from t = 0 of the run), writing its samples from out[0] (at most
 * ceil(n_more_steps / decimate) + 1 of them; res->n_rec says how many). With block statistics a
 * chunk must start where a block starts: every chunk but the last a multiple of decimate periods
 * (otherwise LS_ERR_PARAM; a sample's block is complete when its call returns). After the run has
 * ended a call does nothing (res->n_rec = 0). */
ls_status ls_sim_begin(const ls_sim_cfg *cfg, ls_sim_state *state);
ls_status ls_sim_continue(const ls_sim_cfg *cfg, ls_drive *drive, const ls_sim_cmd *cmds, int32_t n_cmds,
                          ls_sim_state *state, int64_t n_more_steps, const ls_sim_out *out,
                          ls_sim_result *res);

/* Open loop: prescribed pole voltages (V, relative to the DC minus rail). n_seg segments of
 * durations seg_t (s) and voltages seg_v (3 per segment), applied in order; one recorded sample
 * per segment boundary (decimate ignored), i.e. n_rec = n_seg + 1 (the initial state first). */
ls_status ls_sim_open_loop(const ls_sim_cfg *cfg, const double *seg_t, const double *seg_v, int64_t n_seg,
                           const ls_sim_out *out, ls_sim_result *res);

/* Plant maps at electrical angle theta (for the Python/C agreement test): L_ab (3 entries: aa, bb,
 * ab, H), dL_ab/dtheta (3, H/rad), lambda_pm (2, Wb), d lambda_pm/dtheta (2, Wb/rad). */
void ls_sim_plant_eval(const ls_sim_cfg *cfg, double theta, double lab[3], double dlab[3], double lpm[2],
                       double dlpm[2]);

/* Force (N) at theta for alpha-beta currents i (co-energy formula above; the saturated one when
 * sat.on). */
double ls_sim_force(const ls_sim_cfg *cfg, double theta, const double i_ab[2]);

/* The saturated plant at theta and alpha-beta currents i (for the tests; cfg->sat.on need not be
 * set): flux linkage lambda_ab (2, Wb, with the PM flux), incremental inductance d lambda/d i (3:
 * aa, bb, ab, H), d lambda/d theta at constant i (2, Wb/rad) and the force (N). */
void ls_sim_sat_eval(const ls_sim_cfg *cfg, double theta, const double i_ab[2], double lam[2], double l_inc[3],
                     double dlam[2], double *force);

#endif /* LINSENSE_LS_SIM_H */
