/*
 * gw_ensemble.h -- the ensemble path's API (gw_ensemble.c): N trajectories of one model with
 * solver taylor, GW_ENSEMBLE_LANES at a time, each stopping at its own terminating event.
 * Called by the ensemble library's front end (gw_ensemble_lib.c, built next to an FMU by
 * gyrowheel.taylor.ensemble.Ensemble).
 */
#ifndef GW_ENSEMBLE_H
#define GW_ENSEMBLE_H

#include "gw_core.h"

/* One ensemble run.  Arrays are row-major, one row per trajectory; an input array NULL means
 * the model's defaults for every trajectory; an output array NULL is not written. */
typedef struct {
    long n;                 /* trajectories */
    const double *p;        /* n x np parameters (GW_MODEL order) */
    const double *s;        /* n x ns start values */
    double t_start, t_end;  /* common time span, t_end > t_start */
    double rel_tol, abs_tol, max_step; /* solver settings (as the FMU's parameters) */
    int *status;            /* n (required): GW_OK at t_end, GW_DISCARD stopped by a
                               terminating event (at t_final), GW_ERROR (reason logged) */
    double *t_final;        /* n: t_end, the event time, or where the error happened */
    double *x_final;        /* n x nx: states at t_final */
    double *y_final;        /* n x ny: outputs at t_final (NaN after an error) */
    unsigned long *steps;   /* n: Taylor steps taken */
    /* Optional communication grid (n_grid = 0: none).  Each trajectory then advances from
     * point to point as through fmi2DoStep(t_k, t_(k+1) - t_k) (the budget, the event count and
     * the step size guard start anew at each point; each step lands on it) and records its
     * outputs there: the sweep engine's path (studies/ensemble_path.py). */
    int n_grid;             /* communication points after t_start */
    const double *t_grid;   /* n_grid: increasing, in (t_start, t_end], the last == t_end */
    double *y_grid;         /* n x (n_grid + 1) x ny: outputs at t_start and at each point
                               reached; a terminating event in step k writes row k + 1 at the
                               event time, and no rows after it */
    long *n_rows;           /* n: rows of y_grid written */
    int *flags;             /* n x ne (may be NULL): 1 where event i has fired by t_final */
} gw_ensemble_job;

/* Run a job.  GW_OK when every trajectory was attempted (see job->status for each);
 * GW_ERROR for a bad job or a model without a Taylor kernel; GW_FATAL out of memory.
 * Messages (trajectory failures: "ensemble trajectory <j>: ...") go to cb->logger. */
GW_API gw_status gw_ensemble_run(const gw_model *m, const gw_callbacks *cb,
                                 const gw_ensemble_job *job);

/* The same with the memory kept between runs (the lanes' instances, the batch's series): a run
 * of a few trajectories costs less (Ensemble.run of 4 trajectories to 1 us: 0.051 -> 0.030 ms).  One
 * context per thread at a time.  gw_ensemble_new: NULL if out of memory (cb->allocate and
 * cb->free serve everything the context holds; cb->logger is not used); gw_ensemble_run_in:
 * as gw_ensemble_run, messages to logger(env, ...). */
typedef struct gw_ensemble_ctx gw_ensemble_ctx;
GW_API gw_ensemble_ctx *gw_ensemble_new(const gw_model *m, const gw_callbacks *cb);
GW_API gw_status gw_ensemble_run_in(gw_ensemble_ctx *ctx, gw_logger_fn logger, void *env,
                                    const gw_ensemble_job *job);
GW_API void gw_ensemble_free(gw_ensemble_ctx *ctx);

/* `calls` calls of the batch kernel at the order of rel_tol, every lane at state x (nx), inputs
 * u (nu), parameters p (np): what a lane count costs per step on this machine, without the
 * control (gyrowheel.taylor.lanes.ensemble_lanes times it).  GW_ERROR for rel_tol not > 0 or
 * calls < 0. */
#define GW_ENSEMBLE_KERNEL_CALLS 1 /* for gw_ensemble_lib.c, which also compiles older FMUs' runtimes */
GW_API gw_status gw_ensemble_kernel_calls(gw_ensemble_ctx *ctx, double rel_tol, long calls,
                                          const double *x, const double *u, const double *p);

#endif /* GW_ENSEMBLE_H */
