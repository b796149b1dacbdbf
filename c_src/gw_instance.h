/*
 * gw_instance.h -- the fields of one simulation instance (gw_instance) and the internal
 * interfaces between the core's files (allocation, events, dense output, the integrator).
 *
 * Front ends read the fields marked "front end" (t, x, y, ...) directly and change them only
 * through gw_core.h; everything else is the core's.  There is no global mutable state: all
 * memory hangs off one gw_instance, allocated through its callbacks.
 */
#ifndef GW_INSTANCE_H
#define GW_INSTANCE_H

#include "gw_core.h"

/* ---- a CasADi function with its own work buffers (gw_eval.c) ------------------------- */
typedef struct {
    gw_eval_fn eval; /* NULL: function absent */
    const double **arg;
    double **res;
    gw_int *iw;
    double *w;
    gw_int n_arg, n_res; /* allocated lengths of arg / res */
} gw_fun;

struct gw_instance {
    const gw_model *m;
    gw_callbacks cb; /* copy of the front end's callbacks */
    gw_allocator alloc; /* allocate == NULL: allocation through cb.allocate / cb.free */
    char *name;      /* instance name (copied) */

    int logging_on;
    unsigned int log_mask; /* bit per gw_log_category */

    /* front end: phase and conventions */
    int in_setup;              /* 1: parameters/start values being set; x, y from init(s, p) */
    gw_status nonfinite_status; /* answer to non-finite model values: GW_ERROR (default) or
                                   GW_DISCARD (Model Exchange: the importer may retry) */

    /* settings */
    int solver;       /* the setting: a gw_solver, GW_SOLVER_AUTO included */
    int solver_in_use; /* the solver that integrates: solver, or what GW_SOLVER_AUTO picks
                          (gw_solver_select: whenever the setting changes, at initialisation,
                          at every integration call) */
    double rel_tol, abs_tol, max_step;
    int rel_tol_set, abs_tol_set; /* set explicitly: a set-up tolerance does not replace them */
    double max_internal_steps; /* budget of internal steps of one gw_advance */
    double atol_eff;           /* abs_tol in force: abs_tol, or rel_tol / 100 when abs_tol == 0 */

    /* experiment */
    double t_start, t_stop;
    int stop_defined;
    int tol_defined; /* gw_setup_experiment tolerance: applied at initialisation (gw_core.h) */
    double tolerance;

    /* model data (front end) */
    double t;
    double *x, *s, *u, *p, *y, *e, *c, *nominal;
    int *flags; /* ne: event has fired */
    double *t_events; /* ne: time of the event's last firing (valid where flags[i] is set);
                         part of gw_state's blob */
    int terminated;
    double last_successful_time;
    /* front end: what gw_advance does at a located update event (GW_EVENT_UPDATE, a mode
     * switch): GW_STOP_NEVER integrates through it (the default); GW_STOP_AFTER_UPDATE stops
     * at its time with the updated state; GW_STOP_BEFORE_UPDATE stops there with the state
     * before the update, which stays pending (update_pending: the instant's events as located,
     * in ev_fired and e) until gw_event_update applies it.  stopped_at_update: the last
     * gw_advance stopped so (I->t is the event's time, before the t_end asked for). */
    int stop_at_update;
    int update_pending;
    int stopped_at_update;

    /* caches */
    int y_valid;    /* y == out(t, x, u, p) */
    int fcur_valid; /* k[0] == ode(t, x, u, p) (FSAL / restart) */

    /* solver */
    double h_adapt; /* adaptive step size carried between steps (0: estimate) */
    double *k[7];   /* stage derivatives, nx each */
    double *xnew, *xtmp, *xev, *rcont; /* rcont: 5*nx dense output coefficients */
    double dense_t0, dense_h;          /* the last accepted step [t0, t0 + h] */
    int k7_valid;                      /* k[6] == ode(t0 + h, xnew) */
    int dense_ready;                   /* rcont holds the dense output of that step */
    double *enew, *eev;                /* ne */
    int enew_ready; /* enew holds the indicators at the pending attempt's end (t1, xnew), read
                       from the Taylor kernel's order-0 row (gw_taylor_model.h: GW_TL(evt)) */
    int edot_new_ready; /* edot_new holds their time derivatives there, from the rows of order
                           0 and 1 (GW_TL(evt_slope)) */
    /* compensated summation of the state (TwoSum): x + xc is the state to twice the working
     * precision; xcnew goes with xnew; xc_x is the x that xc belongs to (a front end that
     * writes x makes xc stale) */
    double *xc, *xcnew, *xc_x, *dx;
    double err_old;                 /* PI controller: error norm of the last accepted step (0: none) */
    unsigned long long n_call_steps; /* internal steps (accepted + rejected) of this gw_advance */
    double t_call;                   /* where this gw_advance started */
    /* the run budget's projection window (gw_budget.c, check 4), restarted by every gw_advance */
    double run_h_ref;
    unsigned long run_n_fast;

    /* event instants with state updates (GW_EVENT_UPDATE, gw_events.c) */
    gw_fun f_upd;      /* upd(t, x, u, p, k), only if the model has it */
    double *x_upd;     /* nx: upd's result */
    double *e_upd;     /* ne: indicators after an update */
    /* the indicators' time derivatives (gw_events.c: crossings inside a step): edot at the step's
     * start (I->t, I->x), valid if edot_valid and edot_t == I->t; edot_new at its end */
    double *edot, *edot_new;
    double edot_t;
    int edot_valid;
    int *ev_fired;     /* ne: 0 not yet, 1 fires now, 2 fired in this instant */
    int x_jumped;      /* front end: an update changed x since the front end last cleared it */

    /* backup at the start of gw_advance */
    double *x_bak, *e_bak, *t_events_bak, *xc_bak;
    int *flags_bak;

    /* counters (cumulative since initialisation) */
    unsigned long long n_rhs, n_accepted, n_rejected, n_evt, n_events;

    /* CasADi functions with per-instance buffers */
    gw_fun f_init, f_ode, f_out, f_evt, f_chk, f_nom, f_jac;
    gw_fun f_pre;   /* ode_pre(p) -> pre_c, if the model has it */
    double *pre_c;  /* n_pre: the parameter-only subexpressions of ode, evt at the current p */
    int pre_valid;  /* pre_c == ode_pre(p) */

    /* state derivatives and directional derivatives (front end: Model Exchange, Jacobians) */
    double *xdot; /* nx: ode(t, x, u, p) at the current point, valid if xdot_valid */
    int xdot_valid;
    double *e_me;  /* ne: scratch for event indicators read by the front end */
    gw_fun f_dir;  /* dir(t, x, u, p) -> D, only if the model has `dir` */
    double *dir_D; /* (nx+ny)*(nx+nu), column-major, valid if dir_valid */
    int dir_valid;
    gw_fun f_dini;  /* dini(t, s, u, p) -> D0, only if the model has `dini` */
    double *dini_D; /* n_init_rows*(ns+np+nu), column-major */

    /* DOP853 and Rosenbrock work memory (gw_solver_alloc).  Nothing here survives a saved
     * state: it is recomputed in every step. */
    double *kx[9]; /* extra stage vectors, nx each */
    double *sacc;  /* nx: DOP853's stage sums */
    double *rcx;   /* 3*nx: DOP853 dense output coefficients beyond rcont */
    double *jac;   /* nx*nx: d xdot / d x, column-major (Rosenbrock) */
    double *lu;    /* nx*nx: LU factors of I/(gamma h) - J, column-major */
    int *piv;      /* nx: pivot rows of lu */

    /* Taylor work memory (gw_taylor_alloc; only if the model has a Taylor kernel): the series
     * of the last step (dense output) and the constants.  Nothing here survives a saved state:
     * the series is recomputed in every step, the state's compensation is xc. */
    double *tl_w;    /* n_var * (GW_TAYLOR_MAX_ORDER + 1): the series of the current step */
    double *tl_wn;   /* the same at the step's end point, computed for its defect check */
    double *tl_c;    /* n_cst */
    int tl_order;    /* order of the series in tl_w */
    /* NULL, or called (with tl_fetch_env) before the dense output of the last step is read:
     * the ensemble path (gw_ensemble.c) leaves a lane's series in its batch block and fills
     * tl_w only where it is read (gw_events.c) */
    void (*tl_fetch)(gw_instance *I, void *env);
    void *tl_fetch_env;
    int tl_si, tl_so; /* their layout: state i's coefficient k at [i tl_si + k tl_so] */
    /* f(t1, xnew) of the attempt being concluded, order 1 of the series at its end point
     * (gw_integrate_taylor), contiguous; NULL where that series was not computed.  The
     * indicators' slopes at t1 come from it as from DOPRI5's FSAL stage (gw_events.c) */
    const double *tl_fnew;
};

/* ---- gw_instance.c ------------------------------------------------------------------------ */
GW_INTERNAL void *gw_alloc(const gw_instance *I, size_t n, size_t size); /* zeroed */
GW_INTERNAL void gw_free(const gw_instance *I, void *ptr);

/* ---- gw_eval.c ------------------------------------------------------------------------------ */
/* Buffers of f for generated function g with n_in inputs and n_out outputs; 0 on success. */
GW_INTERNAL int gw_fun_alloc(gw_instance *I, gw_fun *f, const gw_function *g, gw_int n_in,
                             gw_int n_out);
GW_INTERNAL void gw_fun_free(gw_instance *I, gw_fun *f);
/* preset argument pointers that never change (u, p live in the instance) */
GW_INTERNAL void gw_fun_bind(gw_instance *I);
/* J = jac(t, x, u, p), dense d xdot / d x column-major; non-zero if failed or absent */
GW_INTERNAL int gw_eval_jac(gw_instance *I, double t, const double *x, double *J);
/* x_out = upd(t, x, u, p, k); non-zero if failed or absent */
GW_INTERNAL int gw_eval_upd(gw_instance *I, double t, const double *x, int k, double *x_out);
/* I->pre_c = ode_pre(p) if the parameters changed since (the hoisted part of ode and evt);
 * non-zero if it failed */
GW_INTERNAL GW_MAYBE_UNUSED int gw_eval_pre(gw_instance *I);

/* ---- gw_values.c ---------------------------------------------------------------------------- */
#define GW_N_SETTINGS 5 /* gw_setting: solver, rel_tol, abs_tol, max_step, max_internal_steps */
/* Every setting within its range (gw_value_check): value[k] for setting k, or the instance's
 * own settings if value is NULL.  GW_OK, or GW_ERROR with the first reason logged. */
GW_INTERNAL gw_status gw_settings_check(gw_instance *I, const char *fn, const double *value);

/* ---- gw_simulation.c -------------------------------------------------------------------------- */
/* The checks of gw_setup_experiment's arguments, without storing them: GW_OK, or GW_ERROR with
 * the reason logged (also what a restored state must pass, gw_state_checks.c). */
GW_INTERNAL gw_status gw_experiment_check(gw_instance *I, const char *fn, int tolerance_defined,
                                          double tolerance, double start_time,
                                          int stop_time_defined, double stop_time);
/* The model's validity checks c(s, p) > 0 at I->s, I->p (gw_initialize; a restored state):
 * GW_OK, or GW_ERROR with every failed check logged. */
GW_INTERNAL gw_status gw_validity_check(gw_instance *I, const char *fn);
/* nominal = nom(p) at I->p, each finite and > 0: GW_OK, or GW_ERROR with the reason logged. */
GW_INTERNAL gw_status gw_nominals_check(gw_instance *I, const char *fn, double *nominal);
/* I->atol_eff from abs_tol and rel_tol: abs_tol, or GW_ATOL_PER_RTOL * rel_tol if it is 0 */
GW_INTERNAL void gw_update_atol_eff(gw_instance *I);

/* ---- gw_simulation.c: logging a non-finite model value with the front end's status ---------- */
#define GW_LOG_NONFINITE(I, ...)                                                                \
    gw_log((I), (I)->nonfinite_status,                                                          \
           (I)->nonfinite_status >= GW_ERROR ? GW_LOG_ERROR : GW_LOG_DISCARD, __VA_ARGS__)

/* ---- gw_solver.c: the integrator behind gw_advance -------------------------------------------- */
typedef enum {
    GW_INT_OK = 0,
    GW_INT_TERMINATED = 1, /* a terminating event was located; state at the event */
    GW_INT_ERROR = 2,      /* logged; caller restores the state */
    GW_INT_EVENT = 3       /* stopped at an update event (I->stop_at_update); state at the event */
} gw_int_result;

/* I->stop_at_update */
enum { GW_STOP_NEVER = 0, GW_STOP_AFTER_UPDATE = 1, GW_STOP_BEFORE_UPDATE = 2 };

/* Integrate from I->t exactly to t_end, handling events. */
GW_INTERNAL gw_int_result gw_integrate(gw_instance *I, double t_end);
/* Dense output of the last accepted step: prepare once, then evaluate at t within it. */
GW_INTERNAL void gw_dense_prepare(gw_instance *I);
GW_INTERNAL void gw_dense_eval(const gw_instance *I, double t, double *x_out);
/* I->solver_in_use from the setting I->solver (GW_SOLVER_AUTO: gw_solver_auto) */
GW_INTERNAL void gw_solver_select(gw_instance *I);
GW_INTERNAL int gw_solver_alloc(gw_instance *I); /* 0 on success, -1: out of memory */
GW_INTERNAL void gw_solver_free(gw_instance *I);

/* ---- gw_events.c ------------------------------------------------------------------------------ */
/* After an accepted step [t0, t1] (x -> xnew, dense output available on request):
 * evaluates the event indicators at t1 into I->enew.  If one crossed from > 0 to
 * <= 0, locates the earliest crossing te, writes the state there into I->xev and
 * the indicators into I->eev, sets flags, logs, and returns *t_event = te. */
GW_INTERNAL gw_ev_result gw_events_check(gw_instance *I, double t0, double t1, double *t_event);
/* The error of a communication step with more than `limit` events (GW_MAX_EVENTS_PER_STEP; the
 * latest at te): the events that fired since I->t_call, what it means, what to try. */
GW_INTERNAL void gw_events_log_too_many(const gw_instance *I, double te, int limit);
/* gw_initialize: update events whose indicator is <= 0 at the start (I->e) fire now, so the
 * model's discrete state (a stiction mode) is settled before the first step.  0 or -1 logged. */
GW_INTERNAL int gw_events_initial(gw_instance *I, const char *fn);

#endif /* GW_INSTANCE_H */
