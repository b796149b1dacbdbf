/*
 * toy_stiff.c -- a stiff linear toy model satisfying c_src/gw_model.h, with its
 * analytic Jacobian in the jac slot:
 *
 *   y' = A y + w sin(t) (1, 1),   A = V diag(-k_slow, -k_fast) V^-1,  V = [1 1; 1 -1]
 *   A = 1/2 [ -(k_slow + k_fast)   k_fast - k_slow  ]
 *           [  k_fast - k_slow   -(k_slow + k_fast) ]
 *
 * In the modal coordinates z1 = (y1 + y2)/2, z2 = (y1 - y2)/2:
 *   z1' = -k_slow z1 + w sin t,   z2' = -k_fast z2,
 * so with l = -k_slow, Q = -w/(1 + l^2), P = l Q:
 *   z1(t) = (z1(0) - Q) e^(l t) + P sin t + Q cos t,   z2(t) = z2(0) e^(-k_fast t),
 *   y1 = z1 + z2,  y2 = z1 - z2.
 * Defaults k_slow = 1, k_fast = 1e5 (stiffness ratio 1e5), w = 0, y = (2, 0).
 * Event "low" (TERMINATE): e = y1 - y_lim (default -10: never).  For t > t_nan the
 * right-hand side is NaN (default 1e300: never), to provoke a step size underflow.
 * Check: "k_fast must be > 0".
 */
#include <math.h>
#include <stddef.h>

#include "gw_model.h"

/* p: k_slow, k_fast, w, y_lim, t_nan */
enum { P_KSLOW = 0, P_KFAST = 1, P_W = 2, P_YLIM = 3, P_TNAN = 4 };

static int init_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[0][0];
    res[0][1] = arg[0][1];
    return 0;
}
static int init_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 2; *r = 1; *iw = 0; *w = 0;
    return 0;
}

static void matrix(const double *p, double A[4]) { /* column-major */
    const double ks = p[P_KSLOW], kf = p[P_KFAST];
    A[0] = -0.5 * (ks + kf);
    A[1] = 0.5 * (kf - ks);
    A[2] = 0.5 * (kf - ks);
    A[3] = -0.5 * (ks + kf);
}

static int ode_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double t = arg[0][0], *x = arg[1], *p = arg[3];
    double *A = w, force;
    (void)iw; (void)mem;
    matrix(p, A);
    force = p[P_W] * sin(t);
    res[0][0] = A[0] * x[0] + A[2] * x[1] + force;
    res[0][1] = A[1] * x[0] + A[3] * x[1] + force;
    if (t > p[P_TNAN]) res[0][0] = res[0][1] = NAN;
    return 0;
}
static int ode_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 4; *r = 1; *iw = 0; *w = 4;
    return 0;
}

static int jac_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    matrix(arg[3], res[0]);
    return 0;
}
static int jac_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 4; *r = 1; *iw = 0; *w = 0;
    return 0;
}

static int out_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[1][0];
    res[0][1] = arg[1][1];
    return 0;
}
static int out_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 4; *r = 1; *iw = 0; *w = 0;
    return 0;
}

static int evt_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[1][0] - arg[3][P_YLIM];
    return 0;
}

static int chk_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[1][P_KFAST];
    return 0;
}
static int chk_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 2; *r = 1; *iw = 0; *w = 0;
    return 0;
}

static const double s_start[] = {2.0, 0.0};
static const double p_start[] = {1.0, 1e5, 0.0, -10.0, 1e300};

static const gw_variable vars[] = {
    {0, "k_slow", GW_REAL, GW_VAR_PARAM, P_KSLOW, -1, 0, -1},
    {1, "k_fast", GW_REAL, GW_VAR_PARAM, P_KFAST, -1, 0, -1},
    {2, "w", GW_REAL, GW_VAR_PARAM, P_W, -1, 0, -1},
    {3, "y_lim", GW_REAL, GW_VAR_PARAM, P_YLIM, -1, 1, -1},
    {4, "t_nan", GW_REAL, GW_VAR_PARAM, P_TNAN, -1, 0, -1},
    {10, "y1", GW_REAL, GW_VAR_START, 0, 0, 0, 0},
    {11, "y2", GW_REAL, GW_VAR_START, 1, 1, 0, 1},
    {40, "solver", GW_ENUM, GW_VAR_SETTING, GW_SET_SOLVER, -1, 0, -1},
    {41, "rel_tol", GW_REAL, GW_VAR_SETTING, GW_SET_REL_TOL, -1, 0, -1},
    {42, "abs_tol", GW_REAL, GW_VAR_SETTING, GW_SET_ABS_TOL, -1, 0, -1},
    {43, "max_step", GW_REAL, GW_VAR_SETTING, GW_SET_MAX_STEP, -1, 0, -1},
    {50, "low", GW_BOOLEAN, GW_VAR_EVENT, 0, -1, 0, -1},
};

static const char *const x_names[] = {"y1", "y2"};
static const char *const event_names[] = {"low"};
static const int event_actions[] = {GW_EVENT_TERMINATE};
static const char *const check_messages[] = {"k_fast must be > 0"};

static const gw_model GW_MODEL = {
    .identifier = "stiff",
    .token = "{st1ff-0000-0000-0000-000000000004}",
    .nx = 2, .ns = 2, .nu = 0, .np = 5, .ny = 2, .ne = 1, .nc = 1,
    .s_start = s_start, .u_start = NULL, .p_start = p_start,
    .n_vars = (int)(sizeof(vars) / sizeof(vars[0])),
    .vars = vars,
    .init = {init_f, init_w},
    .ode = {ode_f, ode_w},
    .out = {out_f, out_w},
    .evt = {evt_f, out_w},
    .chk = {chk_f, chk_w},
    .nom = {NULL, NULL}, /* nominals: ones */
    .jac = {jac_f, jac_w},
    .dir = {NULL, NULL},
    .x_names = x_names,
    .event_names = event_names,
    .event_actions = event_actions,
    .check_messages = check_messages,
    .default_solver = GW_SOLVER_ROSENBROCK,
    .default_rel_tol = 1e-6, .default_abs_tol = 1e-8, .default_max_step = 10.0,
    /* no dini: Initialization Mode knows the states */
    .dini = {NULL, NULL}, .n_init_rows = 0, .init_rows = NULL,
    .upd = {NULL, NULL}, /* no update events */
    .default_max_internal_steps = 0.0, /* the runtime's default */
    .ode_pre = {NULL, NULL}, /* no parameter-only subexpressions */
    .n_pre = 0,
    .taylor = {.jet = NULL, .cst = NULL, .n_var = 0, .n_cst = 0,
               .why_absent = "a toy model without a Taylor kernel"},
};
