/* linsense: C helpers of the Python binding (ls_py.h). */
#include "ls_py.h"

/* Unwrapped angle of a position, rad (double: the period count does not lose the angle). */
static double ls_py_unwrap(ls_pos p)
{
    return (double)p.period * 6.28318530717958647692 + (double)p.theta;
}

void ls_py_lut_run(const ls_lut *lut, const double *theta, size_t n, double *out)
{
    size_t k;
    for (k = 0; k < n; ++k) {
        out[k] = (double)ls_lut_step(lut, (LS_REAL)theta[k]);
    }
}

void ls_py_biquad_run(ls_biquad *f, const double *x, size_t n, double *y)
{
    size_t k;
    for (k = 0; k < n; ++k) {
        y[k] = (double)ls_biquad_step(f, (LS_REAL)x[k]);
    }
}

void ls_py_inject_run(ls_inject *inj, size_t n, double *v_out, double *car_c_out, double *car_s_out)
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

void ls_py_demod_run(ls_demod *d, const double *i_a, const double *i_b, const double *theta_est,
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

void ls_py_observer_run(ls_observer *o, const double *eps, const double *f_motor, size_t n,
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

void ls_py_observer_track(ls_observer *o, const double *theta, const double *f_motor, size_t n,
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

void ls_py_drive_run(ls_drive *d, const double *i_abc, const double *v_dc, const int32_t *enc_count,
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
