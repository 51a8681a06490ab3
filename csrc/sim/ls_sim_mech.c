/* linsense simulator, the mechanics (ls_sim.h): load force, friction with stiction, and the mover's
 * position and speed over a period. */
#include "ls_sim_internal.h"

#define GRAVITY 9.81

LS_SIM_INLINE double load_force(const ls_sim_cfg *c, double t)
{
    switch (c->load) {
    case LS_SIM_LOAD_STEP:
        return t < c->load_t ? c->load_f0 : c->load_f1;
    case LS_SIM_LOAD_INCLINE:
        return c->load_f0 + c->mass * GRAVITY * sin(c->load_incline);
    case LS_SIM_LOAD_CONSTANT:
    default:
        return c->load_f0;
    }
}

/* advance x, v over h with the motor force average f_avg */
LS_SIM_HOT void ls_sim_mechanics(const ls_sim_cfg *c, const ls_sim_coef *q, double t, double h, double f_avg,
                                 double *x, double *v)
{
    double f_net, v_new;
    if (c->motion == LS_SIM_HELD) {
        *v = 0.0;
        return;
    }
    if (c->motion == LS_SIM_PRESCRIBED) {
        *x += c->v0 * h;
        *v = c->v0;
        return;
    }
    f_net = f_avg - load_force(c, t) - c->visc * *v;
    if (*v == 0.0 && fabs(f_net) <= c->coulomb) { /* stiction */
        return;
    }
    f_net -= c->coulomb * (*v > 0.0 ? 1.0 : (*v < 0.0 ? -1.0 : (f_net > 0.0 ? 1.0 : -1.0)));
    v_new = *v + f_net * q->inv_mass * h;
    if (c->coulomb > 0.0 && (*v) * v_new < 0.0) { /* friction cannot reverse the motion */
        v_new = 0.0;
    }
    *x += 0.5 * (*v + v_new) * h;
    *v = v_new;
}

