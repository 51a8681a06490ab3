/* A compact linear-motor plant for the drive-level C tests and the benchmark: flux-linkage state
 * in alpha-beta with L_ab(theta) from paper eq. 3 (ecce2010 preset by default), PM flux from the
 * force constant, period-averaged 2-level inverter with the one-period computation delay, and a
 * mass with viscous friction and a load force. Double precision, RK2 with 8 sub-steps per PWM
 * period. This is test scaffolding, not the simulator (csrc/sim/ is the faithful plant).
 * Optional (all off after tp_init): d-axis saturation for the start-up tests, an extra d-axis
 * flux -sat_k sat_ld i_d^2 / 2 (incremental L_d lower by 2 sat_k I relatively at +I than at -I),
 * Coulomb friction with stiction, Gaussian current-sensor noise. */
#ifndef LS_TEST_PLANT_H
#define LS_TEST_PLANT_H

#include <math.h>

#include "linsense/ls_drive.h"

#define TP_PI 3.14159265358979323846

typedef struct {
    double L0, L2, M0, M2, dM0; /* H, paper eq. 3 */
    double R, tau, kf, mass;    /* ohm, m, N/A, kg */
    double visc, f_load;        /* N s/m, N */
    double v_dc, fs;            /* V, Hz */
    double x, v;                /* m, m/s */
    double lam[2];              /* Wb, alpha-beta flux linkage */
    double duty[3];             /* duties applied during the present period */
    double i[2];                /* A, alpha-beta current */
    int32_t enc_counts;         /* counts per period */
    double sat_k, sat_ld;       /* 1/A, H: d-axis saturation (0: linear) */
    double coulomb;             /* N, Coulomb friction (held while |F - f_load| <= coulomb) */
    double i_noise;             /* A rms, current-sensor noise */
    uint64_t rng;               /* noise generator state */
} tp_plant;

static inline void tp_L_ab(const tp_plant *p, double th, double L[2][2])
{
    const double t3 = 2 * TP_PI / 3, s3 = sqrt(3.0) / 2;
    double la = p->L0 + p->L2 * cos(2 * th), lb = p->L0 + p->L2 * cos(2 * th + t3);
    double lc = p->L0 + p->L2 * cos(2 * th - t3);
    double mab = p->M0 + p->M2 * cos(2 * th - t3), mbc = p->M0 + p->M2 * cos(2 * th) + p->dM0;
    double mca = p->M0 + p->M2 * cos(2 * th + t3) + p->dM0;
    double A[3][3] = {{la, mab, mca}, {mab, lb, mbc}, {mca, mbc, lc}};
    double T[2][3] = {{2.0 / 3, -1.0 / 3, -1.0 / 3}, {0, 2.0 / 3 * s3, -2.0 / 3 * s3}};
    double Ti[3][2] = {{1, 0}, {-0.5, s3}, {-0.5, -s3}};
    int r, c, k, m;
    for (r = 0; r < 2; ++r) {
        for (c = 0; c < 2; ++c) {
            double acc = 0;
            for (k = 0; k < 3; ++k) {
                for (m = 0; m < 3; ++m) {
                    acc += T[r][k] * A[k][m] * Ti[m][c];
                }
            }
            L[r][c] = acc;
        }
    }
}

static inline double tp_psi_pm(const tp_plant *p)
{
    return p->kf * p->tau / (3 * TP_PI);
}

/* currents from fluxes at position x (with saturation: fixed-point iterations on the d-axis term,
 * each contracting by about sat_k |i_d|) */
static inline void tp_currents(const tp_plant *p, double x, const double lam[2], double i[2])
{
    double th = 2 * TP_PI * x / p->tau, L[2][2], det, r0, r1, c = cos(th), s = sin(th), id, dl;
    int it;
    tp_L_ab(p, th, L);
    r0 = lam[0] - tp_psi_pm(p) * c;
    r1 = lam[1] - tp_psi_pm(p) * s;
    det = L[0][0] * L[1][1] - L[0][1] * L[1][0];
    i[0] = (L[1][1] * r0 - L[0][1] * r1) / det;
    i[1] = (-L[1][0] * r0 + L[0][0] * r1) / det;
    for (it = 0; p->sat_k != 0.0 && it < 12; ++it) {
        id = c * i[0] + s * i[1];
        dl = -0.5 * p->sat_k * p->sat_ld * id * id; /* extra d-axis flux */
        i[0] = (L[1][1] * (r0 - dl * c) - L[0][1] * (r1 - dl * s)) / det;
        i[1] = (-L[1][0] * (r0 - dl * c) + L[0][0] * (r1 - dl * s)) / det;
    }
}

static inline void tp_deriv(const tp_plant *p, const double s[4], const double v_ab[2], double ds[4])
{
    double i[2], th = 2 * TP_PI * s[2] / p->tau, iq, f;
    tp_currents(p, s[2], s, i);
    iq = -sin(th) * i[0] + cos(th) * i[1];
    f = 1.5 * (2 * TP_PI / p->tau) * tp_psi_pm(p) * iq;
    ds[0] = v_ab[0] - p->R * i[0];
    ds[1] = v_ab[1] - p->R * i[1];
    ds[2] = s[3];
    if (p->coulomb > 0.0 && s[3] == 0.0 && fabs(f - p->f_load) <= p->coulomb) {
        ds[3] = 0.0; /* stiction */
    } else {
        double fc = p->coulomb * (s[3] > 0.0 ? 1.0 : s[3] < 0.0 ? -1.0 : (f - p->f_load > 0.0 ? 1.0 : -1.0));
        ds[3] = (f - p->f_load - p->visc * s[3] - fc) / p->mass;
    }
}

static inline void tp_init(tp_plant *p, double x0)
{
    p->L0 = 2.75e-3; p->L2 = -0.317e-3; p->M0 = -0.92e-3; p->M2 = -0.317e-3; p->dM0 = -0.47e-3;
    p->R = 9.0; p->tau = 0.056; p->kf = 20.0; p->mass = 1.5; p->visc = 5.0; p->f_load = 0.0;
    p->v_dc = 72.0; p->fs = 16000.0; p->x = x0; p->v = 0.0; p->enc_counts = 56000;
    p->lam[0] = tp_psi_pm(p) * cos(2 * TP_PI * x0 / p->tau);
    p->lam[1] = tp_psi_pm(p) * sin(2 * TP_PI * x0 / p->tau);
    p->duty[0] = p->duty[1] = p->duty[2] = 0.5;
    p->i[0] = p->i[1] = 0.0;
    p->sat_k = 0.0;
    p->sat_ld = 3.5e-3;
    p->coulomb = 0.0;
    p->i_noise = 0.0;
    p->rng = 0x9E3779B97F4A7C15ull;
}

/* standard normal deviate (xorshift64*, Box-Muller) */
static inline double tp_gauss(tp_plant *p)
{
    double u1, u2;
    p->rng ^= p->rng >> 12; p->rng ^= p->rng << 25; p->rng ^= p->rng >> 27;
    u1 = ((double)((p->rng * 2685821657736338717ull) >> 11) + 0.5) / 9007199254740992.0;
    p->rng ^= p->rng >> 12; p->rng ^= p->rng << 25; p->rng ^= p->rng >> 27;
    u2 = ((double)((p->rng * 2685821657736338717ull) >> 11) + 0.5) / 9007199254740992.0;
    return sqrt(-2.0 * log(u1)) * cos(2 * TP_PI * u2);
}

/* measurements at the start of the period (carrier peak) */
static inline void tp_measure(tp_plant *p, ls_meas *m)
{
    double i[2], cnt;
    tp_currents(p, p->x, p->lam, i);
    m->i_abc[0] = (LS_REAL)i[0];
    m->i_abc[1] = (LS_REAL)(-0.5 * i[0] + sqrt(3.0) / 2 * i[1]);
    m->i_abc[2] = (LS_REAL)(-0.5 * i[0] - sqrt(3.0) / 2 * i[1]);
    if (p->i_noise > 0.0) {
        m->i_abc[0] += (LS_REAL)(p->i_noise * tp_gauss(p));
        m->i_abc[1] += (LS_REAL)(p->i_noise * tp_gauss(p));
        m->i_abc[2] += (LS_REAL)(p->i_noise * tp_gauss(p));
    }
    m->v_dc = (LS_REAL)p->v_dc;
    cnt = floor(p->x / p->tau * p->enc_counts);
    m->enc_valid = true;
    m->enc_count = (int32_t)cnt;
}

/* integrate one PWM period with the duties of the previous step, then latch the new ones */
static inline void tp_advance(tp_plant *p, const ls_cmd *cmd)
{
    const int n = 8;
    double h = 1.0 / (p->fs * n), v_abc[3], v_ab[2], s[4], k1[4], mid[4], k2[4];
    int k, j;
    for (j = 0; j < 3; ++j) {
        v_abc[j] = p->duty[j] * p->v_dc;
    }
    v_ab[0] = (2 * v_abc[0] - v_abc[1] - v_abc[2]) / 3;
    v_ab[1] = (v_abc[1] - v_abc[2]) / sqrt(3.0);
    s[0] = p->lam[0]; s[1] = p->lam[1]; s[2] = p->x; s[3] = p->v;
    for (k = 0; k < n; ++k) {
        tp_deriv(p, s, v_ab, k1);
        for (j = 0; j < 4; ++j) mid[j] = s[j] + 0.5 * h * k1[j];
        tp_deriv(p, mid, v_ab, k2);
        for (j = 0; j < 4; ++j) s[j] += h * k2[j];
        if (p->coulomb > 0.0 && s[3] * mid[3] < 0.0) {
            s[3] = 0.0; /* friction stops the mover rather than reversing it */
        }
    }
    p->lam[0] = s[0]; p->lam[1] = s[1]; p->x = s[2]; p->v = s[3];
    for (j = 0; j < 3; ++j) {
        p->duty[j] = cmd->enable ? (double)cmd->duty[j] : 0.5; /* disabled: no net voltage */
    }
}

/* dq inductances and the uncompensated equilibrium error of the plant's model (closed forms of
 * the brief, sections 3-4; the Python suite checks them against the 3x3 transform) */
static inline void tp_dq(const tp_plant *p, double th, double *ld, double *lq, double *ldq)
{
    double c = cos(2 * th - 2 * TP_PI / 3), s = sin(2 * th - 2 * TP_PI / 3);
    *ld = p->L0 + p->L2 / 2 - p->M0 + p->M2 - 2.0 / 3 * p->dM0 * (1 + c);
    *lq = p->L0 - p->L2 / 2 - p->M0 - p->M2 - 2.0 / 3 * p->dM0 * (1 - c);
    *ldq = 2.0 / 3 * p->dM0 * s;
}

static inline double tp_err_nolut(const tp_plant *p, double th)
{
    double ld, lq, ldq;
    tp_dq(p, th, &ld, &lq, &ldq);
    return 0.5 * atan2(-2 * ldq, lq - ld);
}

static inline double tp_pos_m(ls_pos q, double tau)
{
    return ((double)q.period + (double)q.theta / (2 * TP_PI)) * tau;
}

static inline ls_pos tp_pos_of_m(double x, double tau)
{
    ls_pos q;
    double u = x / tau;
    q.period = (int32_t)floor(u);
    q.theta = (LS_REAL)((u - floor(u)) * 2 * TP_PI);
    return ls_pos_norm(q);
}

#endif /* LS_TEST_PLANT_H */
