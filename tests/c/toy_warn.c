/*
 * toy_warn.c -- hand-written model with an input and two WARN events:
 *   x' = u + g x^2,  x(0) = x0 (start value "x"),  outputs x and x2 = 2x.
 * With u = 1, g = 0, x0 = 0: x = t; "crossed1" fires at t = x_thresh,
 * "crossed2" at t = x_thresh2 (both WARN: logged, flagged, integration goes on).
 * g > 0 makes x blow up at t = 1/(g x0) (non-finite / step size underflow tests).
 * No nominal function (ones), no Jacobian.
 */
#include <stddef.h>

#include "gw_model.h"

static int init_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[0][0];
    return 0;
}
static int w_2_1(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 2; *r = 1; *iw = 0; *w = 0;
    return 0;
}
static int w_4_1(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 4; *r = 1; *iw = 0; *w = 0;
    return 0;
}

/* p = (x_thresh, g, x_thresh2) */
static int ode_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double x = arg[1][0], u = arg[2][0], g = arg[3][1];
    (void)iw; (void)w; (void)mem;
    res[0][0] = u + g * x * x;
    return 0;
}
static int out_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[1][0];
    res[0][1] = 2.0 * arg[1][0];
    return 0;
}
static int evt_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double x = arg[1][0], *p = arg[3];
    (void)iw; (void)w; (void)mem;
    res[0][0] = p[0] - x;
    res[0][1] = p[2] - x;
    return 0;
}
static int chk_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[1][0];
    return 0;
}

static const double s_start[] = {0.0};
static const double u_start[] = {1.0};
static const double p_start[] = {0.25, 0.0, 0.5};

static const gw_variable vars[] = {
    {0, "x_thresh", GW_REAL, GW_VAR_PARAM, 0, -1, 0, -1},
    {1, "g", GW_REAL, GW_VAR_PARAM, 1, -1, 1, -1},
    {2, "x_thresh2", GW_REAL, GW_VAR_PARAM, 2, -1, 0, -1},
    {5, "x", GW_REAL, GW_VAR_START, 0, 0, 0, 0},
    {6, "x2", GW_REAL, GW_VAR_OUTPUT, 1, -1, 0, -1},
    {7, "u", GW_REAL, GW_VAR_INPUT, 0, -1, 0, -1},
    {8, "solver", GW_ENUM, GW_VAR_SETTING, GW_SET_SOLVER, -1, 0, -1},
    {9, "rel_tol", GW_REAL, GW_VAR_SETTING, GW_SET_REL_TOL, -1, 0, -1},
    {10, "abs_tol", GW_REAL, GW_VAR_SETTING, GW_SET_ABS_TOL, -1, 0, -1},
    {11, "max_step", GW_REAL, GW_VAR_SETTING, GW_SET_MAX_STEP, -1, 0, -1},
    {12, "crossed1", GW_BOOLEAN, GW_VAR_EVENT, 0, -1, 0, -1},
    {13, "crossed2", GW_BOOLEAN, GW_VAR_EVENT, 1, -1, 0, -1},
};

static const char *const x_names[] = {"x"};
static const char *const event_names[] = {"crossed1", "crossed2"};
static const int event_actions[] = {GW_EVENT_WARN, GW_EVENT_WARN};
static const char *const check_messages[] = {"x_thresh must be > 0"};

static const gw_model GW_MODEL = {
    .identifier = "warner",
    .token = "{3a7b-warn-0000-0000-000000000002}",
    .nx = 1, .ns = 1, .nu = 1, .np = 3, .ny = 2, .ne = 2, .nc = 1,
    .s_start = s_start, .u_start = u_start, .p_start = p_start,
    .n_vars = (int)(sizeof(vars) / sizeof(vars[0])),
    .vars = vars,
    .init = {init_f, w_2_1},
    .ode = {ode_f, w_4_1},
    .out = {out_f, w_4_1},
    .evt = {evt_f, w_4_1},
    .chk = {chk_f, w_2_1},
    .nom = {NULL, NULL},
    .jac = {NULL, NULL},
    .dir = {NULL, NULL},
    .x_names = x_names,
    .event_names = event_names,
    .event_actions = event_actions,
    .check_messages = check_messages,
    .default_solver = GW_SOLVER_RK4,
    .default_rel_tol = 1e-6, .default_abs_tol = 1e-9, .default_max_step = 0.01,
    /* no dini: Initialization Mode knows the states */
    .dini = {NULL, NULL}, .n_init_rows = 0, .init_rows = NULL,
    .upd = {NULL, NULL}, /* no update events */
    .default_max_internal_steps = 0.0, /* the runtime's default */
    .ode_pre = {NULL, NULL}, /* no parameter-only subexpressions */
    .n_pre = 0,
    .taylor = {.jet = NULL, .cst = NULL, .n_var = 0, .n_cst = 0,
               .why_absent = "a toy model without a Taylor kernel"},
};
