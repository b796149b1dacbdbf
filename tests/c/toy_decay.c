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
    "decay",
    "{decay-0000-0000-0000-000000000003}",
    1, 1, 0, 0, 1, 0, 0,
    s_start, NULL, NULL,
    (int)(sizeof(vars) / sizeof(vars[0])),
    vars,
    {init_f, NULL},
    {ode_f, NULL},
    {out_f, NULL},
    {NULL, NULL},
    {NULL, NULL},
    {NULL, NULL},
    {NULL, NULL},
    {NULL, NULL}, /* dir */
    x_names,
    NULL,
    NULL,
    NULL,
    GW_SOLVER_DOPRI5,
    1e-8, 1e-10, 0.1,
    {NULL, NULL}, 0, NULL, /* no dini: Initialization Mode knows the states */
    {NULL, NULL}, /* upd: no update events */
    0.0, /* default_max_internal_steps: the runtime's default */
    {NULL, NULL}, /* ode_pre: none */
    0,
    {NULL, NULL, 0, 0, "a toy model without a Taylor kernel"}, /* taylor */
};
