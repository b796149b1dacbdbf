/*
 * toy_decay.c -- the smallest model: x' = -x, y = x; no inputs, no parameters,
 * no events, no checks, no nominals (NULL functions, zero-size vectors).
 */
#include <stddef.h>

#include "gw_model.h"

static int init_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[0][0];
    return 0;
}
static int ode_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = -arg[1][0];
    return 0;
}
static int out_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[1][0];
    return 0;
}

static const double s_start[] = {1.0};

static const gw_variable vars[] = {
    {0, "x", GW_REAL, GW_VAR_START, 0, 0, 0, 0},
    {1, "solver", GW_ENUM, GW_VAR_SETTING, GW_SET_SOLVER, -1, 0, -1},
    {2, "rel_tol", GW_REAL, GW_VAR_SETTING, GW_SET_REL_TOL, -1, 0, -1},
    {3, "abs_tol", GW_REAL, GW_VAR_SETTING, GW_SET_ABS_TOL, -1, 0, -1},
    {4, "max_step", GW_REAL, GW_VAR_SETTING, GW_SET_MAX_STEP, -1, 0, -1},
};

static const char *const x_names[] = {"x"};

static const gw_model GW_MODEL = {
    .identifier = "decay",
    .token = "{decay-0000-0000-0000-000000000003}",
    .nx = 1, .ns = 1, .nu = 0, .np = 0, .ny = 1, .ne = 0, .nc = 0,
    .s_start = s_start, .u_start = NULL, .p_start = NULL,
    .n_vars = (int)(sizeof(vars) / sizeof(vars[0])),
    .vars = vars,
    .init = {init_f, NULL},
    .ode = {ode_f, NULL},
    .out = {out_f, NULL},
    .evt = {NULL, NULL},
    .chk = {NULL, NULL},
    .nom = {NULL, NULL},
    .jac = {NULL, NULL},
    .dir = {NULL, NULL},
    .x_names = x_names,
    .event_names = NULL,
    .event_actions = NULL,
    .check_messages = NULL,
    .default_solver = GW_SOLVER_DOPRI5,
    .default_rel_tol = 1e-8, .default_abs_tol = 1e-10, .default_max_step = 0.1,
    /* no dini: Initialization Mode knows the states */
    .dini = {NULL, NULL}, .n_init_rows = 0, .init_rows = NULL,
    .upd = {NULL, NULL}, /* no update events */
    .default_max_internal_steps = 0.0, /* the runtime's default */
    .ode_pre = {NULL, NULL}, /* no parameter-only subexpressions */
    .n_pre = 0,
    .taylor = {.jet = NULL, .cst = NULL, .n_var = 0, .n_cst = 0,
               .why_absent = "a toy model without a Taylor kernel"},
};
