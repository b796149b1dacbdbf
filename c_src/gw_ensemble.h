/*
 * gw_ensemble.h -- the ensemble path's API (gw_ensemble.c): N trajectories of one model with
 * solver taylor, GW_ENSEMBLE_LANES at a time, each stopping at its own terminating event.
 * Called by the ensemble library (fmu_build/ensemble.py builds it next to an FMU, Python
 * wrapper fmu_build.ensemble.Ensemble) and, later, by the plain C API of `gyrowheel export-c`.
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
} gw_ensemble_job;

/* Run a job.  GW_OK when every trajectory was attempted (see job->status for each);
 * GW_ERROR for a bad job or a model without a Taylor kernel; GW_FATAL out of memory.
 * Messages (trajectory failures: "ensemble trajectory <j>: ...") go to cb->logger. */
GW_API gw_status gw_ensemble_run(const gw_model *m, const gw_callbacks *cb,
                                 const gw_ensemble_job *job);

#endif /* GW_ENSEMBLE_H */
