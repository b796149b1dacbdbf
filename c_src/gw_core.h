/*
 * gw_core.h -- the simulation core's API: what a front end calls.  Two front ends use it:
 * the FMI 2.0 layer (gw_fmi2_*.c, the only code that includes fmi2Functions.h) and a plain
 * C program embedding the generated model (`gyrowheel export-c`).  docs/runtime.md has the
 * layer diagram and a worked call sequence.
 *
 * The core knows no FMI: its own status codes (gw_status), its own callbacks (gw_callbacks:
 * logger, allocator, free, environment pointer).  There is no global mutable state; every
 * allocation goes through gw_callbacks.allocate / .free.
 *
 * Linkage.  Every function of the runtime is `static` (GW_API / GW_INTERNAL): the runtime
 * is compiled only as part of ONE translation unit that also #includes the model (gw_fmu.c
 * for an FMU), so nothing but the front end's own entry points (the fmi2* functions) is
 * global, whatever flags the build uses.  Two FMUs or two exported models therefore link
 * into one program without clashes.  GW_API functions may go unused by a front end
 * (GW_MAYBE_UNUSED keeps -Wunused-function quiet for them, not for internal functions).
 *
 * Call sequence of a front end (docs/runtime.md maps it onto the fmi2 functions):
 *   I = gw_instance_new(&GW_MODEL, "name", &cb, logging_on);
 *   gw_value_set(I, gw_variable_find(I->m, vr), value);   parameters, start values, settings
 *   gw_setup_experiment(I, fn, 0, 0.0, t0, 0, 0.0);
 *   gw_initialize(I, fn);                  checks, x = init(s, p), outputs, event indicators
 *   gw_advance(I, fn, t_end);              GW_OK / GW_DISCARD (terminating event) / GW_ERROR
 *   gw_update_outputs(I, fn); gw_value_get(I, v);          states, outputs, event flags
 *   gw_state_size / _write / _check / _apply               save and restore
 *   gw_instance_free(I);
 * fn is the name the front end's messages start with ("fmi2DoStep", "advance", ...).
 */
#ifndef GW_CORE_H
#define GW_CORE_H

#include <stddef.h>

#include "gw_model.h"

#if defined(__GNUC__)
#define GW_MAYBE_UNUSED __attribute__((unused))
#define GW_PRINTF(fmt, args) __attribute__((format(printf, fmt, args)))
#else
#define GW_MAYBE_UNUSED
#define GW_PRINTF(fmt, args)
#endif

/* A function of the core API (may be unused by one front end) and an internal function
 * shared between runtime files (must be used).  Both have internal linkage. */
#define GW_API static GW_MAYBE_UNUSED
#define GW_INTERNAL static

/* ---- status and callbacks ------------------------------------------------------------ */

/* Result of a core call; same order as fmi2Status (worse is larger), mapped explicitly by
 * the FMI layer.  GW_DISCARD: the call did what it could but the result is not usable as
 * asked (a terminating event stopped the step; a non-finite value in Model Exchange). */
typedef enum { GW_OK = 0, GW_WARNING = 1, GW_DISCARD = 2, GW_ERROR = 3, GW_FATAL = 4 } gw_status;

static inline gw_status gw_worst(gw_status a, gw_status b) { return a > b ? a : b; }

/* message: plain text, already formatted (no printf directives to expand) */
typedef void (*gw_logger_fn)(void *env, const char *instance_name, gw_status status,
                             const char *category, const char *message);
typedef void *(*gw_allocate_fn)(size_t n, size_t size); /* n * size bytes; need not be zeroed */
typedef void (*gw_free_fn)(void *ptr);

typedef struct {
    gw_logger_fn logger;     /* NULL: no messages at all */
    gw_allocate_fn allocate; /* required */
    gw_free_fn free;         /* required */
    void *env;               /* handed to logger unchanged */
} gw_callbacks;

/* An allocator with a context pointer (a plain C front end's: an arena per instance needs no
 * global state).  Given to gw_instance_new_with, it replaces gw_callbacks.allocate / .free. */
typedef struct {
    void *(*allocate)(void *ctx, size_t n, size_t size); /* n * size bytes; need not be zeroed */
    void (*free)(void *ctx, void *ptr);
    void *ctx; /* handed to allocate and free unchanged */
} gw_allocator;

/* Log categories (names: gw_log_category_name; modelDescription.xml <LogCategories>, the
 * names of FMI 2.0.4 section 2.2.4).  A message with any status but GW_OK (the reason of a
 * warning, discard, error or fatal status) always reaches the logger; GW_OK messages
 * (events, solver statistics) only when logging is on and their category (or GW_LOG_ALL)
 * is enabled. */
typedef enum {
    GW_LOG_EVENTS = 0,
    GW_LOG_SOLVER = 1,
    GW_LOG_WARNING = 2,
    GW_LOG_ERROR = 3,
    GW_LOG_FATAL = 4,
    GW_LOG_ALL = 5,
    GW_LOG_DISCARD = 6,
    GW_LOG_N = 7
} gw_log_category;

/* One simulation: model data, settings, solver memory (gw_instance.h has the fields). */
typedef struct gw_instance gw_instance;

/* ---- life cycle (gw_instance.c) ----------------------------------------------------------- */

/* A new instance of model m in its set-up phase, defaults applied; NULL if out of memory.
 * name is copied.  cb is copied; cb->allocate and cb->free must not be NULL. */
GW_API gw_instance *gw_instance_new(const gw_model *m, const char *name, const gw_callbacks *cb,
                                    int logging_on);
/* The same with every allocation (the instance itself included) through alloc, whose
 * allocate and free must not be NULL; cb->allocate and cb->free are then not used. */
GW_API gw_instance *gw_instance_new_with(const gw_model *m, const char *name,
                                         const gw_callbacks *cb, const gw_allocator *alloc,
                                         int logging_on);
GW_API void gw_instance_free(gw_instance *I);
/* Back to the state right after gw_instance_new (set-up phase, default values). */
GW_API void gw_instance_reset(gw_instance *I);

/* ---- logging (gw_log.c) --------------------------------------------------------------------- */

GW_API int gw_log_enabled(const gw_instance *I, gw_log_category cat);
GW_API void gw_log(const gw_instance *I, gw_status status, gw_log_category cat, const char *fmt,
                   ...) GW_PRINTF(4, 5);
GW_API const char *gw_log_category_name(int cat);
/* Logging on/off; n == 0: all categories, else the named ones (gw_log_category_name).
 * An unknown name is GW_ERROR with the reason logged (messages start with fn). */
GW_API gw_status gw_set_logging(gw_instance *I, const char *fn, int on, size_t n,
                                const char *const categories[]);
/* log a GW_ERROR (always passed to the logger) */
#define GW_LOG_ERR(I, ...) gw_log((I), GW_ERROR, GW_LOG_ERROR, __VA_ARGS__)

/* ---- values (gw_values.c) ------------------------------------------------------------------- */

/* The variable with value reference vr (binary search in m->vars), or NULL. */
GW_API const gw_variable *gw_variable_find(const gw_model *m, unsigned int vr);
/* Name of the variable of a kind and index (for messages), or NULL. */
GW_API const char *gw_variable_name(const gw_model *m, int kind, int index);
/* Current value of v as a double (Integer, Enumeration and Boolean included).  Outputs and
 * state derivatives are only current after gw_update_outputs / gw_update_derivatives. */
GW_API double gw_value_get(const gw_instance *I, const gw_variable *v);
/* Valid ranges of the settings (docs/fmi.md, "Settings"): tolerances are fractions of the
 * states' nominal scales, so neither exceeds 1; rel_tol below 10 machine epsilons cannot be
 * met in double precision (Hairer's DOPRI5 refuses it alike); an abs_tol below 1e-30
 * nominals underflows the error weights, but abs_tol = 0 exactly is valid and means "follow
 * rel_tol" (GW_ATOL_PER_RTOL * rel_tol, gw_model.h).  max_internal_steps, the budget of
 * internal steps of one call, is a whole number that an fmi2Integer holds. */
#define GW_REL_TOL_MIN 2.220446049250313e-15 /* 10 * DBL_EPSILON */
#define GW_REL_TOL_MAX 1.0
#define GW_ABS_TOL_MIN 1e-30 /* or 0 */
#define GW_ABS_TOL_MAX 1.0
#define GW_MAX_INTERNAL_STEPS_MIN 1.0
#define GW_MAX_INTERNAL_STEPS_MAX 2147483647.0
/* Is `value` valid for v?  Every value must be finite; a setting must lie in its range
 * (solver: a known gw_solver; rel_tol, abs_tol as above; max_step > 0; max_internal_steps
 * whole, in [1, 2^31 - 1]); a Boolean is 0 or 1.  GW_OK, or GW_ERROR with the reason logged
 * (messages start with fn).  The front end calls it before gw_value_set; gw_initialize and
 * restoring a saved state apply the same checks. */
GW_API gw_status gw_value_check(gw_instance *I, const char *fn, const gw_variable *v,
                                double value);
/* Store a value (parameter, start value, input, setting) without any check: the front end
 * decides what may be set when (the FMI layer: gw_fmi2_variables.c) and checks it with
 * gw_value_check.  A tunable parameter or an input invalidates the caches; a parameter
 * after initialisation recomputes the state nominals.  Setting rel_tol or abs_tol marks it
 * explicit: a tolerance from gw_setup_experiment then does not replace it. */
GW_API void gw_value_set(gw_instance *I, const gw_variable *v, double value);
/* t, x, u or p changed behind the core's back (Model Exchange): cached values are stale. */
GW_API void gw_point_changed(gw_instance *I);

/* ---- simulation (gw_simulation.c) --------------------------------------------------------- */

/* Start time, optional stop time, optional tolerance.  The tolerance precedence (applied at
 * initialisation, whatever the order of the calls; docs/fmi.md "Tolerances"):
 *   rel_tol set explicitly (gw_value_set)        -> that rel_tol
 *   else a tolerance defined here                -> rel_tol = tolerance, and abs_tol (unless
 *        set explicitly) scaled alike: default_abs_tol * tolerance / default_rel_tol, so
 *        the declared default tolerance (= default_rel_tol) gives the scene's accuracy
 *   else                                         -> the scene's rel_tol and abs_tol.
 * abs_tol = 0 (the scenes' default) follows the rel_tol in force (GW_ATOL_PER_RTOL * rel_tol)
 * and stays 0 when scaled, so it follows a set-up tolerance too; forwarding the declared
 * default tolerance gives exactly the scene's run.
 * GW_ERROR for a non-finite start, a tolerance outside rel_tol's range or a bad stop time
 * (reason logged). */
GW_API gw_status gw_setup_experiment(gw_instance *I, const char *fn, int tolerance_defined,
                                     double tolerance, double start_time, int stop_time_defined,
                                     double stop_time);
/* End of the set-up phase: checks parameters, start values, inputs, settings and the model's
 * validity checks; x = init(s, p), nominals, outputs, derivatives, event indicators.  Leaves
 * the set-up phase only if everything is consistent (I->in_setup = 0); otherwise GW_ERROR
 * with every reason logged (also for non-finite values: nothing to retry here) and the
 * instance still in its set-up phase. */
GW_API gw_status gw_initialize(gw_instance *I, const char *fn);
/* Integrate from I->t to t_end (> I->t) with the selected solver, locating events.
 * GW_OK: I->t == t_end, or, if the front end set I->stop_at_update (gw_instance.h), the time
 * of an update event the call stopped at (I->stopped_at_update).  GW_DISCARD: a terminating event; I->t is the event time,
 * I->terminated set.  GW_ERROR: reason logged (messages start with fn), instance back at
 * its state before the call.  Outputs are current afterwards.  Never allocates. */
GW_API gw_status gw_advance(gw_instance *I, const char *fn, double t_end);
/* Make I->y the outputs at the current point (set-up phase: from x = init(s, p)). */
GW_API gw_status gw_update_outputs(gw_instance *I, const char *fn);
/* Make I->xdot the state derivatives at the current point (set-up phase: at init(s, p)). */
GW_API gw_status gw_update_derivatives(gw_instance *I, const char *fn);

/* ---- model evaluation with the instance's buffers (gw_eval.c) ------------------------------ */
/* 0 on success, non-zero if the generated function failed or is absent. */
GW_API int gw_eval_init(gw_instance *I, double *x_out);
GW_API int gw_eval_out(gw_instance *I, double t, const double *x, double *y_out);
GW_API int gw_eval_evt(gw_instance *I, double t, const double *x, double *e_out);
GW_API int gw_eval_chk(gw_instance *I, double *c_out);
GW_API int gw_eval_nom(gw_instance *I, double *nom_out);
GW_API int gw_eval_dir(gw_instance *I, double t, const double *x, double *D);
/* D0 = dini(t, s, u, p) (gw_model.h), n_init_rows x (ns+np+nu); -1 if the model has none */
GW_API int gw_eval_dini(gw_instance *I, double t, double *D0);
/* the right-hand side; counts evaluations in I->n_rhs */
GW_API int gw_rhs(gw_instance *I, double t, const double *x, double *xdot);

/* ---- events (gw_events.c) ------------------------------------------------------------------- */

typedef enum {
    GW_EV_NONE = 0,
    GW_EV_WARN = 1,
    GW_EV_TERMINATE = 2,
    GW_EV_ERROR = 3,
    GW_EV_UPDATE = 4 /* the state jumped (GW_EVENT_UPDATE); the integration goes on from it */
} gw_ev_result;
/* Event update at the current point when the front end has located the crossing itself
 * (Model Exchange): e_now are the indicators now, I->e those of the previous update (or the
 * positive values gw_event_observe saw since).  An indicator that went from > 0 to <= 0 (or
 * is <= 0 now and TERMINATE and not yet fired) fires: flag set, logged; an UPDATE event
 * changes I->x (and sets I->x_jumped), and crossings that jump causes fire in the same
 * instant (each event at most once per instant).  Then I->e = the indicators at the final
 * state.  An instant gw_advance stopped at with its update pending (I->update_pending) is
 * applied as it was located there (e_now is not used). */
GW_API gw_ev_result gw_event_update(gw_instance *I, const double *e_now);
/* Indicators the front end evaluated on the current trajectory (Model Exchange,
 * fmi2GetEventIndicators): one that is > 0 arms its event (I->e[i] = e[i]), so that a later
 * <= 0 counts as a crossing even when the previous event update left it at 0. */
GW_API void gw_event_observe(gw_instance *I, const double *e);
/* 1 if event i is a terminating event and has fired: the reason the simulation ended.  A
 * flag alone does not say it: warning events and update events (stiction modes: "switched at
 * least once") set theirs and the simulation goes on. */
GW_API int gw_event_ended(const gw_instance *I, int i);

/* ---- solvers (gw_solver.c) ------------------------------------------------------------------ */

GW_API int gw_solver_available(int solver); /* 1 for a known gw_solver value */
GW_API const char *gw_solver_name(int solver);
/* The solver GW_SOLVER_AUTO integrates with (docs/accuracy.md, "Solver auto"): taylor where
 * the model has the Taylor kernel (m->taylor.jet) and no mode switches (update events: m->upd,
 * the contact modes), dop853 otherwise, at every rel_tol in its range.  Measured with
 * benchmarks/work_precision.py (paper scenario): from rel_tol 0.1 to 1e-14 taylor reaches every
 * error in less time than dop853, and dop853 in less than dopri5, so the tolerance does not
 * enter the rule.  A mode switch can start a sliding mode at zero slip, where the slip
 * direction's series diverge (a wheel that slides from rest on an incline), so models with
 * update events take dop853, whose steps need the right-hand side's values only. */
GW_API int gw_solver_auto(const gw_model *m);

/* ---- saving and restoring the state (gw_state.c, gw_state_checks.c) --------------------------
 * A state is a byte blob (layout in gw_state.c) holding everything but the logging settings,
 * plus two ints of the front end (the FMI layer: its state machine state and the status of
 * the last fmi2DoStep), stored at fixed places so the layout is one for every front end. */
GW_API size_t gw_state_size(const gw_instance *I);
/* buf holds gw_state_size(I) bytes */
GW_API void gw_state_write(const gw_instance *I, const int front[2], unsigned char *buf);
/* 1 if buf is a state of this model with the right layout and size; else 0, reason logged */
GW_API int gw_state_check(gw_instance *I, const char *fn, const unsigned char *buf, size_t size);
/* What the front end's own words (gw_state_front) say about a state, for gw_state_check_run. */
typedef struct {
    int initialised; /* saved after a successful initialisation (gw_initialize) */
    int time_free;   /* the front end lets its caller set t and x at will (Model Exchange) */
    int terminated;  /* the front end's state is one after a terminating event */
    int pending_event; /* the front end stopped at a located crossing and has not yet run its
                          event update (FMI 3.0 Co-Simulation's early return, Event Mode): the
                          state holds that update (I->update_pending), and only then */
} gw_state_facts;
/* 1 if the fields of a checked state agree with each other and pass the live path's checks
 * (the experiment's times in order, events and their flags, the model's validity checks on its
 * parameters and start values); else 0, reason logged.  Run before gw_state_apply. */
GW_API int gw_state_check_run(gw_instance *I, const char *fn, const unsigned char *buf,
                              const gw_state_facts *facts);
/* the front end's two ints of a checked state */
GW_API void gw_state_front(const gw_instance *I, const unsigned char *buf, int front[2]);
/* restore a checked state */
GW_API void gw_state_apply(gw_instance *I, const unsigned char *buf);

#endif /* GW_CORE_H */
