/*
 * toy_oscillator.c -- hand-written model satisfying c_src/gw_model.h without CasADi:
 * a harmonic oscillator  pos' = vel,  vel' = -k pos + use_force * f.
 * With k = 1, pos0 = 1, vel0 = 0, f = 0:  pos = cos t, vel = -sin t.
 * Event "hit" (TERMINATE): e = pos - pos_lim, fires at t = acos(pos_lim).
 * Check: "k must be > 0".  Nominals (1, 2).  Functions follow the CasADi calling
 * convention, including oversized arg arrays and work vectors.
 */
#include <math.h>
#include <stddef.h>

#include "gw_model.h"

/* arg: init(s, p); ode/out/evt(t, x, u, p); chk(s, p); nom(p) */

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

static int ode_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double *x = arg[1], *u = arg[2], *p = arg[3];
    (void)mem;
    iw[0] = 1;
    w[0] = -p[0] * x[0];        /* use the work vector like CasADi does */
    w[1] = p[3] * u[0];
    res[0][0] = x[1];
    res[0][1] = w[0] + w[1];
    return 0;
}
static int ode_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 6; *r = 2; *iw = 1; *w = 2; /* oversized, as CasADi may report */
    return 0;
}

static int out_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double *x = arg[1], *u = arg[2], *p = arg[3];
    double *y = res[0];
    (void)iw; (void)w; (void)mem;
    y[0] = x[0];
    y[1] = x[1];
    y[2] = 0.5 * (x[1] * x[1] + p[0] * x[0] * x[0]);
    y[3] = p[3] * u[0];
    return 0;
}
static int out_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 4; *r = 1; *iw = 0; *w = 0;
    return 0;
}

static int evt_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[1][0] - arg[3][1];
    return 0;
}

static int chk_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[1][0];
    return 0;
}
static int chk_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 2; *r = 1; *iw = 0; *w = 0;
    return 0;
}

static int nom_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)arg; (void)iw; (void)w; (void)mem;
    res[0][0] = 1.0;
    res[0][1] = 2.0;
    return 0;
}
static int nom_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 1; *r = 1; *iw = 0; *w = 0;
    return 0;
}

static const double s_start[] = {1.0, 0.0};
static const double u_start[] = {0.0};
/* k, pos_lim, n_int, use_force */
static const double p_start[] = {1.0, -2.0, 3.0, 1.0};

/* GW_TOY_VR_BASE: value references from this base (the FMI 3.0 tests: 1, as in a generated
 * model, 0 being time there) */
#ifndef GW_TOY_VR_BASE
#define GW_TOY_VR_BASE 0
#endif
#define VR(n) (GW_TOY_VR_BASE + (n))
static const gw_variable vars[] = {
    {VR(0), "k", GW_REAL, GW_VAR_PARAM, 0, -1, 0, -1},
    {VR(1), "pos_lim", GW_REAL, GW_VAR_PARAM, 1, -1, 1, -1},
    {VR(2), "n_int", GW_INTEGER, GW_VAR_PARAM, 2, -1, 0, -1},
    {VR(3), "use_force", GW_BOOLEAN, GW_VAR_PARAM, 3, -1, 0, -1},
    {VR(10), "pos", GW_REAL, GW_VAR_START, 0, 0, 0, 0},
    {VR(11), "vel", GW_REAL, GW_VAR_START, 1, 1, 0, 1},
    {VR(20), "energy", GW_REAL, GW_VAR_OUTPUT, 2, -1, 0, -1},
    {VR(21), "force", GW_REAL, GW_VAR_OUTPUT, 3, -1, 0, -1},
    {VR(30), "f", GW_REAL, GW_VAR_INPUT, 0, -1, 0, -1},
    {VR(40), "solver", GW_ENUM, GW_VAR_SETTING, GW_SET_SOLVER, -1, 0, -1},
    {VR(41), "rel_tol", GW_REAL, GW_VAR_SETTING, GW_SET_REL_TOL, -1, 0, -1},
    {VR(42), "abs_tol", GW_REAL, GW_VAR_SETTING, GW_SET_ABS_TOL, -1, 0, -1},
    {VR(43), "max_step", GW_REAL, GW_VAR_SETTING, GW_SET_MAX_STEP, -1, 0, -1},
    {VR(44), "max_internal_steps", GW_INTEGER, GW_VAR_SETTING, GW_SET_MAX_INTERNAL_STEPS, -1, 0, -1},
    {VR(50), "hit", GW_BOOLEAN, GW_VAR_EVENT, 0, -1, 0, -1},
#if GW_TOY_VR_BASE > 0 /* an FMI 3.0 model's row: the event indicator as a variable */
    {VR(60), "hit_indicator", GW_REAL, GW_VAR_INDICATOR, 0, -1, 0, -1},
#endif
};

static const char *const x_names[] = {"pos", "vel"};
static const char *const event_names[] = {"hit"};
static const int event_actions[] = {GW_EVENT_TERMINATE};
static const char *const check_messages[] = {"k must be > 0"};

static const gw_model GW_MODEL = {
    .identifier = "oscillator",
    .token = "{0sc1-11a7-0r00-0000-000000000001}",
    .nx = 2, .ns = 2, .nu = 1, .np = 4, .ny = 4, .ne = 1, .nc = 1,
    .s_start = s_start, .u_start = u_start, .p_start = p_start,
    .n_vars = (int)(sizeof(vars) / sizeof(vars[0])),
    .vars = vars,
    .init = {init_f, init_w},
    .ode = {ode_f, ode_w},
    .out = {out_f, out_w},
    .evt = {evt_f, out_w},
    .chk = {chk_f, chk_w},
    .nom = {nom_f, nom_w},
    .jac = {NULL, NULL},
    .dir = {NULL, NULL},
    .x_names = x_names,
    .event_names = event_names,
    .event_actions = event_actions,
    .check_messages = check_messages,
    .default_solver = GW_SOLVER_DOPRI5,
    .default_rel_tol = 1e-6, .default_abs_tol = 1e-8, .default_max_step = 0.01,
    /* no dini: Initialization Mode knows the states */
    .dini = {NULL, NULL}, .n_init_rows = 0, .init_rows = NULL,
    .upd = {NULL, NULL}, /* no update events */
    .default_max_internal_steps = 0.0, /* the runtime's default */
    .ode_pre = {NULL, NULL}, /* no parameter-only subexpressions */
    .n_pre = 0,
    .taylor = {.jet = NULL, .cst = NULL, .n_var = 0, .n_cst = 0,
               .why_absent = "a toy model without a Taylor kernel"},
};
