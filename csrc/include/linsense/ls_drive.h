/* linsense firmware library: the drive, called once per PWM period.
 *
 *   ls_drive_step(drive, &meas, &cmd)
 *
 * in:  phase currents sampled at the carrier peak, DC-bus voltage, optional encoder count;
 * out: duty cycles for the next period, enable, fault bits, estimates and diagnostics.
 *
 * Call order inside a step (docs/firmware.md): protection on the measurements; Clarke; encoder
 * tracking loop (sensored, calibration); the dead-time residual's current taken out of the HF
 * path (hf_dtres); HF band-pass and fundamental notch; demodulator
 * in the compensated frame and HF observer (sensorless, calibration); position reference
 * (trajectory or step; calibration sequence); position/speed control -> force -> i_q reference;
 * d/q current control on the feedback angle; HF injection added on the estimated d-axis;
 * modulator with the angle advanced for the one-period computation delay; observer-loss checks.
 *
 * HF injection shapes (cfg.inject.shape, docs/firmware.md): pulsating or elliptical on the estimated
 * d-axis (the paper's; band-pass, product or heterodyne demodulation); rotating in the stationary
 * frame (band-pass, negative-sequence demodulation LS_DEMOD_ROTATING, its own table psi_rot and gain
 * schedule); square wave at fs/2 on the estimated d-axis (cfg.bpf is then the first difference
 * LS_BIQUAD_DIFF, the current's change over one period, for the product demodulator, and cfg.sep
 * a low-pass, whose zeros at fs/2 remove the square wave from the fundamental).
 *
 * Modes:
 *   LS_MODE_OFF              outputs disabled, estimators idle
 *   LS_MODE_SENSORED         encoder closes every loop (HF injection optional, on the encoder's
 *                            d-axis: with inject_sensored, cmd.pos_est is the HF estimate beside the
 *                            encoder, its position plus the error demodulated there with the table
 *                            when there is one: where a sensorless observer would settle)
 *   LS_MODE_SENSORLESS_LUT   HF observer with the compensation table (cfg.demod.comp required);
 *                            with cfg.emf_on the EMF estimate takes over at speed (ls_fuse.h)
 *   LS_MODE_SENSORLESS_NOLUT HF observer without compensation (the paper's unstable case)
 *   LS_MODE_CALIBRATION      encoder closes the position loop; at each of cal.points positions of
 *                            one electrical period (move, settle, adapt) the HF injection and the
 *                            demodulator run on the encoder angle and an integrator adjusts the
 *                            compensation angle until the demodulated error is zero, i.e. until
 *                            the sensorless observer's equilibrium agrees with the encoder; the
 *                            result is written to cal.table (paper Fig. 9, "measured" LUT)
 *   LS_MODE_STARTUP          start-up from an unknown position (ls_startup.h, cfg.startup and
 *                            cfg.demod.comp required, startup.t_quiet and t_settle at least the
 *                            injection's ramp time): HF lock on the axis modulo pi with zero
 *                            currents, d-axis pulse pairs for the magnet polarity (the estimate
 *                            turned by pi when they say so), HF relock, then LS_MODE_SENSORLESS_LUT
 *                            by itself with the reference at the estimate (no jump); su holds the
 *                            decision; a failed start-up trips LS_FAULT_OBSERVER
 *   LS_MODE_COMMISSION       the end-effect table learned without a sensor (ls_drive_commission.c;
 *                            cfg.emf_on, cal.table, cal.learn and demod.comp over cal.table
 *                            required): the sensorless step of cfg.emf_on with the injection kept
 *                            on at every speed; while the estimated speed is at least fuse.v_hi
 *                            (the EMF error alone drives the observer) the demodulator's error
 *                            with the table is learned into it at the estimated angle, forward and
 *                            backward apart (cal.learn) and the table their mean; the caller moves
 *                            the mover back and forth (ls_drive_move_to); cmd.cal_index counts the
 *                            points seen cal.t_hold in both directions, cmd.cal_done when all are
 */
#ifndef LINSENSE_LS_DRIVE_H
#define LINSENSE_LS_DRIVE_H

#include "linsense/ls_biquad.h"
#include "linsense/ls_current.h"
#include "linsense/ls_demod.h"
#include "linsense/ls_dtres.h"
#include "linsense/ls_emf.h"
#include "linsense/ls_fuse.h"
#include "linsense/ls_inject.h"
#include "linsense/ls_lut.h"
#include "linsense/ls_mod.h"
#include "linsense/ls_observer.h"
#include "linsense/ls_pi.h"
#include "linsense/ls_pos.h"
#include "linsense/ls_posctrl.h"
#include "linsense/ls_protect.h"
#include "linsense/ls_startup.h"
#include "linsense/ls_traj.h"
#include "linsense/ls_types.h"

#define LS_FAULT_ENCODER 0x80u /* encoder needed by the mode but not valid, a count jump beyond
                                  enc_v_max, or a count beyond +-LS_POS_PERIOD_MAX periods */

/* Bounds ls_drive_init enforces beyond each module's own (docs/firmware.md) */
#define LS_DRIVE_FS_MAX LS_R(1.0e6)    /* Hz, largest sampling rate */
#define LS_DRIVE_I_MAX LS_R(1.0e5)     /* A, largest current limit (i_max, prot.i_max) */
#define LS_DRIVE_V_DC_MAX LS_R(1.0e5)  /* V, largest bus-voltage limit (prot.v_dc_max) */
#define LS_DRIVE_ENC_JUMP_MAX LS_R(1.0e9) /* -, largest enc_v_max in counts per step */
#define LS_DRIVE_POLE_PITCH_MAX LS_R(10.0) /* m, largest pole pitch (a speed in m/s stays finite) */
#define LS_DRIVE_RIPPLE_ORDER_MAX 64 /* -, highest ripple_order (ripple_order theta stays in ls_sincos's fast range) */
#define LS_DRIVE_RIPPLE_MAX LS_R(0.5)  /* -, largest |ripple_c| + |ripple_s| */
/* -, the injection's largest share of the linear modulation range at the under-voltage limit,
 * inject.amplitude sqrt(3) / prot.v_dc_min (below it: the fundamental gets the rest) */
#define LS_DRIVE_V_INJ_SHARE_MAX LS_R(0.8)
/* -, the least share of the force constant a d-current may leave (1 + kf_id i_d with kf_id =
 * (current.l_d - current.l_q) / current.psi_pm: the reluctance force; i_d_inj and i_d_near) */
#define LS_DRIVE_KF_SHARE_MIN LS_R(0.5)
/* -, LS_MODE_COMMISSION: the largest cal.slope (the pulsating injection's is 1) */
#define LS_DRIVE_CAL_SLOPE_MAX LS_R(2.0)
/* -, LS_MODE_COMMISSION learns where the estimated speed is at least this share of traj.v_max
 * (the cruise of the moves: both directions at one speed, so that what follows the speed cancels
 * in their mean) */
#define LS_DRIVE_LEARN_CRUISE LS_R(0.95)
/* -, ... and where the trajectory cruises: its acceleration output (low-passed) below this share of
 * its acceleration, for cal.t_settle (the speed loop and the EMF estimate settled after the
 * acceleration) */
#define LS_DRIVE_LEARN_A_CRUISE LS_R(1.0e-3)

/* Whether an injection of `amplitude` (V, peak) leaves the fundamental its share of the linear range
 * at the under-voltage limit `v_dc_min` (V): ls_drive_init refuses a configuration where it does not
 * (and linsense's design and scenario checks ask this function, through the binding). */
static inline bool ls_drive_inject_fits(LS_REAL amplitude, LS_REAL v_dc_min)
{
    return !(amplitude * LS_SQRT3 / v_dc_min >= LS_DRIVE_V_INJ_SHARE_MAX);
}

typedef enum {
    LS_MODE_OFF = 0,
    LS_MODE_SENSORED = 1,
    LS_MODE_SENSORLESS_LUT = 2,
    LS_MODE_SENSORLESS_NOLUT = 3,
    LS_MODE_CALIBRATION = 4,
    LS_MODE_STARTUP = 5,
    LS_MODE_COMMISSION = 6
} ls_mode;

typedef struct {
    uint32_t points;  /* -, table length over one electrical period, >= 4 */
    float *table;     /* rad, caller-owned output table of `points` values (NULL: no calibration) */
    LS_REAL k_int;    /* 1/s, adaptation: d psi_cal/dt = k_int * demodulated ratio, > 0 */
    LS_REAL t_settle; /* s, wait after each move before adapting, >= 0 */
    LS_REAL t_hold;   /* s, averaging window: a point is accepted after a window whose mean
                         demodulated error is below tol, with the window's mean angle, > 0 */
    LS_REAL tol;      /* rad, acceptance threshold on that mean error (the observer's error against
                         the encoder, electrical rad), > 0 */
    LS_REAL t_max;    /* s, a point not accepted within this time trips LS_FAULT_OBSERVER, > 0 */
    int32_t period;   /* -, the electrical period (encoder periods) swept by the calibration */
    LS_REAL dither_amp;  /* A, q-current dither added while settling and adapting: it sweeps the
                            phase currents through zero so that the dead time averages out instead
                            of acting as a relay on the near-zero force current (0: none), >= 0 */
    LS_REAL dither_freq; /* Hz, its frequency (well above the position loop, below the demodulator
                            low-pass; its motion is amp K_f / (m w^2)), > 0 if dither_amp > 0 */
    float *learn;     /**< unit: rad and s, LS_MODE_COMMISSION: caller-owned work of 4 points floats,
                           the table's forward estimate, its backward estimate (rad), then the time
                           each point was seen moving forward, backward (s; linear weights); NULL:
                           no commissioning. There cal.k_int (1/s) is the estimates' rate
                           (k_int / fs < 1), cal.t_hold (s) the time each point needs in each
                           direction and cal.t_settle (s) the wait after each acceleration */
    LS_REAL slope;    /**< unit: -, LS_MODE_COMMISSION: the demodulated ratio's change per rad of the
                           table's error, -d ratio / d psi at the table (1 for the pulsating
                           injection, 0.2-0.5 for the elliptical one at kappa 0.9: the design's,
                           linsense.studies.commission.ratio_slope), in (0, LS_DRIVE_CAL_SLOPE_MAX] */
} ls_cal_cfg;

typedef struct {
    uint32_t lib_version;   /* -, the LS_VERSION the configuration was made for: ls_drive_default_cfg
                               sets this library's, a generated ls_cfg_*.h the version of linsense
                               that wrote it; ls_drive_init refuses another (LS_ERR_VERSION) */
    LS_REAL fs;             /* Hz, control sampling rate = PWM frequency, > 0 */
    LS_REAL pole_pitch;     /* m, one electrical period tau, in (0, LS_DRIVE_POLE_PITCH_MAX]; obs, enc_obs
                               and traj use the same */
    LS_REAL force_constant; /* N/A, per peak phase current, > 0 */
    LS_REAL i_max;          /* A, limit of the current reference, > 0 */
    LS_REAL delay_comp;     /* -, angle advance of the voltage in sampling periods (1.5 for a
                               one-period computation delay plus the half-period average), >= 0 */
    LS_REAL hf_delay;       /* s, the HF path's delay, in [0, 0.1]: the pulsating and elliptical
                               injections' demodulated error is advanced by omega hf_delay (the
                               estimated axis turns while the HF current passes the band-pass; about
                               one injection period, docs/tuning.md); 0: none */
    int32_t enc_counts;     /* -, encoder counts per electrical period, > 0 */
    LS_REAL enc_v_max;      /* m/s, encoder plausibility: a count change between two samples of
                               more than enc_v_max / fs of travel (and more than one count) trips
                               LS_FAULT_ENCODER; > 0, at most LS_DRIVE_ENC_JUMP_MAX counts per step */
    bool inject_sensored;   /* keep injecting in LS_MODE_SENSORED (and estimate beside the encoder) */
    bool hf_dtres;          /* take the current the dead-time residual drove out of the HF path (not
                               with the square wave) */
    bool load_ff;           /* the sensorless modes: feed the HF observer's load-force estimate forward
                               into the force reference (obs.type LS_OBS_MECH, pos.mass > 0) and hold
                               the speed PI's integrator at 0 (the estimate is the integral action: the
                               load is taken up at the observer's bandwidth); the encoder modes keep the
                               PI (docs/tuning.md, "The observer") */
    ls_inject_cfg inject;   /* HF injection */
    ls_biquad_cfg bpf;      /* HF band-pass on the alpha-beta currents (LS_BIQUAD_BANDPASS; with the
                               square wave LS_BIQUAD_DIFF) */
    ls_biquad_cfg sep;      /* fundamental separation (LS_BIQUAD_NOTCH at the injection
                               frequency, or LS_BIQUAD_LOWPASS) */
    ls_demod_cfg demod;     /* demodulator; demod.comp is the compensation table */
    ls_observer_cfg obs;    /* HF position observer */
    ls_observer_cfg enc_obs; /* encoder tracking loop (speed from the encoder) */
    ls_current_cfg current; /* d/q current controller */
    ls_posctrl_cfg pos;     /* position (and speed) controller */
    ls_traj_cfg traj;       /* trajectory generator */
    ls_mod_cfg mod;         /* modulator */
    ls_dtres_cfg dtres;     /* response model of the dead-time residual (used if hf_dtres); with
                               dtres.adapt_r its measured resistance scale k_r (ls_dtres_adapt; held
                               in the start-up and LS_MODE_SENSORLESS_NOLUT, kept across
                               ls_drive_set_mode, 1 after ls_drive_reset) also scales current.ki
                               (which it takes for R_s w_c, the design's rule: set adapt_r false
                               to keep a hand-set ki) and corrects the demodulator's tables
                               (demod.comp_r, demod.gain_r). k_r is only as good as mod.dead_time:
                               a dead time off by 0.1 us moves it by about 3 % */
    ls_protect_cfg prot;    /* protection */
    ls_cal_cfg cal;         /* LUT calibration */
    LS_REAL i_d_inj;        /* A, d-axis current reference while the HF injection is on (0: none): keeps
                               the phase currents off zero, where the dead time would act on the
                               square wave's current change (docs/firmware.md), |i_d_inj| < i_max */
    LS_REAL i_d_near;       /* A, the square wave's sensorless step only (ls_drive_square.c): the
                               d-current reference while injecting near the six positions per period
                               where the current reference's vector (i_d_inj, i_q_ref) in the
                               estimated frame is normal to a phase axis (at no load the d-axis:
                               theta = pi/6 + k pi/3), whose phase current then lies in the dead
                               time's relay band (docs/theory.md); |i_d_near| < i_max */
    LS_REAL near_in;        /* rad, electrical angle from the nearest of those positions below which
                               i_d_near replaces i_d_inj, [0, near_out] */
    LS_REAL near_out;       /* rad, ... above which i_d_inj returns (the hysteresis), < pi/6; 0: no
                               such schedule (i_d_inj everywhere) */
    bool emf_on;            /**< unit: -, the sensorless modes with the pulsating or elliptical injection:
                                 the EMF estimate beside the HF one, handed over on the speed and the
                                 injection faded out at speed (emf, fuse; docs/theory.md, "The
                                 hand-over"); not with the rotating vector or the square wave */
    ls_emf_cfg emf;         /* the EMF estimate (with emf_on; emf.fs = fs) */
    ls_fuse_cfg fuse;       /* the hand-over band and the injection's fade (with emf_on; fuse.fs = fs,
                               fuse.pole_pitch = pole_pitch) */
    ls_startup_cfg startup; /* start-up with the magnet polarity (startup.pairs = 0: none, and
                               LS_MODE_STARTUP refused); startup.fs = fs */
    int32_t ripple_order;   /**< unit: -, the order n (per electrical period) of the force constant's
                                 ripple the current reference divides out: i_q = F / (force_constant
                                 (1 + ripple_c cos(n theta) + ripple_s sin(n theta))) at the position
                                 the controllers use (a PM flux's 5th and 7th harmonics: n = 6;
                                 docs/tuning.md, "Friction and thrust ripple"), in [0, 64]; 0: none
                                 (and not a cycle spent) */
    LS_REAL ripple_c;       /**< unit: -, its cosine share of force_constant, |ripple_c| + |ripple_s| <=
                                 LS_DRIVE_RIPPLE_MAX */
    LS_REAL ripple_s;       /**< unit: -, its sine share of force_constant */
} ls_drive_cfg;

typedef struct {
    LS_REAL i_abc[3]; /* A, phase currents sampled at the carrier peak */
    LS_REAL v_dc;     /* V, DC-bus voltage */
    bool enc_valid;   /* encoder count available */
    int32_t enc_count; /* -, encoder count (enc_counts per electrical period, 0 at theta = 0) */
} ls_meas;

typedef struct {
    LS_REAL duty[3];     /* -, duty cycles for the next PWM period, [0, 1] */
    bool enable;         /* gate drivers enabled */
    uint32_t fault;      /* latched LS_FAULT_* bits */
    ls_mode mode;        /* active mode */
    ls_pos pos_fb;       /* position used by the controllers (encoder or HF estimate) */
    ls_pos pos_est;      /* HF position estimate: the observer's (sensorless modes), the encoder's
                            position plus the error demodulated there (LS_MODE_SENSORED) */
    ls_pos pos_ref;      /* position reference */
    LS_REAL v_est;       /* m/s, speed of pos_est (LS_MODE_SENSORED: the encoder's) */
    LS_REAL v_fb;        /* m/s, speed used by the controllers */
    LS_REAL f_load_est;  /* N, load-force estimate (mechanical observer) */
    LS_REAL err_sig;     /* rad, demodulated error (estimate of theta - theta_est) */
    bool err_valid;      /* HF signal strong enough */
    LS_REAL hf_level;    /* A^2, mean-square HF current */
    LS_REAL psi_comp;    /* rad, compensation angle used by the demodulator */
    LS_REAL i_dq[2];     /* A, fundamental currents in the feedback frame */
    LS_REAL i_dq_ref[2]; /* A, current references */
    LS_REAL v_dq[2];     /* V, fundamental voltage references */
    LS_REAL v_hf;        /* V, HF injection voltage of this step */
    uint32_t cal_index;  /* -, calibration point in progress (= points when done) */
    bool cal_done;       /* calibration finished, table written */
    LS_REAL psi_cal;     /* rad, calibration compensation angle */
} ls_cmd;

typedef enum {
    LS_CAL_MOVE = 0,
    LS_CAL_SETTLE = 1,
    LS_CAL_ADAPT = 2,
    LS_CAL_DONE = 3
} ls_cal_phase;

typedef struct {
    ls_drive_cfg cfg;    /* copy of the configuration */
    bool initialised;    /* ls_drive_init succeeded */
    ls_mode mode;        /* active mode */
    bool hf_on;          /* the mode injects and estimates (set with it) */
    LS_REAL v_hf_max;    /* V, voltage kept for the injection (its amplitude with hf_on, else 0) */
    bool align;          /* re-align estimators and reference at the next step */
    bool pending;        /* a move or step commanded before the alignment, applied after it */
    bool pending_move;   /* the pending command is a move (else a step) */
    ls_pos pending_target; /* its target */
    ls_inject inj;
    ls_biquad bpf[2];    /* alpha, beta */
    ls_biquad sep[2];    /* alpha, beta */
    ls_demod demod;
    ls_observer obs;
    ls_observer enc;
    ls_current cur;
    ls_posctrl pos;
    ls_traj traj;
    ls_mod mod;
    ls_dtres dtres;
    ls_protect prot;
    ls_emf emf;          /* the EMF estimate (cfg.emf_on) */
    ls_fuse fuse;        /* the hand-over and the injection's fade (cfg.emf_on) */
    LS_REAL f_ref;       /* N, force reference of the last step */
    LS_REAL w_ref;       /* rad/s, the trajectory's electrical speed at the sensorless modes' last
                            step (0 in the others): the dead-time residual model's back-EMF
                            (ls_drive_residual_) */
    LS_REAL ts;          /* s */
    LS_REAL kx;          /* rad/m, 2 pi / tau */
    LS_REAL inv_kx;      /* m/rad, tau / (2 pi) */
    LS_REAL kf;          /* N/A, the force constant at i_d_ref: force_constant (1 + kf_id i_d_ref),
                            with the d-current's reluctance force (ls_drive_set_i_d_) */
    LS_REAL inv_kf;      /* A/N, 1 / kf */
    LS_REAL kf_id;       /* 1/A, (l_d - l_q) / psi_pm of cfg.current's model (0 with psi_pm 0): the
                            force constant's change per ampere of d-current */
    LS_REAL ff_load_k;   /* 1/kg, the load-force estimate's share of the acceleration feed-forward:
                            1 / pos.mass with load_ff, else 0 */
    LS_REAL integ_keep;  /* -, the sensorless step's factor on the speed PI's integrator: 0 with
                            load_ff, else 1 */
    LS_REAL delay_ts;    /* s, delay_comp ts: angle advance per rad/s of speed */
    ls_cal_phase cal_phase;
    uint32_t cal_index;
    uint32_t cal_timer;  /* steps in the present phase */
    uint32_t cal_hold;   /* steps in the present averaging window */
    LS_REAL psi_cal;     /* rad */
    LS_REAL cal_c, cal_s; /* -, cos and sin of psi_cal: turned with it by its small steps, exact
                             again at the start, the end and every reset of an averaging window */
    LS_REAL cal_sum_err; /* rad, sum of the demodulated error over the window */
    LS_REAL cal_sum_psi; /* rad, sum of psi_cal over the window */
    uint32_t cal_n_settle; /* -, steps of cal.t_settle: the first n with n ts >= t_settle */
    uint32_t cal_n_hold;   /* -, steps of cal.t_hold: the first n with n ts >= t_hold */
    uint32_t cal_n_max;    /* -, steps beyond cal.t_max: the first n with n ts > t_max */
    uint32_t cal_acc;    /* -, the dither's phase, 2^32 per period */
    uint32_t cal_inc;    /* -, its step per period: dither_freq / fs 2^32 */
    LS_REAL learn_w;     /**< unit: rad/s, LS_MODE_COMMISSION learns at |omega| >= it: fuse.v_hi and
                              LS_DRIVE_LEARN_CRUISE traj.v_max, the larger, as electrical speeds */
    LS_REAL learn_inv_s; /**< unit: -, 1 / cal.slope */
    LS_REAL learn_kd;    /**< unit: s, hf_delay / demod.gain: the HF path's delay in the ratio per rad/s */
    uint32_t learn_turn; /**< unit: -, LS_MODE_COMMISSION: 1 in a step that may learn (two periods' worth),
                              0 in one that takes the EMF's angle; they alternate (the time budget) */
    LS_REAL cal_amp;     /* A, the dither's amplitude now: cal.dither_amp while settling and
                            adapting, else 0 */
    int32_t enc_prev;    /* -, encoder count of the last sample (encoder modes) */
    int64_t enc_jump_max; /* -, largest plausible count change per step (>= 1) */
    LS_REAL i_d_ref;     /* A, d-current reference (cfg.i_d_inj with hf_on, else 0; i_d_near near the
                            positions of cfg.near_in) */
    LS_REAL near_c3_in;  /* -, sin(3 near_in): |cos(3 phi)| below it is near, phi the angle of the
                            current reference's vector (ls_drive_square.c) */
    LS_REAL near_c3_out; /* -, sin(3 near_out) (0: no schedule) */
    uint8_t path;        /* the step that runs: its entry in the step table (csrc/ctrl/ls_drive.c),
                            by mode and injection shape */
    LS_REAL enc_k;       /* rad, 2 pi / enc_counts: the angle of one encoder count */
    /* LS_MODE_STARTUP: while it runs, mode holds LS_MODE_OFF and starting is set (the step table's
     * start-up row runs) */
    bool starting;       /* the start-up sequence runs (cmd.mode reports LS_MODE_STARTUP) */
    ls_startup su;       /* its sequence and decision (su.flip, su.i_diff, su.phase, su.steps) */
} ls_drive;

/* Fill cfg with the defaults documented in docs/firmware.md: 16 kHz, 12 V / 1 kHz injection and
 * the ecce2010 reference motor; the caller then sets its tables, motor and gains. */
void ls_drive_default_cfg(ls_drive_cfg *cfg);
/* Validate every module's configuration; LS_ERR_PARAM names no field, but each module's
 * ls_<module>_init can be called alone to find it. LS_ERR_VERSION: cfg->lib_version is not this
 * library's LS_VERSION (a header generated by another linsense: regenerate it). */
ls_status ls_drive_init(ls_drive *d, const ls_drive_cfg *cfg);
/* Clear every state and fault; mode OFF; position estimates at p (normalised; a non-finite theta
 * counts as 0, a position beyond +-LS_POS_PERIOD_MAX periods saturates at that end). */
void ls_drive_reset(ls_drive *d, ls_pos p);
/* Change mode (LS_ERR_PARAM if the mode needs a table or encoder setting it lacks). */
ls_status ls_drive_set_mode(ls_drive *d, ls_mode mode);
/* The setters below return LS_OK, LS_ERR_NULL (no drive or not initialised) or LS_ERR_PARAM and
 * then change nothing: a position whose theta is not finite or which lies beyond
 * +-LS_POS_PERIOD_MAX periods once normalised (ls_pos_check) is refused, never saturated, so that
 * the drive never moves towards a target it was not given. */
/* Tell the HF observer where the mover is (sensorless start from a known position). */
ls_status ls_drive_set_position(ls_drive *d, ls_pos p);
/* Start in equilibrium with a known load force f_load (N, opposing positive motion when > 0,
 * e.g. gravity on an incline): the speed controller's integrator (position type P) and the HF
 * mechanical observer's load estimate (sensorless modes: in sensored and calibration modes the
 * alignment to the encoder resets that observer) are preset to it, so that the drive produces the
 * force from the first step instead of sagging until its integrators catch up. Call after
 * ls_drive_set_position (which clears the controllers). A non-finite f_load is refused
 * (LS_ERR_PARAM); a finite one is limited to the force limits of the speed controller and of the
 * observer. */
ls_status ls_drive_set_load(ls_drive *d, LS_REAL f_load);
/* Minimum-time move of the reference to target. Commanded right after ls_drive_set_mode, it
 * starts once the mode has aligned its reference to the measured or estimated position. Ignored
 * (LS_OK, nothing changes) in calibration mode, which moves by itself. */
ls_status ls_drive_move_to(ls_drive *d, ls_pos target);
/* Step the reference to target (as ls_drive_move_to, without the profile). */
ls_status ls_drive_step_to(ls_drive *d, ls_pos target);
/* One PWM period: the step of the active mode and injection shape (which one: the step table in
 * csrc/ctrl/ls_drive.c; the files of the drive: csrc/ctrl/ls_drive_internal.h).
 * d, meas and cmd are three distinct objects that do not overlap (the step reads and writes them
 * as such: restrict inside the library). */
void ls_drive_step(ls_drive *d, const ls_meas *meas, ls_cmd *cmd);
#endif /* LINSENSE_LS_DRIVE_H */
