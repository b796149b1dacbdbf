/*
 * toy_me.c -- hand-written model satisfying c_src/gw_model.h, for the Model Exchange
 * and directional-derivative tests (tests/c/test_me.c).  No CasADi.
 *
 * A forced Duffing oscillator with a local state w (the work of the force):
 *   pos' = vel
 *   vel' = -k pos - c pos^3 + use_force * f
 *   w'   = f vel
 * x = (pos, vel, w): pos and vel have start variables (GW_VAR_START), w is a local
 * state (GW_VAR_STATE, starts at 0); der(pos), der(vel), der(w) are GW_VAR_DERIVATIVE.
 * Outputs y = (pos, vel, energy, force, wpos):
 *   energy = vel^2/2 + k pos^2/2 + c pos^4/4,  force = use_force * f,  wpos = w pos.
 * Events: "hit"  (TERMINATE) e0 = pos - pos_lim
 *         "slow" (WARN)      e1 = vel - vel_lim
 * With c = 0, k = 1, pos0 = 1, vel0 = 0, constant f (use_force = 1):
 *   pos = f + (1 - f) cos t,  vel = -(1 - f) sin t,  w = f (pos - 1).
 * `dir` is the exact dense Jacobian d[xdot; y]/d[x; u], (3+5) x (3+1), column-major;
 * `jac` is left out (NULL).  Tunable parameter: c.
 */
#include <math.h>
#include <stddef.h>

#include "gw_model.h"

enum { P_K = 0, P_C = 1, P_POS_LIM = 2, P_VEL_LIM = 3, P_USE_FORCE = 4 };

static int init_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[0][0];
    res[0][1] = arg[0][1];
    res[0][2] = 0.0;
    return 0;
}
static int init_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 2; *r = 1; *iw = 0; *w = 0;
    return 0;
}

static int ode_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double *x = arg[1], *u = arg[2], *p = arg[3];
    (void)iw; (void)mem;
    w[0] = x[0] * x[0] * x[0];
    res[0][0] = x[1];
    res[0][1] = -p[P_K] * x[0] - p[P_C] * w[0] + p[P_USE_FORCE] * u[0];
    res[0][2] = u[0] * x[1];
    return 0;
}
static int ode_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 5; *r = 2; *iw = 0; *w = 1;
    return 0;
}

static int out_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double *x = arg[1], *u = arg[2], *p = arg[3];
    double *y = res[0];
    (void)iw; (void)w; (void)mem;
    y[0] = x[0];
    y[1] = x[1];
    y[2] = 0.5 * x[1] * x[1] + 0.5 * p[P_K] * x[0] * x[0] + 0.25 * p[P_C] * pow(x[0], 4);
    y[3] = p[P_USE_FORCE] * u[0];
    y[4] = x[2] * x[0];
    return 0;
}
static int four_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 4; *r = 1; *iw = 0; *w = 0;
    return 0;
}

static int evt_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double *x = arg[1], *p = arg[3];
    (void)iw; (void)w; (void)mem;
    res[0][0] = x[0] - p[P_POS_LIM];
    res[0][1] = x[1] - p[P_VEL_LIM];
    return 0;
}

static int chk_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[1][P_K];
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
    res[0][2] = 0.5;
    return 0;
}
static int nom_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 1; *r = 1; *iw = 0; *w = 0;
    return 0;
}

/* D = d[xdot; y]/d[x; u]: rows xdot0..2, y0..4 (8); columns pos, vel, w, f (4) */
#define NR 8
static int dir_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double *x = arg[1], *u = arg[2], *p = arg[3];
    double *D = res[0];
    int i;
    (void)iw; (void)mem;
    w[0] = x[0] * x[0];
    for (i = 0; i < NR * 4; i++) D[i] = 0.0;
#define AT(r, c) D[(r) + (c) * NR]
    /* xdot0 = vel */
    AT(0, 1) = 1.0;
    /* xdot1 = -k pos - c pos^3 + uf f */
    AT(1, 0) = -p[P_K] - 3.0 * p[P_C] * w[0];
    AT(1, 3) = p[P_USE_FORCE];
    /* xdot2 = f vel */
    AT(2, 1) = u[0];
    AT(2, 3) = x[1];
    /* y0 = pos, y1 = vel */
    AT(3, 0) = 1.0;
    AT(4, 1) = 1.0;
    /* y2 = energy */
    AT(5, 0) = p[P_K] * x[0] + p[P_C] * w[0] * x[0];
    AT(5, 1) = x[1];
    /* y3 = force */
    AT(6, 3) = p[P_USE_FORCE];
    /* y4 = w pos */
    AT(7, 0) = x[2];
    AT(7, 2) = x[0];
#undef AT
    return 0;
}
static int dir_w(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 4; *r = 1; *iw = 0; *w = 1;
    return 0;
}

static const double s_start[] = {1.0, 0.0};
static const double u_start[] = {0.0};
/* k, c, pos_lim, vel_lim, use_force */
static const double p_start[] = {1.0, 0.5, -0.5, -10.0, 1.0};

static const gw_variable vars[] = {
    {0, "k", GW_REAL, GW_VAR_PARAM, P_K, -1, 0, -1},
    {1, "c", GW_REAL, GW_VAR_PARAM, P_C, -1, 1, -1},
    {2, "pos_lim", GW_REAL, GW_VAR_PARAM, P_POS_LIM, -1, 0, -1},
    {3, "vel_lim", GW_REAL, GW_VAR_PARAM, P_VEL_LIM, -1, 0, -1},
    {4, "use_force", GW_BOOLEAN, GW_VAR_PARAM, P_USE_FORCE, -1, 0, -1},
    {10, "pos", GW_REAL, GW_VAR_START, 0, 0, 0, 0},
    {11, "vel", GW_REAL, GW_VAR_START, 1, 1, 0, 1},
    {12, "w", GW_REAL, GW_VAR_STATE, 2, -1, 0, 2},
    {20, "energy", GW_REAL, GW_VAR_OUTPUT, 2, -1, 0, -1},
    {21, "force", GW_REAL, GW_VAR_OUTPUT, 3, -1, 0, -1},
    {22, "wpos", GW_REAL, GW_VAR_OUTPUT, 4, -1, 0, -1},
    {30, "f", GW_REAL, GW_VAR_INPUT, 0, -1, 0, -1},
    {40, "solver", GW_ENUM, GW_VAR_SETTING, GW_SET_SOLVER, -1, 0, -1},
    {41, "rel_tol", GW_REAL, GW_VAR_SETTING, GW_SET_REL_TOL, -1, 0, -1},
    {42, "abs_tol", GW_REAL, GW_VAR_SETTING, GW_SET_ABS_TOL, -1, 0, -1},
    {43, "max_step", GW_REAL, GW_VAR_SETTING, GW_SET_MAX_STEP, -1, 0, -1},
    {50, "hit", GW_BOOLEAN, GW_VAR_EVENT, 0, -1, 0, -1},
    {51, "slow", GW_BOOLEAN, GW_VAR_EVENT, 1, -1, 0, -1},
    {60, "der(pos)", GW_REAL, GW_VAR_DERIVATIVE, 0, -1, 0, -1},
    {61, "der(vel)", GW_REAL, GW_VAR_DERIVATIVE, 1, -1, 0, -1},
    {62, "der(w)", GW_REAL, GW_VAR_DERIVATIVE, 2, -1, 0, -1},
};

static const char *const x_names[] = {"pos", "vel", "w"};
static const char *const event_names[] = {"hit", "slow"};
static const int event_actions[] = {GW_EVENT_TERMINATE, GW_EVENT_WARN};
static const char *const check_messages[] = {"k must be > 0"};

/* With -DTOY_ME_ARRAYS, FMI 3.0 array variables (gw_model.h, gw_array): xs the states (pos,
 * vel: start values; w: a state), ef = [energy, force] (outputs y[2], y[3]) */
#ifdef TOY_ME_ARRAYS
static const int toy_xs_index[] = {0, 1, 2};
static const int toy_ef_index[] = {2, 3};
static const gw_array toy_arrays[] = {
    {70, "xs", 3, GW_ARRAY_X, toy_xs_index},
    {71, "ef", 2, GW_ARRAY_Y, toy_ef_index},
};
#define TOY_ME_ARRAYS_SLOT .n_arrays = 2, .arrays = toy_arrays,
#else
#define TOY_ME_ARRAYS_SLOT
#endif

static const gw_model GW_MODEL = {
    .identifier = "toy_me",
    .token = "{70y0-me00-0000-0000-000000000004}",
    .nx = 3, .ns = 2, .nu = 1, .np = 5, .ny = 5, .ne = 2, .nc = 1,
    .s_start = s_start, .u_start = u_start, .p_start = p_start,
    .n_vars = (int)(sizeof(vars) / sizeof(vars[0])),
    .vars = vars,
    .init = {init_f, init_w},
    .ode = {ode_f, ode_w},
    .out = {out_f, four_w},
    .evt = {evt_f, four_w},
    .chk = {chk_f, chk_w},
    .nom = {nom_f, nom_w},
    .jac = {NULL, NULL},
    .dir = {dir_f, dir_w},
    .x_names = x_names,
    .event_names = event_names,
    .event_actions = event_actions,
    .check_messages = check_messages,
    .default_solver = GW_SOLVER_DOPRI5,
    .default_rel_tol = 1e-8, .default_abs_tol = 1e-10, .default_max_step = 0.01,
    /* no dini: Initialization Mode knows the states */
    .dini = {NULL, NULL}, .n_init_rows = 0, .init_rows = NULL,
    .upd = {NULL, NULL}, /* no update events */
    .default_max_internal_steps = 0.0, /* the runtime's default */
    .ode_pre = {NULL, NULL}, /* no parameter-only subexpressions */
    .n_pre = 0,
    .taylor = {.jet = NULL, .cst = NULL, .n_var = 0, .n_cst = 0,
               .why_absent = "a toy model without a Taylor kernel"},
    TOY_ME_ARRAYS_SLOT
};
