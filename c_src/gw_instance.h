/*
 * gw_instance.h -- the per-instance state of a gyrowheel FMU and the internal
 * interfaces between the runtime modules (logging, solver, events, FMU state).
 *
 * Nothing here is exported from the shared library: every internal function is
 * declared GW_INTERNAL (hidden visibility); only the fmi2* functions of
 * gw_fmi2.c / gw_state.c are visible.  There is no global mutable state: all
 * memory hangs off one gw_instance, allocated through the importer's callbacks.
 */
#ifndef GW_INSTANCE_H
#define GW_INSTANCE_H

#include <stddef.h>

#include "fmi2Functions.h"
#include "gw_model.h"

#if defined(__GNUC__) && !defined(_WIN32)
#define GW_INTERNAL __attribute__((visibility("hidden")))
#else
#define GW_INTERNAL
#endif

/* ---- FMI states (bit mask, as in modelica/Reference-FMUs) ---------------- */
enum {
    GW_ST_INSTANTIATED = 1 << 0,
    GW_ST_INIT_MODE = 1 << 1,
    GW_ST_STEP_COMPLETE = 1 << 2,
    GW_ST_STEP_FAILED = 1 << 3, /* after fmi2Discard (terminating event) */
    GW_ST_TERMINATED = 1 << 4,
    GW_ST_ERROR = 1 << 5,
    GW_ST_FATAL = 1 << 6
};
/* Model Exchange states (Co-Simulation never enters them) */
enum { GW_ST_EVENT_MODE = 1 << 7, GW_ST_CONT_TIME_MODE = 1 << 8 };

/* ---- log categories (order = names in gw_log.c) -------------------------- */
typedef enum {
    GW_LOG_EVENTS = 0,
    GW_LOG_SOLVER = 1,
    GW_LOG_WARNING = 2,
    GW_LOG_ERROR = 3,
    GW_LOG_FATAL = 4,
    GW_LOG_ALL = 5,
    GW_LOG_N = 6
} gw_log_category;

/* ---- CasADi function with its own work buffers --------------------------- */
typedef struct {
    gw_eval_fn eval; /* NULL: function absent */
    const double **arg;
    double **res;
    gw_int *iw;
    double *w;
    gw_int n_arg, n_res; /* allocated lengths of arg / res */
} gw_fun;

/* The importer's callbacks, copied field by field (the FMI 2.0.0 headers declare
 * the fields of fmi2CallbackFunctions const, which forbids copying the struct). */
typedef struct {
    fmi2CallbackLogger logger;
    fmi2CallbackAllocateMemory allocateMemory;
    fmi2CallbackFreeMemory freeMemory;
    fmi2ComponentEnvironment componentEnvironment;
} gw_callbacks;

/* ---- the instance ---------------------------------------------------------- */
typedef struct gw_instance {
    const gw_model *m;
    gw_callbacks cb;          /* copy of the importer's callbacks */
    char *name;               /* instance name (copied) */

    int state; /* one GW_ST_* bit */
    int logging_on;
    unsigned int log_mask; /* bit per gw_log_category */

    /* settings */
    int solver;
    double rel_tol, abs_tol, max_step;

    /* experiment */
    double t_start, t_stop;
    int stop_defined;
    int tol_defined;  /* fmi2SetupExperiment tolerance: overrides rel_tol at init */
    double tolerance;

    /* model data */
    double t;
    double *x, *s, *u, *p, *y, *e, *c, *nominal;
    int *flags; /* ne: event has fired */
    int terminated;
    double last_successful_time;
    int last_dostep_status; /* fmi2Status of the last fmi2DoStep */

    /* caches */
    int y_valid;    /* y == out(t, x, u, p) */
    int fcur_valid; /* k1 == ode(t, x, u, p) (FSAL / restart) */

    /* solver */
    double h_adapt; /* DOPRI5 step size carried between steps (0: estimate) */
    double *k[7];   /* stage derivatives, nx each */
    double *xnew, *xtmp, *xev, *rcont; /* rcont: 5*nx dense output coefficients */
    double dense_t0, dense_h; /* the last accepted step [t0, t0 + h] */
    int k7_valid;             /* k[6] == ode(t0 + h, xnew) */
    int dense_ready;          /* rcont holds the dense output of that step */
    double *enew, *eev; /* ne */

    /* backup at the start of a communication step */
    double *x_bak, *e_bak;
    int *flags_bak;

    /* counters (cumulative since initialisation) */
    unsigned long long n_rhs, n_accepted, n_rejected, n_evt, n_events;

    /* CasADi functions with per-instance buffers */
    gw_fun f_init, f_ode, f_out, f_evt, f_chk, f_nom, f_jac;

    /* Model Exchange and directional derivatives (gw_fmi2.c, gw_instance_me_alloc) */
    int fmu_type;       /* fmi2ModelExchange or fmi2CoSimulation, fixed at instantiation */
    double *xdot;       /* nx: ode(t, x, u, p) at the current point, valid if xdot_valid */
    int xdot_valid;
    double *e_me;       /* ne: scratch for event indicators in Model Exchange */
    gw_fun f_dir;       /* dir(t, x, u, p) -> D, only if GW_MODEL.dir.eval */
    double *dir_D;      /* (nx+ny)*(nx+nu), column-major, valid if dir_valid */
    int dir_valid;

    /* DOP853 and Rosenbrock work memory (gw_solver.c, gw_solver_alloc at instantiation).
     * Nothing here survives fmi2Get/SetFMUstate: it is recomputed in every step. */
    double *kx[9]; /* extra stage vectors, nx each */
    double *rcx;   /* 3*nx: DOP853 dense output coefficients beyond rcont */
    double *jac;   /* nx*nx: d xdot / d x, column-major (Rosenbrock) */
    double *lu;    /* nx*nx: LU factors of I/(gamma h) - J, column-major */
    int *piv;      /* nx: pivot rows of lu */
} gw_instance;

/* ---- gw_instance.c ------------------------------------------------------- */
GW_INTERNAL gw_instance *gw_instance_new(const gw_model *m, const char *name,
                                         const fmi2CallbackFunctions *cb, int logging_on);
GW_INTERNAL void gw_instance_free(gw_instance *I);
GW_INTERNAL void gw_instance_defaults(gw_instance *I);
GW_INTERNAL void *gw_alloc(const gw_instance *I, size_t n, size_t size); /* zeroed */
GW_INTERNAL void gw_free(const gw_instance *I, void *ptr);
GW_INTERNAL int gw_all_finite(const double *v, int n);
GW_INTERNAL const char *gw_solver_name(int solver);

/* Evaluation helpers: return 0 on success, non-zero if the generated function failed. */
GW_INTERNAL int gw_eval_init(gw_instance *I, double *x_out);
GW_INTERNAL int gw_eval_out(gw_instance *I, double t, const double *x, double *y_out);
GW_INTERNAL int gw_eval_evt(gw_instance *I, double t, const double *x, double *e_out);
GW_INTERNAL int gw_eval_chk(gw_instance *I, double *c_out);
GW_INTERNAL int gw_eval_nom(gw_instance *I, double *nom_out);
/* The RHS: thin wrapper with preset t/u/p pointers; counts evaluations. */
GW_INTERNAL int gw_rhs(gw_instance *I, double t, const double *x, double *xdot);

/* ---- gw_log.c -------------------------------------------------------------- */
GW_INTERNAL int gw_log_enabled(const gw_instance *I, gw_log_category cat);
GW_INTERNAL void gw_log(const gw_instance *I, fmi2Status status, gw_log_category cat,
                        const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
/* log an fmi2Error (always passed to the logger) */
#define GW_ERROR(I, ...) gw_log((I), fmi2Error, GW_LOG_ERROR, __VA_ARGS__)
GW_INTERNAL void gw_log_cb(const gw_callbacks *cb, const char *name, fmi2Status status,
                           const char *category, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;
GW_INTERNAL fmi2Status gw_set_debug_logging(gw_instance *I, fmi2Boolean on, size_t n,
                                            const fmi2String categories[]);

/* ---- gw_solver.c ----------------------------------------------------------- */
typedef enum {
    GW_INT_OK = 0,
    GW_INT_TERMINATED = 1, /* a terminating event was located; state at the event */
    GW_INT_ERROR = 2       /* logged; caller restores the state */
} gw_int_result;

/* Integrate from I->t (== t0) exactly to t_end, handling events. */
GW_INTERNAL gw_int_result gw_integrate(gw_instance *I, double t_end);
/* Dense output of the last accepted step at time t (within it). */
GW_INTERNAL void gw_dense_prepare(gw_instance *I);
GW_INTERNAL void gw_dense_eval(const gw_instance *I, double t, double *x_out);

/* ---- gw_events.c ----------------------------------------------------------- */
typedef enum { GW_EV_NONE = 0, GW_EV_WARN = 1, GW_EV_TERMINATE = 2, GW_EV_ERROR = 3 } gw_ev_result;
/* After an accepted step [t0, t1] (x -> xnew, dense output available on request):
 * evaluates the event indicators at t1 into I->enew.  If one crossed from > 0 to
 * <= 0, locates the earliest crossing te, writes the state there into I->xev and
 * the indicators into I->eev, sets flags, logs, and returns *t_event = te. */
GW_INTERNAL gw_ev_result gw_events_check(gw_instance *I, double t0, double t1, double *t_event);

/* ---- gw_fmi2.c: state machine helpers shared with gw_state.c --------------- */
/* 1 if I is usable and its state is in mask; else logs, enters Error, returns 0 */
GW_INTERNAL int gw_begin(gw_instance *I, const char *fn, int mask);
/* the function's final status; fmi2Error / fmi2Fatal enter the Error / Fatal state */
GW_INTERNAL fmi2Status gw_end(gw_instance *I, fmi2Status status);

/* ---- utilities ------------------------------------------------------------- */
static inline fmi2Status gw_worst(fmi2Status a, fmi2Status b) { return a > b ? a : b; }

/* ---- Model Exchange / directional derivatives (gw_instance.c, gw_events.c) -- */
/* allocates xdot, e_me and, if the model has `dir`, f_dir and dir_D; 0 on success */
GW_INTERNAL int gw_instance_me_alloc(gw_instance *I);
GW_INTERNAL void gw_instance_me_free(gw_instance *I);
/* D = dir(t, x, u, p); 0 on success */
GW_INTERNAL int gw_eval_dir(gw_instance *I, double t, const double *x, double *D);
/* Model Exchange event update at the current point (fmi2NewDiscreteStates): e_now are
 * the indicators now, I->e those of the previous event update.  An indicator that went
 * from > 0 to <= 0 (or is <= 0 now and TERMINATE) fires: flag set, logged; I->e = e_now. */
GW_INTERNAL gw_ev_result gw_events_me_update(gw_instance *I, const double *e_now);

/* ---- gw_solver.c: solver work memory and the solvers gw_integrate implements ---- */
GW_INTERNAL int gw_solver_alloc(gw_instance *I); /* 0 on success, -1: out of memory */
GW_INTERNAL void gw_solver_free(gw_instance *I);
GW_INTERNAL int gw_solver_available(int solver); /* 1 for a known gw_solver value */

#endif /* GW_INSTANCE_H */
