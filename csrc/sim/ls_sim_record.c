/* linsense simulator, the recording (ls_sim_out, ls_sim.h): one sample of the output arrays, the block
 * statistics, and the conversions between metres and the drive's positions. */
#include "ls_sim_internal.h"

static double pos_m(ls_pos p, double tau)
{
    return ((double)p.period + (double)p.theta * (1.0 / (2.0 * LS_SIM_PI))) * tau;
}

LS_SIM_INTERNAL ls_pos ls_sim_pos_of_m(double x, double tau)
{
    ls_pos p;
    double u = x / tau, f = floor(u);
    if (!(fabs(f) <= (double)LS_POS_PERIOD_MAX)) { /* beyond the drive's range (or not finite): a
                                                     * target its setters refuse (range-checked
                                                     * before the conversion) */
        p.period = LS_POS_PERIOD_MAX;
        p.theta = (LS_REAL)NAN;
        return p;
    }
    p.period = (int32_t)f;
    p.theta = (LS_REAL)((u - f) * 2.0 * LS_SIM_PI);
    return ls_pos_norm(p);
}

static double wrap_pi(double a)
{
    return a - 2.0 * LS_SIM_PI * floor((a + LS_SIM_PI) * (1.0 / (2.0 * LS_SIM_PI)));
}

/* theta_err of the drive's estimate against the true position x (rad, wrapped); one compiled copy
 * for the samples and the block statistics, so that both round alike (-ffp-contract) */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
LS_SIM_INTERNAL double ls_sim_est_err(const ls_cmd *cmd, double x, double tau, double kx)
{
    return wrap_pi((pos_m(cmd->pos_est, tau) - x) * kx);
}

LS_SIM_INTERNAL void ls_sim_record(const ls_sim_out *o, int64_t r, double t, double x, double v, const double i[2],
                                   double cth, double sth, const double u[3], double force, const ls_cmd *cmd,
                                   double tau, double kx, uint32_t fault)
{
    if (o->t) o->t[r] = t;
    if (o->x) o->x[r] = x;
    if (o->v) o->v[r] = v;
    if (o->i_abc) ls_sim_ab_to_abc(i, &o->i_abc[3 * r]);
    if (o->i_dq) {
        o->i_dq[2 * r] = cth * i[0] + sth * i[1];
        o->i_dq[2 * r + 1] = -sth * i[0] + cth * i[1];
    }
    if (o->duty) {
        o->duty[3 * r] = u[0];
        o->duty[3 * r + 1] = u[1];
        o->duty[3 * r + 2] = u[2];
    }
    if (o->force) o->force[r] = force;
    if (cmd != NULL) {
        double x_est = pos_m(cmd->pos_est, tau);
        if (o->x_est) o->x_est[r] = x_est;
        if (o->v_est) o->v_est[r] = (double)cmd->v_est;
        if (o->x_ref) o->x_ref[r] = pos_m(cmd->pos_ref, tau);
        if (o->theta_err) o->theta_err[r] = ls_sim_est_err(cmd, x, tau, kx);
        if (o->err_sig) o->err_sig[r] = (double)cmd->err_sig;
    } else {
        if (o->x_est) o->x_est[r] = NAN;
        if (o->v_est) o->v_est[r] = NAN;
        if (o->x_ref) o->x_ref[r] = NAN;
        if (o->theta_err) o->theta_err[r] = NAN;
        if (o->err_sig) o->err_sig[r] = NAN;
    }
    if (o->fault) o->fault[r] = fault;
}

LS_SIM_INTERNAL void ls_sim_block_open(ls_sim_block *b, int64_t r, double x, double e, const double i[2])
{
    double iabc[3];
    int j;
    ls_sim_ab_to_abc(i, iabc);
    b->r = r;
    b->n = 1;
    b->x_lo = b->x_hi = b->x_sum = x;
    b->e_lo = b->e_hi = b->e_sum = e;
    for (j = 0; j < 3; ++j) {
        b->i_lo[j] = b->i_hi[j] = iabc[j];
    }
}

LS_SIM_INTERNAL void ls_sim_block_add(ls_sim_block *b, double x, double e, const double i[2])
{
    double iabc[3];
    int j;
    ls_sim_ab_to_abc(i, iabc);
    b->n++;
    b->x_lo = x < b->x_lo ? x : b->x_lo;
    b->x_hi = x > b->x_hi ? x : b->x_hi;
    b->x_sum += x;
    b->e_lo = e < b->e_lo ? e : b->e_lo;
    b->e_hi = e > b->e_hi ? e : b->e_hi;
    b->e_sum += e;
    for (j = 0; j < 3; ++j) {
        b->i_lo[j] = iabc[j] < b->i_lo[j] ? iabc[j] : b->i_lo[j];
        b->i_hi[j] = iabc[j] > b->i_hi[j] ? iabc[j] : b->i_hi[j];
    }
}

LS_SIM_INTERNAL void ls_sim_block_write(const ls_sim_out *o, const ls_sim_block *b)
{
    const int64_t r = b->r;
    int j;
    if (r < 0 || b->n == 0) {
        return;
    }
    if (o->x_min) o->x_min[r] = b->x_lo;
    if (o->x_max) o->x_max[r] = b->x_hi;
    if (o->x_mean) o->x_mean[r] = b->n == 1 ? b->x_sum : b->x_sum / (double)b->n;
    if (o->err_min) o->err_min[r] = b->e_lo;
    if (o->err_max) o->err_max[r] = b->e_hi;
    if (o->err_mean) o->err_mean[r] = b->n == 1 ? b->e_sum : b->e_sum / (double)b->n;
    for (j = 0; j < 3; ++j) {
        if (o->i_abc_min) o->i_abc_min[3 * r + j] = b->i_lo[j];
        if (o->i_abc_max) o->i_abc_max[3 * r + j] = b->i_hi[j];
    }
}

/* The time loop of ls_sim_continue, instantiated twice (sat a constant): the linear plant's copy
 * has no trace of the saturated plant (the fast path), the other runs it. */
