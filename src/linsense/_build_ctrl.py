"""cffi build script of :mod:`linsense._ctrl`, the compiled binding of the C99 firmware library.

API (out-of-line) mode: ``setup.py`` names this file in ``cffi_modules``, so ``pip install``
(editable or not) compiles ``csrc/ctrl/*.c`` together with the small helpers below into the
extension ``linsense._ctrl``, with ``-std=c99 -O2`` and the default float ``LS_REAL``, as on the
MCU. The C sources live outside the package, in ``csrc/`` at the repository root; they are found
relative to this file (``src/linsense/_build_ctrl.py`` -> ``../../csrc``).

The declarations (``CDEF``) are written by hand because the headers contain ``static inline``
functions that cffi's parser cannot read. cffi checks every declared struct layout, enum value
and function signature against the real headers when it compiles, so a mismatch fails the build
instead of corrupting memory. ``LS_REAL`` is declared as ``float...``: its real type (float, or
double with ``-DLS_REAL_DOUBLE``) is taken from the headers.

Run directly (``python src/linsense/_build_ctrl.py``) to compile in place for a quick check.
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

from cffi import FFI

ROOT = Path(__file__).resolve().parents[2]
CSRC = ROOT / "csrc"
INCLUDE = CSRC / "include"
SOURCES = sorted((CSRC / "ctrl").glob("*.c")) + sorted((CSRC / "sim").glob("*.c"))

if not SOURCES or not (INCLUDE / "linsense" / "ls_drive.h").is_file():
    raise RuntimeError(f"linsense C sources not found under {CSRC} (expected csrc/ctrl/*.c, csrc/include)")


def _load_digest_module():
    """Load ``_digest.py`` beside this file by path (the package is not importable at build time)."""
    spec = importlib.util.spec_from_file_location("_linsense_digest", Path(__file__).with_name("_digest.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


source_digest = _load_digest_module().source_digest


DIGEST = source_digest(CSRC, Path(__file__).resolve())


def _rel(p: Path) -> str:
    """Path relative to the working directory when possible (setuptools prefers relative sources)."""
    try:
        return os.path.relpath(p)
    except ValueError:  # another drive (Windows)
        return str(p)


CDEF = r"""
typedef float... LS_REAL;

typedef enum { LS_OK = 0, LS_ERR_NULL = 1, LS_ERR_PARAM = 2 } ls_status;

/* ls_pos.h */
typedef struct { int32_t period; LS_REAL theta; } ls_pos;

/* ls_lut.h */
typedef struct { const float *table; uint32_t len; } ls_lut_cfg;
typedef struct { const float *table; uint32_t len; LS_REAL points_per_rad; } ls_lut;
ls_status ls_lut_init(ls_lut *lut, const ls_lut_cfg *cfg);
void ls_lut_reset(ls_lut *lut);
LS_REAL ls_lut_step(const ls_lut *lut, LS_REAL theta);

/* ls_biquad.h */
typedef enum {
    LS_BIQUAD_LOWPASS = 0, LS_BIQUAD_BANDPASS = 1, LS_BIQUAD_NOTCH = 2, LS_BIQUAD_DIFF = 3
} ls_biquad_type;
typedef struct { ls_biquad_type type; LS_REAL f0; LS_REAL q; LS_REAL fs; } ls_biquad_cfg;
typedef struct { LS_REAL b0, b1, b2; LS_REAL a1, a2; LS_REAL z1, z2; } ls_biquad;
ls_status ls_biquad_init(ls_biquad *f, const ls_biquad_cfg *cfg);
void ls_biquad_reset(ls_biquad *f);

/* ls_inject.h */
typedef enum { LS_INJ_PULSATING = 0, LS_INJ_ROTATING = 1, LS_INJ_SQUARE = 2 } ls_inject_shape;
typedef struct {
    ls_inject_shape shape; LS_REAL amplitude; LS_REAL freq; LS_REAL fs; LS_REAL ramp_rate; LS_REAL quad;
} ls_inject_cfg;
typedef struct {
    ls_inject_cfg cfg;
    LS_REAL c, s;
    LS_REAL dc, ds;
    LS_REAL amp;
    LS_REAL amp_step;
    bool on;
    LS_REAL v_q;
} ls_inject;
ls_status ls_inject_init(ls_inject *inj, const ls_inject_cfg *cfg);
void ls_inject_reset(ls_inject *inj);
void ls_inject_enable(ls_inject *inj, bool on);
LS_REAL ls_inject_step(ls_inject *inj);

/* ls_demod.h */
typedef enum { LS_DEMOD_PRODUCT = 0, LS_DEMOD_HETERODYNE = 1, LS_DEMOD_ROTATING = 2 } ls_demod_method;
typedef struct {
    ls_demod_method method;
    LS_REAL f_lpf;
    LS_REAL fs;
    LS_REAL gain;
    const ls_lut *comp;
    const ls_lut *gain_table;
    const ls_lut *comp_r;
    const ls_lut *gain_r;
    LS_REAL min_level;
    LS_REAL f_notch;
    LS_REAL ref_phase;
} ls_demod_cfg;
typedef struct {
    ls_demod_cfg cfg;
    ls_biquad lp[4];
    bool use_comp;
    bool use_gain_table;
    LS_REAL k_r;
    LS_REAL psi;
    LS_REAL level;
    LS_REAL ratio;
    LS_REAL err;
    bool valid;
    LS_REAL ref_c, ref_s;
    LS_REAL den_min;
} ls_demod;
ls_status ls_demod_init(ls_demod *d, const ls_demod_cfg *cfg);
void ls_demod_reset(ls_demod *d);
void ls_demod_set_comp(ls_demod *d, bool on);
void ls_demod_set_gain_table(ls_demod *d, bool on);
LS_REAL ls_demod_step(ls_demod *d, LS_REAL i_a, LS_REAL i_b, LS_REAL theta_est, LS_REAL car_c,
                      LS_REAL car_s, LS_REAL psi_cal);

/* ls_observer.h */
typedef enum { LS_OBS_PLL = 0, LS_OBS_MECH = 1 } ls_observer_type;
typedef struct {
    ls_observer_type type;
    LS_REAL fs;
    LS_REAL k1;
    LS_REAL k2;
    LS_REAL k3;
    LS_REAL pole_pitch;
    LS_REAL mass;
    LS_REAL omega_max;
    LS_REAL force_max;
} ls_observer_cfg;
typedef struct {
    ls_observer_cfg cfg;
    ls_pos pos;
    LS_REAL omega;
    LS_REAL f_load;
    LS_REAL ts;
    LS_REAL kx;
    LS_REAL inv_kx;
    LS_REAL k1_ts;
    LS_REAL k2_ts;
    LS_REAL acc_ts;
    LS_REAL k3_ts;
} ls_observer;
void ls_observer_gains(ls_observer_cfg *cfg, LS_REAL f_bw);
ls_status ls_observer_init(ls_observer *o, const ls_observer_cfg *cfg);
void ls_observer_reset(ls_observer *o, ls_pos p);
void ls_observer_step(ls_observer *o, LS_REAL eps, LS_REAL f_motor);

/* ls_pi.h, ls_current.h, ls_posctrl.h */
typedef struct { LS_REAL kp; LS_REAL ki; LS_REAL out_min; LS_REAL out_max; LS_REAL fs; } ls_pi_cfg;
typedef struct { ls_pi_cfg cfg; LS_REAL integ; LS_REAL ts; bool saturated; LS_REAL ki_ts; } ls_pi;
ls_status ls_pi_init(ls_pi *pi, const ls_pi_cfg *cfg);
void ls_pi_reset(ls_pi *pi);
LS_REAL ls_pi_step(ls_pi *pi, LS_REAL err, LS_REAL ff);
typedef struct {
    LS_REAL kp; LS_REAL ki; LS_REAL l_d; LS_REAL l_q; LS_REAL psi_pm; bool decouple; LS_REAL fs;
} ls_current_cfg;
typedef struct {
    ls_current_cfg cfg; LS_REAL integ_d; LS_REAL integ_q; LS_REAL ts; bool saturated; LS_REAL ki_ts;
} ls_current;
ls_status ls_current_init(ls_current *c, const ls_current_cfg *cfg);
void ls_current_reset(ls_current *c);
void ls_current_step(ls_current *c, LS_REAL i_d, LS_REAL i_q, LS_REAL i_d_ref, LS_REAL i_q_ref,
                     LS_REAL omega, LS_REAL v_max, LS_REAL *v_d, LS_REAL *v_q);
#define LS_POS_PERIOD_MAX 16777216
typedef enum { LS_POSCTRL_P = 0, LS_POSCTRL_PD = 1 } ls_posctrl_type;
typedef struct {
    ls_posctrl_type type;
    LS_REAL kp_x;
    LS_REAL kd_x;
    LS_REAL v_max;
    ls_pi_cfg speed;
    LS_REAL mass;
    LS_REAL force_max;
} ls_posctrl_cfg;
typedef struct { ls_posctrl_cfg cfg; ls_pi speed; LS_REAL v_ref; } ls_posctrl;
ls_status ls_posctrl_init(ls_posctrl *p, const ls_posctrl_cfg *cfg);
void ls_posctrl_reset(ls_posctrl *p);
LS_REAL ls_posctrl_step(ls_posctrl *p, LS_REAL x_err, LS_REAL v, LS_REAL v_ff, LS_REAL a_ff);

/* ls_traj.h */
typedef struct {
    LS_REAL v_max; LS_REAL a_max; LS_REAL v_step; LS_REAL a_step; LS_REAL a_lpf;
    LS_REAL pole_pitch; LS_REAL fs;
} ls_traj_cfg;
typedef struct {
    ls_traj_cfg cfg;
    ls_pos start;
    ls_pos target;
    bool active;
    ...;
} ls_traj;
ls_status ls_traj_init(ls_traj *t, const ls_traj_cfg *cfg);
void ls_traj_reset(ls_traj *t, ls_pos p);
void ls_traj_move(ls_traj *t, ls_pos target);
void ls_traj_jump(ls_traj *t, ls_pos target);
void ls_traj_step(ls_traj *t, ls_pos *x_ref, LS_REAL *v_ref, LS_REAL *a_ref);

/* ls_dtres.h */
typedef struct {
    LS_REAL fs; LS_REAL r_s; LS_REAL l_d; LS_REAL l_q; bool forward; bool adapt; bool adapt_r;
    LS_REAL l_ea; LS_REAL l_eb;
} ls_dtres_cfg;
typedef struct {
    ls_dtres_cfg cfg; LS_REAL a_d, a_q; LS_REAL b_d, b_q; LS_REAL i_d, i_q; LS_REAL k_rip; LS_REAL k_l;
    LS_REAL k_r; LS_REAL s[7]; LS_REAL hp[6]; uint32_t n_solve;
    LS_REAL k_r_resp;
} ls_dtres;
ls_status ls_dtres_init(ls_dtres *r, const ls_dtres_cfg *cfg);
void ls_dtres_reset(ls_dtres *r);

/* ls_mod.h */
typedef struct {
    LS_REAL f_pwm; LS_REAL dead_time; bool dtc; LS_REAL i_band; LS_REAL dtc_lead; LS_REAL l_ripple;
} ls_mod_cfg;
typedef struct { LS_REAL d[3]; LS_REAL c[3]; } ls_mod_hist;
typedef struct {
    ls_mod_cfg cfg; LS_REAL d_dead; LS_REAL i_prev[3]; bool have_prev; LS_REAL inv_band;
    LS_REAL k_now; LS_REAL k_prev; LS_REAL k_rip; ls_mod_hist hist[2]; uint32_t newest;
} ls_mod;
ls_status ls_mod_init(ls_mod *m, const ls_mod_cfg *cfg);
void ls_mod_reset(ls_mod *m);
bool ls_mod_step(ls_mod *m, LS_REAL v_a, LS_REAL v_b, LS_REAL v_dc, const LS_REAL i_abc[3],
                 LS_REAL duty[3]);

/* ls_protect.h */
#define LS_FAULT_NONE ...
#define LS_FAULT_OVERCURRENT ...
#define LS_FAULT_UNDERVOLTAGE ...
#define LS_FAULT_OVERVOLTAGE ...
#define LS_FAULT_OBSERVER ...
#define LS_FAULT_OVERSPEED ...
#define LS_FAULT_NONFINITE ...
#define LS_FAULT_CONFIG ...
typedef struct {
    LS_REAL i_max; LS_REAL v_dc_min; LS_REAL v_dc_max; LS_REAL err_max; LS_REAL err_time;
    LS_REAL omega_max; LS_REAL fs;
} ls_protect_cfg;
typedef struct { ls_protect_cfg cfg; uint32_t fault; uint32_t err_count; uint32_t err_limit; } ls_protect;
ls_status ls_protect_init(ls_protect *p, const ls_protect_cfg *cfg);
void ls_protect_reset(ls_protect *p);
void ls_protect_trip(ls_protect *p, uint32_t bits);
uint32_t ls_protect_check_power(ls_protect *p, const LS_REAL i_abc[3], LS_REAL v_dc);
uint32_t ls_protect_check_observer(ls_protect *p, LS_REAL err, bool valid, LS_REAL omega);

/* ls_startup.h */
typedef enum {
    LS_SU_LOCK = 0, LS_SU_QUIET = 1, LS_SU_PULSE = 2, LS_SU_SETTLE = 3, LS_SU_DONE = 4, LS_SU_FAILED = 5
} ls_startup_phase;
typedef struct {
    LS_REAL fs;
    LS_REAL t_lock;
    LS_REAL err_lock;
    LS_REAL t_quiet;
    LS_REAL v_pulse;
    LS_REAL t_pulse;
    LS_REAL t_rest;
    uint32_t pairs;
    LS_REAL i_min;
    LS_REAL t_settle;
    LS_REAL lock_gain;
} ls_startup_cfg;
typedef struct {
    ls_startup_cfg cfg;
    ls_startup_phase phase;
    uint32_t pulse;
    LS_REAL i_diff;
    bool flip;
    uint32_t steps;
    ...;
} ls_startup;
ls_status ls_startup_init(ls_startup *s, const ls_startup_cfg *cfg);

/* ls_drive.h */
#define LS_FAULT_ENCODER ...
typedef enum {
    LS_MODE_OFF = 0, LS_MODE_SENSORED = 1, LS_MODE_SENSORLESS_LUT = 2, LS_MODE_SENSORLESS_NOLUT = 3,
    LS_MODE_CALIBRATION = 4, LS_MODE_STARTUP = 5
} ls_mode;
typedef struct {
    uint32_t points;
    float *table;
    LS_REAL k_int;
    LS_REAL t_settle;
    LS_REAL t_hold;
    LS_REAL tol;
    LS_REAL t_max;
    int32_t period;
    LS_REAL dither_amp;
    LS_REAL dither_freq;
} ls_cal_cfg;
typedef struct {
    LS_REAL fs;
    LS_REAL pole_pitch;
    LS_REAL force_constant;
    LS_REAL i_max;
    LS_REAL delay_comp;
    LS_REAL hf_delay;
    int32_t enc_counts;
    LS_REAL enc_v_max;
    bool inject_sensored;
    bool hf_dtres;
    bool load_ff;
    ls_inject_cfg inject;
    ls_biquad_cfg bpf;
    ls_biquad_cfg sep;
    ls_demod_cfg demod;
    ls_observer_cfg obs;
    ls_observer_cfg enc_obs;
    ls_current_cfg current;
    ls_posctrl_cfg pos;
    ls_traj_cfg traj;
    ls_mod_cfg mod;
    ls_dtres_cfg dtres;
    ls_protect_cfg prot;
    ls_cal_cfg cal;
    LS_REAL i_d_inj;
    LS_REAL i_d_near; LS_REAL near_in; LS_REAL near_out;
    ls_startup_cfg startup;
} ls_drive_cfg;
typedef struct {
    LS_REAL i_abc[3];
    LS_REAL v_dc;
    bool enc_valid;
    int32_t enc_count;
} ls_meas;
typedef struct {
    LS_REAL duty[3];
    bool enable;
    uint32_t fault;
    ls_mode mode;
    ls_pos pos_fb;
    ls_pos pos_est;
    ls_pos pos_ref;
    LS_REAL v_est;
    LS_REAL v_fb;
    LS_REAL f_load_est;
    LS_REAL err_sig;
    bool err_valid;
    LS_REAL hf_level;
    LS_REAL psi_comp;
    LS_REAL i_dq[2];
    LS_REAL i_dq_ref[2];
    LS_REAL v_dq[2];
    LS_REAL v_hf;
    uint32_t cal_index;
    bool cal_done;
    LS_REAL psi_cal;
} ls_cmd;
typedef struct {
    ls_drive_cfg cfg;
    bool initialised;
    ls_mode mode;
    ls_inject inj;
    ls_demod demod;
    ls_observer obs;
    ls_observer enc;
    ls_protect prot;
    uint32_t cal_index;
    LS_REAL psi_cal;
    bool starting;
    ls_startup su;
    ls_dtres dtres;
    ...;
} ls_drive;
void ls_drive_default_cfg(ls_drive_cfg *cfg);
ls_status ls_drive_init(ls_drive *d, const ls_drive_cfg *cfg);
void ls_drive_reset(ls_drive *d, ls_pos p);
ls_status ls_drive_set_mode(ls_drive *d, ls_mode mode);
ls_status ls_drive_set_position(ls_drive *d, ls_pos p);
ls_status ls_drive_set_load(ls_drive *d, LS_REAL f_load);
ls_status ls_drive_move_to(ls_drive *d, ls_pos target);
ls_status ls_drive_step_to(ls_drive *d, ls_pos target);
void ls_drive_step(ls_drive *d, const ls_meas *meas, ls_cmd *cmd);

/* simulator (csrc/sim, linsense/ls_sim.h) */
#define LS_SIM_MAX_ORDER 64
#define LS_SIM_MAX_PM 8
#define LS_SIM_SAT_POW 4
typedef struct {
    int32_t on;
    int32_t n_order;
    int32_t n_pow;
    double dq_cos[4][3][64];
    double dq_sin[4][3][64];
    double i_m;
    double i_sat_d;
} ls_sim_sat;
typedef enum { LS_SIM_AVERAGE = 0, LS_SIM_SWITCHING = 1 } ls_sim_fidelity;
typedef enum { LS_SIM_FREE = 0, LS_SIM_HELD = 1, LS_SIM_PRESCRIBED = 2 } ls_sim_motion;
typedef enum { LS_SIM_LOAD_CONSTANT = 0, LS_SIM_LOAD_STEP = 1, LS_SIM_LOAD_INCLINE = 2 } ls_sim_load;
#define LS_SIM_FAULT_TRAVEL 0x100
#define LS_SIM_FAULT_DIVERGED 0x200
#define LS_SIM_FAULT_STOPPED 0x400
typedef struct {
    double r_s;
    double pole_pitch;
    double psi_pm;
    int32_t n_order;
    double lab_cos[3][64];
    double lab_sin[3][64];
    int32_t n_pm;
    int32_t pm_order[8];
    double pm_amp[8];
    double pm_phase[8];
    double mass;
    double visc;
    double coulomb;
    double x_min, x_max;
    ls_sim_load load;
    double load_f0;
    double load_f1;
    double load_t;
    double load_incline;
    ls_sim_fidelity fidelity;
    double v_dc;
    double f_pwm;
    double dead_time;
    double i_gain[3];
    double i_offset[3];
    double i_noise;
    int32_t adc_bits;
    double adc_range;
    int32_t enc_counts;
    uint64_t seed;
    ls_sim_motion motion;
    double x0;
    double v0;
    int32_t decimate;
    double i_abort;
    ls_sim_sat sat;
} ls_sim_cfg;
typedef struct { double t; double x; int32_t move; } ls_sim_cmd;
typedef struct {
    double *t; double *x; double *v; double *x_est; double *v_est; double *x_ref; double *theta_err;
    double *i_abc; double *i_dq; double *duty; double *force; double *err_sig; uint32_t *fault;
    double *x_min, *x_max, *x_mean; double *err_min, *err_max, *err_mean; double *i_abc_min, *i_abc_max;
    const volatile int32_t *stop;
} ls_sim_out;
typedef struct {
    int64_t steps_done; int64_t n_rec; uint32_t fault; double x_end; double v_end;
} ls_sim_result;
typedef struct { int64_t k; int64_t n_rec; uint32_t fault; int32_t ended; ...; } ls_sim_state;
ls_status ls_sim_check(const ls_sim_cfg *cfg);
ls_status ls_sim_run(const ls_sim_cfg *cfg, ls_drive *drive, const ls_sim_cmd *cmds, int32_t n_cmds,
                     int64_t n_steps, const ls_sim_out *out, ls_sim_result *res);
ls_status ls_sim_begin(const ls_sim_cfg *cfg, ls_sim_state *state);
ls_status ls_sim_continue(const ls_sim_cfg *cfg, ls_drive *drive, const ls_sim_cmd *cmds, int32_t n_cmds,
                          ls_sim_state *state, int64_t n_more_steps, const ls_sim_out *out,
                          ls_sim_result *res);
ls_status ls_sim_open_loop(const ls_sim_cfg *cfg, const double *seg_t, const double *seg_v, int64_t n_seg,
                           const ls_sim_out *out, ls_sim_result *res);
void ls_sim_plant_eval(const ls_sim_cfg *cfg, double theta, double lab[3], double dlab[3], double lpm[2],
                       double dlpm[2]);
double ls_sim_force(const ls_sim_cfg *cfg, double theta, const double i_ab[2]);
void ls_sim_sat_eval(const ls_sim_cfg *cfg, double theta, const double i_ab[2], double lam[2],
                     double l_inc[3], double dlam[2], double *force);

/* binding helpers (defined in the set_source code below) */
int ls_py_real_size(void);
const char *ls_py_source_digest(void);
LS_REAL ls_py_clamp(LS_REAL x, LS_REAL lo, LS_REAL hi);
ls_pos ls_py_pos_norm(ls_pos p);
ls_pos ls_py_pos_add(ls_pos p, LS_REAL dtheta);
LS_REAL ls_py_pos_diff(ls_pos a, ls_pos b);
LS_REAL ls_py_wrap_pi(LS_REAL a);
LS_REAL ls_py_biquad_step(ls_biquad *f, LS_REAL x);
LS_REAL ls_py_observer_speed(const ls_observer *o);
void ls_py_lut_run(const ls_lut *lut, const double *theta, size_t n, double *out);
void ls_py_biquad_run(ls_biquad *f, const double *x, size_t n, double *y);
void ls_py_inject_run(ls_inject *inj, size_t n, double *v_out, double *car_c_out, double *car_s_out);
void ls_py_demod_run(ls_demod *d, const double *i_a, const double *i_b, const double *theta_est,
                     const double *car_c, const double *car_s, const double *psi_cal, size_t n,
                     double *err_out, double *ratio_out, double *level_out);
void ls_py_observer_run(ls_observer *o, const double *eps, const double *f_motor, size_t n,
                        double *theta_out, double *omega_out, double *f_load_out);
void ls_py_observer_track(ls_observer *o, const double *theta, const double *f_motor, size_t n,
                          double *theta_out, double *omega_out, double *f_load_out);
void ls_py_drive_run(ls_drive *d, const double *i_abc, const double *v_dc, const int32_t *enc_count,
                     size_t n, double *duty_out, uint32_t *fault_out, uint8_t *enable_out,
                     double *theta_est_out, double *err_out);
"""

SOURCE = r"""
#include "linsense/ls_sim.h"
#include "linsense/ls_types.h"
#include "linsense/ls_pos.h"
#include "linsense/ls_lut.h"
#include "linsense/ls_biquad.h"
#include "linsense/ls_inject.h"
#include "linsense/ls_demod.h"
#include "linsense/ls_observer.h"
#include "linsense/ls_pi.h"
#include "linsense/ls_current.h"
#include "linsense/ls_posctrl.h"
#include "linsense/ls_traj.h"
#include "linsense/ls_mod.h"
#include "linsense/ls_protect.h"
#include "linsense/ls_drive.h"

/* Digest of the sources this extension was compiled from (see source_digest in the build script). */
static const char *ls_py_source_digest(void) { return "@DIGEST@"; }

/* Non-inline copies of the header's static inline functions, callable from Python. */
static int ls_py_real_size(void) { return (int)sizeof(LS_REAL); }
static LS_REAL ls_py_clamp(LS_REAL x, LS_REAL lo, LS_REAL hi) { return ls_clamp(x, lo, hi); }
static ls_pos ls_py_pos_norm(ls_pos p) { return ls_pos_norm(p); }
static ls_pos ls_py_pos_add(ls_pos p, LS_REAL dtheta) { return ls_pos_add(p, dtheta); }
static LS_REAL ls_py_pos_diff(ls_pos a, ls_pos b) { return ls_pos_diff(a, b); }
static LS_REAL ls_py_wrap_pi(LS_REAL a) { return ls_wrap_pi(a); }
static LS_REAL ls_py_biquad_step(ls_biquad *f, LS_REAL x) { return ls_biquad_step(f, x); }
static LS_REAL ls_py_observer_speed(const ls_observer *o) { return ls_observer_speed(o); }

/* Unwrapped angle of a position, rad (double: the period count does not lose the angle). */
static double ls_py_unwrap(ls_pos p)
{
    return (double)p.period * 6.28318530717958647692 + (double)p.theta;
}

/* Whole-array helpers: one call per array, no Python per sample. Inputs and outputs are double
 * arrays of n samples; each sample is converted to LS_REAL on the way in, as an ADC value would
 * be. Optional (may be NULL) pointers are marked. */
static void ls_py_lut_run(const ls_lut *lut, const double *theta, size_t n, double *out)
{
    size_t k;
    for (k = 0; k < n; ++k) {
        out[k] = (double)ls_lut_step(lut, (LS_REAL)theta[k]);
    }
}

static void ls_py_biquad_run(ls_biquad *f, const double *x, size_t n, double *y)
{
    size_t k;
    for (k = 0; k < n; ++k) {
        y[k] = (double)ls_biquad_step(f, (LS_REAL)x[k]);
    }
}

/* v_out: HF voltage of each step; car_c_out, car_s_out (optional): the carrier phasor the step
 * used (the state before ls_inject_step advances it), as the drive hands it to the demodulator. */
static void ls_py_inject_run(ls_inject *inj, size_t n, double *v_out, double *car_c_out, double *car_s_out)
{
    size_t k;
    for (k = 0; k < n; ++k) {
        if (car_c_out != NULL) {
            car_c_out[k] = (double)inj->c;
        }
        if (car_s_out != NULL) {
            car_s_out[k] = (double)inj->s;
        }
        v_out[k] = (double)ls_inject_step(inj);
    }
}

/* car_c, car_s, psi_cal, ratio_out, level_out optional (NULL: 0 for inputs). */
static void ls_py_demod_run(ls_demod *d, const double *i_a, const double *i_b, const double *theta_est,
                            const double *car_c, const double *car_s, const double *psi_cal, size_t n,
                            double *err_out, double *ratio_out, double *level_out)
{
    size_t k;
    for (k = 0; k < n; ++k) {
        LS_REAL cc = car_c != NULL ? (LS_REAL)car_c[k] : LS_R(0.0);
        LS_REAL cs = car_s != NULL ? (LS_REAL)car_s[k] : LS_R(0.0);
        LS_REAL pc = psi_cal != NULL ? (LS_REAL)psi_cal[k] : LS_R(0.0);
        err_out[k] = (double)ls_demod_step(d, (LS_REAL)i_a[k], (LS_REAL)i_b[k], (LS_REAL)theta_est[k],
                                           cc, cs, pc);
        if (ratio_out != NULL) {
            ratio_out[k] = (double)d->ratio;
        }
        if (level_out != NULL) {
            level_out[k] = (double)d->level;
        }
    }
}

/* Open loop: the observer driven by a given error sequence eps (rad). f_motor optional (0 N).
 * theta_out: unwrapped estimate after each step (rad); omega_out, f_load_out optional. */
static void ls_py_observer_run(ls_observer *o, const double *eps, const double *f_motor, size_t n,
                               double *theta_out, double *omega_out, double *f_load_out)
{
    size_t k;
    for (k = 0; k < n; ++k) {
        ls_observer_step(o, (LS_REAL)eps[k], f_motor != NULL ? (LS_REAL)f_motor[k] : LS_R(0.0));
        theta_out[k] = ls_py_unwrap(o->pos);
        if (omega_out != NULL) {
            omega_out[k] = (double)o->omega;
        }
        if (f_load_out != NULL) {
            f_load_out[k] = (double)o->f_load;
        }
    }
}

/* Closed loop as with an encoder: eps = theta[k] - theta_est (unwrapped, rad), as ls_pos_diff of
 * the true and estimated positions. theta: true unwrapped angle (rad). Outputs as above. */
static void ls_py_observer_track(ls_observer *o, const double *theta, const double *f_motor, size_t n,
                                 double *theta_out, double *omega_out, double *f_load_out)
{
    size_t k;
    for (k = 0; k < n; ++k) {
        double eps = theta[k] - ls_py_unwrap(o->pos);
        ls_observer_step(o, (LS_REAL)eps, f_motor != NULL ? (LS_REAL)f_motor[k] : LS_R(0.0));
        theta_out[k] = ls_py_unwrap(o->pos);
        if (omega_out != NULL) {
            omega_out[k] = (double)o->omega;
        }
        if (f_load_out != NULL) {
            f_load_out[k] = (double)o->f_load;
        }
    }
}

/* The drive on recorded measurements (no plant): i_abc is n x 3 (row-major), v_dc n values,
 * enc_count optional (NULL: encoder not valid). duty_out n x 3, fault_out, enable_out n values;
 * theta_est_out (unwrapped HF estimate, rad) and err_out (demodulated error) optional. */
static void ls_py_drive_run(ls_drive *d, const double *i_abc, const double *v_dc, const int32_t *enc_count,
                            size_t n, double *duty_out, uint32_t *fault_out, uint8_t *enable_out,
                            double *theta_est_out, double *err_out)
{
    size_t k;
    int j;
    ls_meas m;
    ls_cmd cmd;
    for (k = 0; k < n; ++k) {
        for (j = 0; j < 3; ++j) {
            m.i_abc[j] = (LS_REAL)i_abc[3 * k + (size_t)j];
        }
        m.v_dc = (LS_REAL)v_dc[k];
        m.enc_valid = enc_count != NULL;
        m.enc_count = enc_count != NULL ? enc_count[k] : 0;
        ls_drive_step(d, &m, &cmd);
        for (j = 0; j < 3; ++j) {
            duty_out[3 * k + (size_t)j] = (double)cmd.duty[j];
        }
        fault_out[k] = cmd.fault;
        enable_out[k] = cmd.enable ? 1u : 0u;
        if (theta_est_out != NULL) {
            theta_est_out[k] = ls_py_unwrap(cmd.pos_est);
        }
        if (err_out != NULL) {
            err_out[k] = (double)cmd.err_sig;
        }
    }
}
"""

#: -O3 for the simulator's time loop; -ffp-contract=fast lets the compiler fuse a * b + c into one
#: FMA where the target has it (ISO C mode, -std=c99, turns that off; it shortens the time loop's
#: dependency chains by a fifth and changes results only at the rounding level). LINSENSE_NATIVE=1
#: (set by the Makefile for the local venv) adds -march=native, which is faster but not portable,
#: so wheels never get it by default.
COMPILE_ARGS = ["-std=c99", "-O3", "-ffp-contract=fast"] + (
    ["-march=native"] if os.environ.get("LINSENSE_NATIVE") == "1" else [])


def make_ffibuilder(absolute_paths: bool = False) -> FFI:
    """The FFI builder of ``linsense._ctrl``.

    Source paths are relative to the working directory (the project root under pip and
    setuptools) unless ``absolute_paths``; ``FFI.compile`` changes directory, so it needs them.
    """
    path = str if absolute_paths else _rel
    ffi = FFI()
    ffi.cdef(CDEF)
    ffi.set_source(
        "linsense._ctrl",
        SOURCE.replace("@DIGEST@", DIGEST),
        sources=[path(p) for p in SOURCES],
        include_dirs=[path(INCLUDE)],
        extra_compile_args=COMPILE_ARGS,
        libraries=["m"] if os.name == "posix" else [],
    )
    return ffi


ffibuilder = make_ffibuilder()

if __name__ == "__main__":
    make_ffibuilder(absolute_paths=True).compile(tmpdir=str(ROOT / "build" / "cffi"), verbose=True)
