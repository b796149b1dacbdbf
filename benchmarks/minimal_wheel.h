/* A minimal hand-written right-hand side of the base wheel (gravity only): the peer the
 * generated right-hand side's cost is measured against (docs/performance.md: within 1.2x of this
 * closed form; benchmarks/rhs_minimal.c, rhs_bench.c), the RHS of the plain C DOP853
 * (benchmarks/plain_dop853.c) and, written as heyoka expressions, of heyoka's runs
 * (benchmarks/peers.py).  Written by hand for the benchmark ONLY: the FMU's model stays derived by
 * CasADi from the Lagrangian.
 *
 * Closed form in the spin rate about the axle w_n = gamma_dot + alpha_dot cos(beta) (from
 * the Newton-Euler derivation of tests/reference/newton_euler.py, simplified by hand):
 *   x_dot      = R (cos a w_n - beta_dot sin a sin b)
 *   y_dot      = R (sin a w_n + beta_dot cos a sin b)
 *   alpha_ddot = beta_dot (k_a w_n - 2 k_d alpha_dot cos b) / (k_d sin b)
 *   beta_ddot  = -(sin b alpha_dot ((1 + k_a) w_n - k_d alpha_dot cos b) + (g/R) cos b) / (1 + k_d)
 *   w_n_dot    = alpha_dot beta_dot sin b / (1 + k_a)
 *   gamma_ddot = w_n_dot + alpha_dot beta_dot sin b - alpha_ddot cos b
 * 2 sincos, 1 division, 29 flops; parameter-only constants precomputed once (minimal_wheel_init).
 * State (x, y, alpha, beta, gamma, alpha_dot, beta_dot, gamma_dot); parameters
 * (M, R, k_diam, k_axial, g).
 */
#ifndef MINIMAL_WHEEL_H
#define MINIMAL_WHEEL_H

#include <math.h>

typedef struct {
    double R, ka, kd2, inv_kd, inv_1kd, g_R, c_n, ka1, kd;
} minimal_wheel;

static void minimal_wheel_init(minimal_wheel *w, const double p[5]) {
    const double R = p[1], kd = p[2], ka = p[3], g = p[4];
    w->R = R;
    w->ka = ka;
    w->kd = kd;
    w->kd2 = 2.0 * kd;
    w->inv_kd = 1.0 / kd;
    w->inv_1kd = 1.0 / (1.0 + kd);
    w->g_R = g / R;
    w->ka1 = 1.0 + ka;
    w->c_n = 1.0 + 1.0 / (1.0 + ka);
}

/* the right-hand side given sin and cos of alpha (x[2]) and beta (x[3]) */
static inline void minimal_wheel_rhs_trig(const minimal_wheel *w, const double *x, double *xd, double sa,
                                          double ca, double sb, double cb) {
    const double ad = x[5], bd = x[6], wn = x[7] + ad * cb;
    const double add = bd * (w->ka * wn - w->kd2 * ad * cb) * w->inv_kd / sb;
    xd[0] = w->R * (ca * wn - bd * sa * sb);
    xd[1] = w->R * (sa * wn + bd * ca * sb);
    xd[2] = ad;
    xd[3] = bd;
    xd[4] = x[7];
    xd[5] = add;
    xd[6] = -(sb * ad * (w->ka1 * wn - w->kd * ad * cb) + w->g_R * cb) * w->inv_1kd;
    xd[7] = w->c_n * ad * bd * sb - add * cb;
}

/* with libm's sin and cos (the peer of the generated right-hand side, and plain_dop853.c's RHS) */
static inline void minimal_wheel_rhs(const minimal_wheel *w, const double *x, double *xd) {
    minimal_wheel_rhs_trig(w, x, xd, sin(x[2]), cos(x[2]), sin(x[3]), cos(x[3]));
}

#endif /* MINIMAL_WHEEL_H */
