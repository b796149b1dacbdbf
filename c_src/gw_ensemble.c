/*
 * gw_ensemble.c -- the ensemble path: N trajectories of one model (each its own parameters and
 * start values) integrated by solver taylor, GW_ENSEMBLE_LANES of them advanced together.
 *
 * Each lane is a full gw_instance (the same checks, initialisation, events, outputs and error
 * messages as one FMU run); only the Taylor coefficients are computed for all lanes at once by
 * the model's kernel instantiated with GW_ENSEMBLE_LANES lanes (gw_tlb_series: structure of
 * arrays, the lane loops of gw_taylor_ops.h vectorise; on x86-64 with GCC or clang the kernel
 * is also compiled for x86-64-v3 (AVX2, FMA) and x86-64-v4 (AVX-512) and chosen at load time,
 * target_clones, with a portable default).  Each lane then takes its own step
 * (gw_taylor_attempt / _conclude of solver taylor: its own step size, defect check, dense
 * output, event location, compensated update); the batch runs each lane at its pending
 * attempt's end point, so that the series of the next step is also the defect check's
 * f(t1, P(h)) (one kernel call per lane and step, as in gw_integrate_taylor).  A lane whose
 * trajectory reaches t_end or stops at a terminating event (a fall) takes the next trajectory of
 * the job at once, while the others go on; the tail of the job (fewer active lanes than
 * GW_ENSEMBLE_LANES) stays on the lane kernel, the idle lanes repeating an active one, unless
 * GW_ENSEMBLE_SINGLE_MAX (default 0) lets the one-lane kernel take it (below).
 * The order p is common (from rel_tol); the constants are recomputed only when a lane's
 * parameters change.
 *
 * Not part of an FMU's binary: included by the ensemble library's front end (gw_ensemble_lib.c),
 * after gw_core.c and the model (gw_taylor_model.h).  All memory through the callbacks.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "gw_ensemble.h"
#include "gw_solver.h"

#ifndef GW_ENSEMBLE_LANES
#define GW_ENSEMBLE_LANES 4 /* gyrowheel.taylor.ensemble.LANES */
#endif

#if defined(__GNUC__) && defined(__x86_64__) && defined(__ELF__) && !defined(GW_NO_CLONES) &&   \
    ((defined(__clang__) && __clang_major__ >= 14) || (!defined(__clang__) && __GNUC__ >= 8))
/* used below, so no GW_MAYBE_UNUSED (clang refuses it beside target_clones); x86-64-v4
 * (AVX-512): 3% less per trajectory than v3 with 4 lanes on an AVX-512 machine (32 vector
 * registers), the same values */
#define GW_TL_STATIC                                                                              \
    static __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
/* GW_ENSEMBLE_AVX512 (gyrowheel.taylor.lanes.slice_width: the CPU has AVX-512F, the lanes are a
 * multiple of 8): the kernel's slices are 8 doubles, one AVX-512 register in the x86-64-v4
 * clone that CPU runs (on one machine per trajectory 0.63-0.78x the time of 4-double slices at
 * 8 lanes, N = 16 and 64, paper, benchmarks/ensemble_scaling.py; on another no faster, so
 * gyrowheel.taylor.lanes.ensemble_lanes times both).  Each lane's operations are those of a
 * 4-double slice, so the bits are the same.  Not without the clones: the portable code would
 * run the 8-double vectors as 2-double pieces through memory. */
#if defined(GW_ENSEMBLE_AVX512) && GW_ENSEMBLE_AVX512
#define GW_TL_VW_MAX 8
#endif
#else
#define GW_TL_STATIC static GW_MAYBE_UNUSED
#endif
#define GW_TL_W GW_ENSEMBLE_LANES
#define GW_TL(name) gw_tlb_##name
#include "gw_taylor_model.h" /* with its recurrences, gw_taylor_ops.h */
#undef GW_TL
#undef GW_TL_W
#undef GW_TL_STATIC
#undef GW_TL_VW_MAX

/* one lane: its instance, the trajectory it holds (-1: none), the bookkeeping of its run */
typedef struct {
    gw_instance *I;
    long traj;
    gw_taylor_run run;
    int gi;          /* next communication point (job->t_grid), if the job has a grid */
    unsigned long steps; /* Taylor steps of this trajectory */
    int pending;     /* an attempt (h, t1; I->xnew) awaits its defect check: the lane's point in
                        the next batch is its end point, else the lane's current point; 2: made
                        by the batch's passes, its end point and P'(h) already in the batch's
                        columns E->x, E->dp, I->k[2] not written (gw_ens_dp) */
    double h, t1;
    const double *ser; /* the series at the lane's current point in a batch block (lane
                          innermost), not yet in I->tl_w (gw_ens_fetch); NULL: tl_w has it */
    int soa; /* 0: the lane's states in its instance; 1, 2: in the batch's columns, not yet in
                the instance (gw_ensemble_batch.h, gw_ens_sync) */
} gw_lane;
enum { GW_ENS_LANES = GW_ENSEMBLE_LANES };
/* The batch's series where the kernel leaves them (gw_tlb_series: order-major, a row of its
 * nodes per order, the states first): state i's coefficient k of lane l at
 * w[i GW_ENS_SI + k GW_ENS_SO + l].  Read in place: gw_tlb_jet's copy of the states' series into
 * a state-major block was 4% of a run (N = 4, 4 lanes). */
#define GW_ENS_SI ((size_t)GW_ENS_LANES)
/* the series blocks' alignment (bytes): a slice of 8 lanes, else of 4 (gw_taylor_ops.h) */
#define GW_ENS_ALIGN (GW_ENS_LANES % 8 == 0 ? 64u : 32u)
#define GW_ENS_SO ((size_t)gw_tlb_row * GW_ENS_LANES)

/* With this many active lanes or fewer the batch runs each lane's series with the one-lane
 * kernel (gw_tl1_jet, as solver taylor does) instead of all GW_ENS_LANES lanes of gw_tlb_jet.
 * Default 0 (never): the library is compiled with FMA contraction, which rounds the one-lane
 * kernel unlike the lane kernel (1e-13 on the paper's states), so a trajectory of a job's tail
 * (N not a multiple of the lanes, or trajectories ending at different times) took other bits
 * than in a full batch, and a sweep's points depended on the batch size
 * (tests/test_ensemble.py::test_a_trajectory_has_the_same_bits_in_any_batch).  Its cost at 4
 * lanes: none measured (N = 1, 5, 64, rel_tol 1e-4 and 1e-10: 0.99-1.03x, one slice is one
 * vector); at 8 lanes the lone lane's kernel costs about 3.3 one-lane kernels (N = 1: 3.3 ms
 * per trajectory against 1.07 ms with the one-lane kernel, paper, rel_tol 1e-10). */
#ifndef GW_ENSEMBLE_SINGLE_MAX
#define GW_ENSEMBLE_SINGLE_MAX 0
#endif

typedef struct {
    const gw_model *m;
    const gw_ensemble_job *job;
    gw_lane lane[GW_ENS_LANES];
    double *w, *c, *x, *u, *p, t[GW_ENS_LANES]; /* batch kernel memory, lanes innermost */
    double *wb[2]; /* the series blocks: w is one, the other keeps the previous batch's series,
                      which a pending attempt's retries and event location read */
    double *wa[2]; /* wb[0], wb[1] aligned to GW_ENS_ALIGN bytes (the kernel's slices) */
    /* the lane-innermost step passes (gw_ens_norms, _defects, _increments), nx x lanes each:
     * (atol / rel_tol) nominal_i and atol nominal_i of each lane, the pending attempt's P'(h),
     * the increment's Horner sums (then dx) and their derivatives (then P'(h)) */
    double *fsn, *anom, *dp, *qx;
    double lc[GW_ENS_LANES]; /* log2 c of the step size rule, each lane's (run.log2_c) */
    double *xa, *xca, *xcn; /* the states x, xc, xcnew of lanes with soa (gw_ens_sync) */
    long next;                                  /* next trajectory to start */
    int cst_dirty;                              /* a lane's parameters or inputs changed */
} gw_ensemble;

/* I->tl_fetch of a lane's instance: its series from the batch block into I->tl_w, where the
 * solver code reads it (dense output, a rejected step's retries, a landing step).  Not copying
 * every step saves a pass over every lane's series (about 7% of a run). */
static void gw_ens_fetch(gw_instance *I, void *env) {
    gw_lane *L = (gw_lane *)env;
    const int nx = I->m->nx, p = I->tl_order;
    int i, k;
    if (!L->ser) return;
    for (i = 0; i < nx; i++)
        for (k = 0; k <= p; k++)
            I->tl_w[(size_t)i * (size_t)(p + 1) + (size_t)k] =
                L->ser[(size_t)i * GW_ENS_SI + (size_t)k * GW_ENS_SO];
    L->ser = NULL;
}

static void gw_ens_finish(gw_ensemble *E, gw_lane *L, gw_status status) {
    const gw_ensemble_job *job = E->job;
    const gw_model *m = E->m;
    const long j = L->traj;
    gw_instance *I = L->I;
    int i;
    if (status != GW_ERROR && gw_update_outputs(I, "ensemble") > GW_DISCARD) status = GW_ERROR;
    job->status[j] = (int)status;
    if (job->t_final) job->t_final[j] = I->t;
    if (job->x_final)
        for (i = 0; i < m->nx; i++) job->x_final[(size_t)j * m->nx + i] = I->x[i];
    if (job->y_final)
        for (i = 0; i < m->ny; i++)
            job->y_final[(size_t)j * m->ny + i] = status == GW_ERROR ? NAN : I->y[i];
    if (job->steps) job->steps[j] = L->steps;
    if (job->flags)
        for (i = 0; i < m->ne; i++) job->flags[(size_t)j * m->ne + i] = I->flags[i] != 0;
    L->traj = -1;
}

/* the lane's target of this call: the next communication point, or t_end */
static double gw_ens_target(const gw_ensemble *E, const gw_lane *L) {
    return E->job->n_grid > 0 ? E->job->t_grid[L->gi] : E->job->t_end;
}

/* outputs of lane L as row `row` of its trajectory in y_grid; 0, or -1 (failure logged) */
static int gw_ens_record(gw_ensemble *E, gw_lane *L, long row) {
    const gw_ensemble_job *job = E->job;
    const int ny = E->m->ny;
    int i;
    if (!job->y_grid) return 0;
    if (gw_update_outputs(L->I, "ensemble") > GW_DISCARD) return -1;
    for (i = 0; i < ny; i++)
        job->y_grid[((size_t)L->traj * (size_t)(job->n_grid + 1) + (size_t)row) * (size_t)ny + i] =
            L->I->y[i];
    job->n_rows[L->traj] = row + 1;
    return 0;
}

/* A new call as gw_advance starts one: the budget, the event count, the guard's window. */
static void gw_ens_new_call(gw_lane *L) {
    L->I->n_call_steps = 0;
    L->I->t_call = L->I->t;
    L->run.events = 0;
    L->run.n_fast = 0;
    L->run.h_prev = 0.0;
    gw_point_changed(L->I);
}

/* "ensemble trajectory <j>" into a lane's name buffer (GW_ENS_NAME bytes, made with the lane):
 * the logger's instance argument says whose message it is.  Written by hand, in place: the
 * snprintf and the name's reallocation were about 0.15 us of each trajectory's start. */
#define GW_ENS_NAME 48
static void gw_ens_name(char *name, long j) {
    static const char prefix[] = "ensemble trajectory ";
    char digits[24];
    int n = 0;
    unsigned long u = (unsigned long)j;
    do {
        digits[n++] = (char)('0' + (int)(u % 10u));
        u /= 10u;
    } while (u);
    memcpy(name, prefix, sizeof prefix - 1);
    name += sizeof prefix - 1;
    while (n) *name++ = digits[--n];
    *name = '\0';
}

/* Start trajectories in lane L until one initialises (or none is left). */
static void gw_ens_fill(gw_ensemble *E, gw_lane *L) {
    const gw_ensemble_job *job = E->job;
    const gw_model *m = E->m;
    while (L->I && L->traj < 0 && E->next < job->n) {
        const long j = E->next++;
        gw_instance *I = L->I;
        const char *fn = I->name; /* the trajectory's name, also the functions' in messages */
        int i;
        gw_ens_name(I->name, j); /* (integration errors carry no function name) */
        gw_instance_reset(I);
        for (i = 0; i < m->np; i++) I->p[i] = job->p ? job->p[(size_t)j * m->np + i] : m->p_start[i];
        for (i = 0; i < m->ns; i++) I->s[i] = job->s ? job->s[(size_t)j * m->ns + i] : m->s_start[i];
        I->solver = GW_SOLVER_TAYLOR;
        I->rel_tol = job->rel_tol;
        I->abs_tol = job->abs_tol;
        I->max_step = job->max_step;
        L->traj = j;
        L->gi = 0;
        L->steps = 0;
        L->pending = 0;
        L->ser = NULL;
        L->soa = 0;
        if (job->n_rows) job->n_rows[j] = 0;
        if (gw_setup_experiment(I, fn, 0, 0.0, job->t_start, 1, job->t_end) != GW_OK ||
            gw_initialize(I, fn) > GW_WARNING || gw_taylor_begin(I, &L->run)) {
            gw_ens_finish(E, L, GW_ERROR);
            continue;
        }
        /* one call per communication step (without a grid: the whole trajectory is one call,
         * the budget max_internal_steps covers t_start .. t_end) */
        gw_ens_new_call(L);
        if (gw_ens_record(E, L, 0)) {
            gw_ens_finish(E, L, GW_ERROR);
            continue;
        }
        { /* the error weights' floors of this lane, as gw_taylor_step and _defect form them */
            const size_t l = (size_t)(L - E->lane);
            E->lc[l] = L->run.log2_c;
            for (i = 0; i < m->nx; i++) {
                E->fsn[(size_t)i * GW_ENS_LANES + l] = I->atol_eff / I->rel_tol * I->nominal[i];
                E->anom[(size_t)i * GW_ENS_LANES + l] = I->atol_eff * I->nominal[i];
            }
        }
        if (m->taylor.n_cst > 0) { /* this lane's constants (the kernel computes all lanes) */
            const int l = (int)(L - E->lane);
            for (i = 0; i < m->np; i++) E->p[(size_t)i * GW_ENS_LANES + l] = I->p[i];
            for (i = 0; i < m->nu; i++) E->u[(size_t)i * GW_ENS_LANES + l] = I->u[i];
            E->cst_dirty = 1;
        }
        if (m->taylor.cst) m->taylor.cst(I->u, I->p, I->tl_c); /* for the one-lane kernel */
    }
}

/* Lane L after a concluded step (result r): an error or a fall ends its trajectory, a
 * communication point reached is recorded and starts the next call or ends the trajectory.
 * Returns 1 if the lane goes on with the same trajectory inside the same call. */
static int gw_ens_after(gw_ensemble *E, gw_lane *L, gw_int_result r, double target) {
    L->steps = L->run.steps;
    if (r == GW_INT_ERROR) {
        gw_ens_finish(E, L, GW_ERROR);
        return 0;
    }
    if (r == GW_INT_TERMINATED) {
        gw_ens_finish(E, L, gw_ens_record(E, L, L->gi + 1) ? GW_ERROR : GW_DISCARD);
        return 0;
    }
    if (L->I->t < target) return 1;
    L->I->t = target; /* a communication point (or t_end) reached */
    gw_point_changed(L->I);
    if (gw_ens_record(E, L, L->gi + 1))
        gw_ens_finish(E, L, GW_ERROR);
    else if (!(target < E->job->t_end))
        gw_ens_finish(E, L, GW_OK);
    else {
        L->gi++;
        gw_ens_new_call(L);
    }
    return 0;
}

/* Lane l's point in the next batch: its attempt's end (pending) or its current point. */
static void gw_ens_point(gw_ensemble *E, int l) {
    const gw_lane *L = &E->lane[l];
    const double *x = L->pending ? L->I->xnew : L->I->x;
    int i;
    E->t[l] = L->pending ? L->t1 : L->I->t;
    if (L->pending == 2) return; /* the passes wrote its point and P'(h) in place */
    for (i = 0; i < E->m->nx; i++) E->x[(size_t)i * GW_ENS_LANES + l] = x[i];
    if (L->pending) /* the attempt's P'(h), for the defect pass */
        for (i = 0; i < E->m->nx; i++) E->dp[(size_t)i * GW_ENS_LANES + l] = L->I->k[2][i];
}

/* Lane l's attempt's P'(h) from the batch's column into I->k[2], where the solver code's defect
 * check reads it (an attempt of the passes concluded by the one-lane code) */
static void gw_ens_dp_copy(gw_ensemble *E, int l) {
    int i;
    for (i = 0; i < E->m->nx; i++) E->lane[l].I->k[2][i] = E->dp[(size_t)i * GW_ENS_LANES + l];
}

/* Lane L, its series at its current point in I->tl_w: the next attempt.  A step that lands on
 * the call's target is checked at once (one right-hand side evaluation, as solver taylor
 * does); the lane then needs the series at its new point (or a new trajectory). */
static void gw_ens_attempt(gw_ensemble *E, gw_lane *L) {
    const double target = gw_ens_target(E, L);
    gw_int_result r;
    int last, fresh;
    L->pending = 0;
    r = gw_taylor_attempt(L->I, target, &L->run, &L->h, &L->t1, &last);
    if (r != GW_INT_OK) {
        gw_ens_after(E, L, r, target);
        return;
    }
    if (!last) {
        L->pending = 1;
        return;
    }
    r = gw_taylor_conclude(L->I, target, &L->run, L->h, L->t1, NULL, 1, &fresh);
    gw_ens_after(E, L, r, target);
}

/* Lane l after its one-lane kernel call (the tail of a job): conclude its pending attempt with
 * f(t1, P(h)) from the series at that point (I->tl_wn), then, if that series is the lane's new
 * current one, take it and attempt the next step. */
static void gw_ens_advance(gw_ensemble *E, int l, int order) {
    gw_lane *L = &E->lane[l];
    gw_instance *I = L->I;
    const long traj = L->traj;
    int fresh = 1;
    if (L->pending) {
        const double target = gw_ens_target(E, L);
        gw_int_result r = gw_taylor_conclude(I, target, &L->run, L->h, L->t1, I->tl_wn + 1,
                                             (size_t)order + 1, &fresh);
        L->pending = 0;
        if (!gw_ens_after(E, L, r, target)) fresh = 0;
    }
    if (L->traj != traj || L->traj < 0) return; /* ended (a new one, if any, needs its series) */
    if (!fresh) return;                          /* the state moved: a new series next batch */
    {
        double *tmp = I->tl_w;
        I->tl_w = I->tl_wn;
        I->tl_wn = tmp;
    }
    gw_ens_attempt(E, L);
}

#include "gw_ensemble_batch.h" /* gw_ens_batch_steps: every lane's step after the batch kernel */

/* the same for a pending attempt of the passes (pending 2), its states into the instance too */
static void gw_ens_dp(gw_ensemble *E, int l) {
    if (E->lane[l].pending != 2) return;
    gw_ens_sync(E, l);
    gw_ens_dp_copy(E, l);
    E->lane[l].pending = 1;
}

/* One batch: the series of every active lane at its point, then each lane's step.  Returns
 * the number of active lanes (0: the job is done). */
static int gw_ens_step(gw_ensemble *E, int order) {
    const gw_model *m = E->m;
    int l, i, active = -1, n_active = 0;
    for (l = 0; l < GW_ENS_LANES; l++)
        if (E->lane[l].traj >= 0) {
            active = l;
            n_active++;
            gw_ens_point(E, l);
            E->lane[l].I->n_rhs++; /* one kernel call counts as one right-hand side evaluation */
        }
    if (active < 0) return 0;
    if (n_active <= GW_ENSEMBLE_SINGLE_MAX) { /* the one-lane kernel, lane by lane */
        for (l = 0; l < GW_ENS_LANES; l++) {
            gw_instance *I = E->lane[l].I;
            if (E->lane[l].traj < 0) continue;
            gw_ens_fetch(I, &E->lane[l]); /* the lane's series from the last batch */
            gw_ens_dp(E, l);              /* its pending attempt's P'(h) for gw_taylor_defect */
            m->taylor.jet(order, &E->t[l], E->lane[l].pending ? I->xnew : I->x, I->tl_c, I->tl_wn);
        }
        for (l = 0; l < GW_ENS_LANES; l++)
            if (E->lane[l].traj >= 0) {
                gw_ens_advance(E, l, order);
                if (E->lane[l].traj < 0) gw_ens_fill(E, &E->lane[l]);
            }
        return n_active;
    }
    for (l = 0; l < GW_ENS_LANES; l++) { /* idle lanes repeat an active one (finite values) */
        if (E->lane[l].traj >= 0) continue;
        E->t[l] = E->t[active];
        for (i = 0; i < m->nx; i++)
            E->x[(size_t)i * GW_ENS_LANES + l] = E->x[(size_t)i * GW_ENS_LANES + active];
        if (m->taylor.n_cst > 0 && E->lane[l].traj == -1) {
            const gw_instance *A = E->lane[active].I;
            for (i = 0; i < m->np; i++) E->p[(size_t)i * GW_ENS_LANES + l] = A->p[i];
            for (i = 0; i < m->nu; i++) E->u[(size_t)i * GW_ENS_LANES + l] = A->u[i];
            E->lane[l].traj = -2; /* idle, with an active lane's parameters */
            E->cst_dirty = 1;
        }
    }
    if (m->taylor.n_cst > 0 && E->cst_dirty) gw_tlb_cst(E->u, E->p, E->c);
    E->cst_dirty = 0;
    E->w = E->w == E->wa[0] ? E->wa[1] : E->wa[0]; /* the lanes' series stay in the other */
    gw_tlb_series(order, E->t, E->x, E->c, E->w);
    gw_ens_batch_steps(E, order);
    for (l = 0; l < GW_ENS_LANES; l++)
        if (E->lane[l].traj == -1) gw_ens_fill(E, &E->lane[l]);
    return n_active;
}

#include "gw_ensemble_ctx.h" /* gw_ensemble_new, gw_ensemble_free: the context kept between runs */

GW_API gw_status gw_ensemble_run_in(gw_ensemble_ctx *C, gw_logger_fn logger, void *env,
                                    const gw_ensemble_job *job) {
    gw_ensemble *E = &C->E;
    const gw_model *m = E->m;
    int l, order;
    long j;
    int bad_grid = job->n_grid < 0 || (job->n_grid > 0 && (!job->t_grid || !job->n_rows ||
                                                           job->t_grid[job->n_grid - 1] != job->t_end));
    for (j = 0; !bad_grid && j < job->n_grid; j++)
        bad_grid = !(job->t_grid[j] > (j > 0 ? job->t_grid[j - 1] : job->t_start));
    if (!m->taylor.jet || job->n < 0 || !job->status || !(job->t_end > job->t_start) ||
        !(job->rel_tol > 0.0) || !(job->abs_tol >= 0.0) || !(job->max_step > 0.0) || bad_grid) {
        if (logger)
            logger(env, "ensemble", GW_ERROR, "logStatusError",
                   !m->taylor.jet ? "ensemble: the model has no Taylor kernel"
                                  : "ensemble: bad job (n >= 0, status, t_end > t_start, "
                                    "rel_tol, max_step > 0, abs_tol >= 0, an increasing grid "
                                    "ending at t_end with n_rows required)");
        return GW_ERROR;
    }
    E->job = job;
    E->next = 0;
    E->cst_dirty = 0;
    E->w = E->wa[0];
    order = gw_taylor_order(job->rel_tol);
    for (j = 0; j < (long)((size_t)m->nx * GW_ENS_LANES); j++) E->fsn[j] = E->anom[j] = 1.0; /* idle */
    for (l = 0; l < GW_ENS_LANES; l++) { /* instances for the lanes that will have work */
        gw_lane *L = &E->lane[l];
        L->traj = -1;
        if (l >= job->n) continue;
        if (!L->I) {
            char name[32];
            gw_callbacks cb = C->cb;
            cb.logger = logger;
            cb.env = env;
            snprintf(name, sizeof name, "ensemble lane %d", l);
            char *buf = NULL;
            if (!(L->I = gw_instance_new(m, name, &cb, 0)) ||
                !(buf = (char *)gw_alloc(L->I, GW_ENS_NAME, 1))) {
                if (L->I) gw_instance_free(L->I);
                L->I = NULL;
                if (logger)
                    logger(env, "ensemble", GW_FATAL, "logStatusFatal", "ensemble: out of memory");
                return GW_FATAL;
            }
            memcpy(buf, name, strlen(name) + 1); /* the name buffer gw_ens_name writes into */
            gw_free(L->I, L->I->name);
            L->I->name = buf;
            L->I->tl_fetch = gw_ens_fetch;
            L->I->tl_fetch_env = L;
        }
        L->I->cb.logger = logger; /* this run's messages */
        L->I->cb.env = env;
    }
    for (j = 0; j < job->n; j++) job->status[j] = (int)GW_FATAL; /* not run (yet) */
    for (l = 0; l < GW_ENS_LANES; l++) gw_ens_fill(E, &E->lane[l]);
    while (gw_ens_step(E, order) > 0) {
    }
    return GW_OK;
}

/* `calls` calls of the batch kernel at the order of rel_tol (gw_taylor_order), every lane at the
 * state x (nx) with inputs u (nu) and parameters p (np), in the context's batch memory: the
 * arithmetic of an ensemble step without its control, which gyrowheel.taylor.lanes times to
 * compare lane counts on the machine at hand.  The next run sets every lane afresh.  GW_OK, or
 * GW_ERROR for rel_tol not > 0 or calls < 0 (nothing run). */
GW_API gw_status gw_ensemble_kernel_calls(gw_ensemble_ctx *C, double rel_tol, long calls,
                                          const double *x, const double *u, const double *p) {
    gw_ensemble *E = &C->E;
    const gw_model *m = E->m;
    int i, l, order;
    long k;
    if (!(rel_tol > 0.0) || calls < 0) return GW_ERROR;
    order = gw_taylor_order(rel_tol);
    for (l = 0; l < GW_ENS_LANES; l++) {
        E->t[l] = 0.0;
        for (i = 0; i < m->nx; i++) E->x[(size_t)i * GW_ENS_LANES + l] = x[i];
        for (i = 0; i < m->nu; i++) E->u[(size_t)i * GW_ENS_LANES + l] = u[i];
        for (i = 0; i < m->np; i++) E->p[(size_t)i * GW_ENS_LANES + l] = p[i];
    }
    if (m->taylor.n_cst > 0) gw_tlb_cst(E->u, E->p, E->c);
    for (k = 0; k < calls; k++) gw_tlb_series(order, E->t, E->x, E->c, E->wa[0]);
    return GW_OK;
}

GW_API gw_status gw_ensemble_run(const gw_model *m, const gw_callbacks *cb,
                                 const gw_ensemble_job *job) {
    gw_ensemble_ctx *C = gw_ensemble_new(m, cb);
    gw_status st;
    if (!C) {
        if (cb->logger)
            cb->logger(cb->env, "ensemble", GW_FATAL, "logStatusFatal", "ensemble: out of memory");
        return GW_FATAL;
    }
    st = gw_ensemble_run_in(C, cb->logger, cb->env, job);
    gw_ensemble_free(C);
    return st;
}

#endif /* GW_UNITY_BUILD */
