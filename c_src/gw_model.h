/*
 * gw_model.h -- the contract between the generic runtime (c_src/) and one generated
 * model (model_desc.c + CasADi-generated functions gw_funcs.c, written by fmu_build).
 *
 * The runtime knows nothing of the wheel: every size, variable and function it
 * needs comes through the single constant GW_MODEL, which the model defines as
 *     static const gw_model GW_MODEL = { ... };
 * ahead of the runtime in the same translation unit (gw_fmu.c): internal linkage, so two
 * models never clash in one process.  The core takes a `const gw_model *`; only the front
 * end names GW_MODEL.
 *
 * Vectors (all double):
 *   x  continuous state            (nx)   integrated by the runtime
 *   s  start values                (ns)   user-facing initial values (angles, rates, ...)
 *   u  inputs                      (nu)   FMI inputs, piecewise constant over a step
 *   p  parameters                  (np)   FMI parameters seen by the equations
 *   y  outputs                     (ny)   everything readable that is computed from x
 *   e  event indicators            (ne)   an event happens when e_i goes from > 0 to <= 0
 *   c  validity checks             (nc)   each c_i must be > 0 at initialisation
 * abs_tol = 0 (the scenes' default, or a user's value) means "follow rel_tol": the absolute
 * tolerance of state i is then GW_ATOL_PER_RTOL * rel_tol * nominal_i.
 *
 * Generated functions (CasADi calling convention, see CodeGenerator docs):
 *   int f(const double **arg, double **res, gw_int *iw, double *w, int mem);
 *   int f_work(gw_int *sz_arg, gw_int *sz_res, gw_int *sz_iw, gw_int *sz_w);
 * Their inputs and outputs, in this order (all dense column vectors; an input of
 * size 0 may be passed as NULL):
 *   init(s, p)       -> x0          consistent initial state from the start values
 *   ode (t, x, u, p) -> xdot        right-hand side (ode(t, x, u, p, c) with ode_pre, below)
 *   out (t, x, u, p) -> y           outputs
 *   evt (t, x, u, p) -> e           event indicators (NULL eval if ne == 0; c too, below)
 *   chk (s, p)       -> c           validity checks           (NULL eval if nc == 0)
 *   nom (p)          -> x_nominal   state scales for absolute tolerances (NULL -> ones)
 *   jac (t, x, u, p) -> J           dense d xdot / d x, column-major nx*nx (NULL if absent)
 *   dir (t, x, u, p) -> D           dense d [xdot; y] / d [x; u], column-major
 *                                   (nx+ny) x (nx+nu), for fmi2GetDirectionalDerivative
 *                                   after initialisation (knowns: states, inputs)
 *   dini(t, s, u, p) -> D0          dense d v / d [s; p; u] at x = init(s, p), column-major
 *                                   n_init_rows x (ns+np+nu): v are the Real InitialUnknowns
 *                                   of modelDescription.xml (row init_rows[k] for vars[k],
 *                                   -1 if not one), the knowns of Initialization Mode
 *                                   (FMI 2.0.4 section 2.2.8); NULL if absent
 *   upd (t, x, u, p, k) -> x_new    the state after the update of event k (k, an event index
 *                                   passed as a double, has action GW_EVENT_UPDATE); only in
 *                                   models with such events (NULL otherwise)
 * Each instance allocates its own arg/res/iw/w buffers from the sizes f_work reports
 * (CasADi SX functions are reentrant then); mem is always 0.  The generated functions
 * are static too (fmu_build/codegen.py makes them so and keeps only what the runtime calls).
 */
#ifndef GW_MODEL_H
#define GW_MODEL_H

typedef long long gw_int; /* must equal casadi_int of the generated code */

typedef int (*gw_eval_fn)(const double **arg, double **res, gw_int *iw, double *w, int mem);
typedef int (*gw_work_fn)(gw_int *sz_arg, gw_int *sz_res, gw_int *sz_iw, gw_int *sz_w);

typedef struct {
    gw_eval_fn eval; /* NULL: the model has no such function */
    gw_work_fn work;
} gw_function;

/* FMI base type of a variable (ENUM is set/got through fmi2Set/GetInteger). */
typedef enum { GW_REAL = 0, GW_INTEGER = 1, GW_BOOLEAN = 2, GW_ENUM = 3 } gw_type;

/* Where a variable's value lives. */
typedef enum {
    GW_VAR_PARAM = 0,   /* p[index]; settable before initialisation ends (tunable: any time) */
    GW_VAR_START = 1,   /* s[index] until initialisation ends; then read from y[out_index] */
    GW_VAR_INPUT = 2,   /* u[index]; settable any time after instantiation */
    GW_VAR_OUTPUT = 3,  /* y[index]; read-only */
    GW_VAR_SETTING = 4, /* runtime setting, index is a gw_setting (solver, tolerances) */
    GW_VAR_EVENT = 5,   /* Boolean: true once event indicator `index` has fired */
    GW_VAR_STATE = 6,   /* x[index], a continuous state with no start variable of its own (local) */
    GW_VAR_DERIVATIVE = 7, /* xdot[index], the derivative of continuous state `index` (local) */
    GW_VAR_INDICATOR = 8   /* e[index], event indicator `index` (FMI 3.0 only: a local variable
                              that <EventIndicator> of ModelStructure names) */
} gw_kind;

/* Runtime settings exposed as FMI parameters (kind GW_VAR_SETTING). */
typedef enum {
    GW_SET_SOLVER = 0,   /* Enumeration, values gw_solver */
    GW_SET_REL_TOL = 1,  /* Real */
    GW_SET_ABS_TOL = 2,  /* Real */
    GW_SET_MAX_STEP = 3, /* Real, s: bound of internal steps; the fixed step of euler/rk4 */
    GW_SET_MAX_INTERNAL_STEPS = 4 /* Integer: budget of internal steps (accepted + rejected)
                                     of one call that advances time */
} gw_setting;

/* Default budget of internal steps per call when the model gives none (0): about 1 s of CPU
 * for the base wheel with DOP853 (docs/fmi.md, "Bounded calls"). */
#define GW_DEFAULT_MAX_INTERNAL_STEPS 1000000.0
/* abs_tol = 0: abs_tol follows rel_tol as rel_tol / 100 (the old fixed 1e-10 at rel_tol 1e-8) */
#define GW_ATOL_PER_RTOL 1e-2

/* Enumeration values of the `solver` parameter (modelDescription.xml uses the same). */
typedef enum {
    GW_SOLVER_EULER = 1,
    GW_SOLVER_RK4 = 2,
    GW_SOLVER_DOPRI5 = 3,
    GW_SOLVER_ROSENBROCK = 4, /* linearly implicit Rosenbrock RODAS4, uses jac */
    GW_SOLVER_DOP853 = 5,     /* Dormand-Prince 8(5,3) */
    GW_SOLVER_TAYLOR = 6,     /* Taylor series of adaptive order (needs the model's taylor kernel) */
    GW_SOLVER_AUTO = 7        /* taylor where the model has the Taylor kernel and no update
                                 events, else dop853 (gw_solver_auto, gw_core.h) */
} gw_solver;

/* The Taylor kernel of solver `taylor`, generated from the ode (taylor/kernel_c.py,
 * template gw_taylor_model.h instantiated by gw_taylor.c): cst(u, p, c) computes the n_cst
 * quantities that depend on u and p only; jet(order, t, x, c, w) the Taylor series of order
 * `order` of the states at (t, x), state i's coefficient k at w[i (order + 1) + k]
 * (x_i^[k] = x_i^(k)(t) / k!); w holds n_var series of order `order` (the rest is the kernel's
 * work: every node of the right-hand side). */
typedef void (*gw_taylor_cst_fn)(const double *u, const double *p, double *c);
typedef void (*gw_taylor_jet_fn)(int order, const double *t, const double *x, const double *c,
                                 double *w);
typedef struct {
    gw_taylor_jet_fn jet; /* NULL: no kernel (why_absent says why) */
    gw_taylor_cst_fn cst;
    int n_var, n_cst;
    const char *why_absent; /* NULL if present */
} gw_taylor_kernel;

/* What happens when an event indicator crosses zero from above. */
typedef enum {
    GW_EVENT_TERMINATE = 0, /* stop at the located time: fmi2Discard + fmi2Terminated */
    GW_EVENT_WARN = 1,      /* log a warning at the located time, set the flag, go on */
    GW_EVENT_UPDATE = 2     /* the state jumps to upd(t, x, u, p, k) at the located time (a
                               discrete mode switch; the flag: switched at least once) and
                               the integration restarts */
} gw_event_action;

typedef struct {
    unsigned int vr;
    const char *name;
    gw_type type;
    gw_kind kind;
    int index;     /* into p, s, u, y, settings or events, by kind */
    int out_index; /* GW_VAR_START: index of the same quantity in y; otherwise -1 */
    /* Every continuous state x[i] is exposed by exactly one variable: a GW_VAR_START whose
     * `state_index` is i, or a GW_VAR_STATE; its derivative by a GW_VAR_DERIVATIVE. */
    int tunable;   /* GW_VAR_PARAM: may change after initialisation */
    int state_index; /* GW_VAR_START / GW_VAR_STATE: the continuous state it is; otherwise -1 */
} gw_variable;

/* An FMI 3.0 array variable (FMI 3.0.2 section 2.4.7.2, <Dimension>): a read-only Float64
 * output of n elements, element k being x[index[k]] (GW_ARRAY_X) or y[index[k]] (GW_ARRAY_Y).
 * Arrays are no rows of `vars` (FMI 2.0 has none): only the FMI 3.0 layer reads them. */
typedef enum { GW_ARRAY_X = 0, GW_ARRAY_Y = 1 } gw_array_source;
typedef struct {
    unsigned int vr;
    const char *name;
    int n;
    gw_array_source source;
    const int *index; /* n */
} gw_array;

typedef struct {
    const char *identifier; /* modelIdentifier */
    const char *token;      /* guid of modelDescription.xml */
    int nx, ns, nu, np, ny, ne, nc;
    const double *s_start, *u_start, *p_start; /* defaults, sizes ns, nu, np */
    int n_vars;
    const gw_variable *vars; /* sorted by vr */
    gw_function init, ode, out, evt, chk, nom, jac, dir;
    const char *const *x_names;        /* nx, for log messages */
    const char *const *event_names;    /* ne */
    const int *event_actions;          /* ne, gw_event_action */
    const char *const *check_messages; /* nc, e.g. "M must be > 0" */
    int default_solver;                /* gw_solver */
    /* default_rel_tol is also DefaultExperiment's tolerance in modelDescription.xml */
    double default_rel_tol, default_abs_tol, default_max_step;
    /* partial derivatives in Initialization Mode (see dini above); all zero if absent */
    gw_function dini;
    int n_init_rows;
    const int *init_rows; /* n_vars: row of vars[k] in dini's result, or -1 */
    gw_function upd; /* state update of GW_EVENT_UPDATE events ({NULL, NULL}: none) */
    double default_max_internal_steps; /* 0: GW_DEFAULT_MAX_INTERNAL_STEPS */
    /* Optional: ode_pre(p) -> c (n_pre values), the subexpressions of ode and evt that depend
     * on the parameters alone (model/hoist.py), computed by the runtime when p changes.  When
     * present, ode and evt take c as a fifth argument: ode(t, x, u, p, c) -> xdot,
     * evt(t, x, u, p, c) -> e. */
    gw_function ode_pre;
    int n_pre;
    gw_taylor_kernel taylor; /* zero: the model has no Taylor kernel */
    int n_arrays;            /* FMI 3.0 only; 0 in an FMI 2.0 model */
    const gw_array *arrays;  /* sorted by vr, each vr above every row of vars */
    /* NULL, or what the fixed-step solvers cannot do for this model: gw_initialize logs it as a
     * warning (category logStatusWarning) when the solver is euler or rk4 */
    const char *fixed_step_caveat;
} gw_model;

#endif /* GW_MODEL_H */
