/*
 * toy_stickslip.c -- hand-written model with a GW_EVENT_UPDATE event: a unit mass on a
 * line under the force F(t) = F0 sin(t), held by Coulomb friction of limit L with true
 * stiction (the wheel's law of model/stiction.py in one dimension):
 *   states x = (pos, v, m), m = +1 / -1 sliding forwards / backwards, 0 stuck, s = 1 - m^2
 *   pos' = v,  v' = m^2 (F(t) - L m),  m' = 0          (stuck: v' = 0 exactly)
 *   hold H = -F(t) (the friction force needed while stuck)
 *   e0 "slip" (UPDATE): s ((L (1 + 1e-9))^2 - H^2) + m v
 *   e1 "stuck" (WARN):  m^2 - 0.5 (crosses when the update of e0 sticks: the event
 *                       iteration fires it in the same instant)
 *   upd(k = 0): v = 0, m = 0 if H^2 < (L (1 + 1e-9))^2 else -sign(H)
 *   init: pos = pos0, v = v0, m = sign(v0)
 * Analytic: from rest, it breaks away where |F| = L (1 + 1e-9) and slides with
 * v = F0 (cos t_b - cos t) - L m (t - t_b) until v = 0, then sticks or reverses.
 */
#include <math.h>
#include <stddef.h>

#include "gw_model.h"

#define BREAK (1.0 + 1e-9)

static double sgn(double a) { return a > 0.0 ? 1.0 : (a < 0.0 ? -1.0 : 0.0); }

static int init_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[0][0];
    res[0][1] = arg[0][1];
    res[0][2] = sgn(arg[0][1]);
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
static int w_5_1(gw_int *a, gw_int *r, gw_int *iw, gw_int *w) {
    *a = 5; *r = 1; *iw = 0; *w = 0;
    return 0;
}

/* p = (F0, L) */
static int ode_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double t = arg[0][0], *x = arg[1], *p = arg[3];
    (void)iw; (void)w; (void)mem;
    res[0][0] = x[1];
    res[0][1] = x[2] * x[2] * (p[0] * sin(t) - p[1] * x[2]);
    res[0][2] = 0.0;
    return 0;
}
static int out_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double t = arg[0][0], *x = arg[1], *p = arg[3];
    (void)iw; (void)w; (void)mem;
    res[0][0] = x[0];
    res[0][1] = x[1];
    res[0][2] = x[2];
    res[0][3] = (1.0 - x[2] * x[2]) * -p[0] * sin(t) - p[1] * x[2]; /* friction force */
    return 0;
}
static int evt_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double t = arg[0][0], *x = arg[1], *p = arg[3];
    const double s = 1.0 - x[2] * x[2], H = -p[0] * sin(t);
    (void)iw; (void)w; (void)mem;
    res[0][0] = s * (p[1] * BREAK * p[1] * BREAK - H * H) + x[2] * x[1];
    res[0][1] = x[2] * x[2] - 0.5;
    return 0;
}
static int upd_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    const double t = arg[0][0], *x = arg[1], *p = arg[3], k = arg[4][0];
    const double H = -p[0] * sin(t);
    const int holds = H * H < p[1] * BREAK * p[1] * BREAK;
    (void)iw; (void)w; (void)mem;
    res[0][0] = x[0];
    res[0][1] = k == 0.0 ? 0.0 : x[1];
    res[0][2] = k == 0.0 ? (holds ? 0.0 : (H > 0.0 ? -1.0 : 1.0)) : x[2];
    return 0;
}
static int chk_f(const double **arg, double **res, gw_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    res[0][0] = arg[1][1];
    return 0;
}

static const double s_start[] = {0.0, 0.0};
static const double u_start[] = {0.0};
static const double p_start[] = {1.2, 1.0};

/* GW_TOY_VR_BASE: value references from this base (the FMI 3.0 tests: 1, as in a generated
 * model, 0 being time there) */
#ifndef GW_TOY_VR_BASE
#define GW_TOY_VR_BASE 0
#endif
#define VR(n) (GW_TOY_VR_BASE + (n))
static const gw_variable vars[] = {
    {VR(0), "F0", GW_REAL, GW_VAR_PARAM, 0, -1, 0, -1},
    {VR(1), "L", GW_REAL, GW_VAR_PARAM, 1, -1, 0, -1},
    {VR(2), "pos", GW_REAL, GW_VAR_START, 0, 0, 0, 0},
    {VR(3), "v", GW_REAL, GW_VAR_START, 1, 1, 0, 1},
    {VR(4), "m", GW_REAL, GW_VAR_STATE, 2, -1, 0, 2},
    {VR(5), "friction", GW_REAL, GW_VAR_OUTPUT, 3, -1, 0, -1},
    {VR(6), "solver", GW_ENUM, GW_VAR_SETTING, GW_SET_SOLVER, -1, 0, -1},
    {VR(7), "rel_tol", GW_REAL, GW_VAR_SETTING, GW_SET_REL_TOL, -1, 0, -1},
    {VR(8), "abs_tol", GW_REAL, GW_VAR_SETTING, GW_SET_ABS_TOL, -1, 0, -1},
    {VR(9), "max_step", GW_REAL, GW_VAR_SETTING, GW_SET_MAX_STEP, -1, 0, -1},
    {VR(10), "stuck", GW_BOOLEAN, GW_VAR_EVENT, 1, -1, 0, -1},
};

static const char *const x_names[] = {"pos", "v", "m"};
static const char *const event_names[] = {"slip", "stuck"};
static const int event_actions[] = {GW_EVENT_UPDATE, GW_EVENT_WARN};
static const char *const check_messages[] = {"L must be > 0"};

static const gw_model GW_MODEL = {
    .identifier = "stickslip",
    .token = "{5t1c-k5l1-0000-0000-000000000006}",
    .nx = 3, .ns = 2, .nu = 0, .np = 2, .ny = 4, .ne = 2, .nc = 1,
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
    .default_solver = GW_SOLVER_DOPRI5,
    .default_rel_tol = 1e-10, .default_abs_tol = 1e-12, .default_max_step = 0.05,
    /* no dini: Initialization Mode knows the states */
    .dini = {NULL, NULL}, .n_init_rows = 0, .init_rows = NULL,
    .upd = {upd_f, w_5_1},
    .default_max_internal_steps = 0.0, /* the runtime's default */
    .ode_pre = {NULL, NULL}, /* no parameter-only subexpressions */
    .n_pre = 0,
    .taylor = {.jet = NULL, .cst = NULL, .n_var = 0, .n_cst = 0,
               .why_absent = "a toy model without a Taylor kernel"},
};
