/*
 * gw_ensemble_lib.c -- the ensemble library's front end: the functions <id>_ensemble_* that
 * gyrowheel.taylor.ensemble.Ensemble calls through ctypes, over the ensemble path
 * (gw_ensemble.c) of one model.  The library is one translation unit: the model, the core and
 * this file, compiled from an FMU's sources/ with a unity file the Python side writes,
 *
 *     #define GW_ENSEMBLE_ID <modelIdentifier>     the prefix of the exported names
 *     #define GW_ENSEMBLE_LANES <lanes>            trajectories advanced together
 *     #include "gw_ensemble_lib.c"
 *
 * after the extra #defines of Ensemble(..., defines=...).  Only the <id>_ensemble_* functions
 * are exported (every other function has internal linkage, gw_core.h).  Compiled on its own
 * (no GW_ENSEMBLE_ID) the file is empty, as every .c file of an FMU's sources but gw_fmu.c.
 *
 * The packed run (<id>_ensemble_run_packed) takes every array of a job at its place in one
 * buffer; those places are computed here only (gw_lib_layout) and exported
 * (<id>_ensemble_layout, <id>_ensemble_layout_names), which is where the Python side reads them.
 */
#ifndef GW_ENSEMBLE_ID
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#define GW_UNITY_BUILD 1
#ifndef GW_ENSEMBLE_LANES
#error "GW_ENSEMBLE_LANES: the trajectories advanced together, defined by the unity file"
#endif
/* a rejected step's retry: gw_fm_logexp.h's ln and exp (the step size: gw_fm_step) */
#ifndef GW_TAYLOR_STEP_FM
#define GW_TAYLOR_STEP_FM 1
#endif
#include <stdlib.h>
#include "gw_funcs.c"
#include "gw_taylor.c"
#include "model_desc.c"
#include "gw_core.c"
#include "gw_ensemble.c"

#if defined(__GNUC__)
#define GW_EXPORT __attribute__((visibility("default")))
#else
#define GW_EXPORT
#endif

/* GW_LIB(name): the exported function <GW_ENSEMBLE_ID>_ensemble_<name> */
#define GW_LIB_CAT2(a, b) a##b
#define GW_LIB_CAT(a, b) GW_LIB_CAT2(a, b)
#define GW_LIB(name) GW_LIB_CAT(GW_ENSEMBLE_ID, _ensemble_##name)

static void *gw_lib_alloc(size_t n, size_t size) { return calloc(n, size); }
static void gw_lib_free(void *p) { free(p); }

/* out[0..7]: nx, ns, nu, np, ny, the lanes, 1 if the model has a Taylor kernel, ne */
GW_EXPORT int GW_LIB(sizes)(int *out);
GW_EXPORT int GW_LIB(sizes)(int *out) {
    out[0] = GW_MODEL.nx; out[1] = GW_MODEL.ns; out[2] = GW_MODEL.nu; out[3] = GW_MODEL.np;
    out[4] = GW_MODEL.ny; out[5] = GW_ENSEMBLE_LANES; out[6] = GW_MODEL.taylor.jet != 0;
    out[7] = GW_MODEL.ne;
    return 0;
}

/* the name of variable `index` of a kind (gw_kind), kind < 0: of state `index`; NULL if none */
GW_EXPORT const char *GW_LIB(name)(int kind, int index);
GW_EXPORT const char *GW_LIB(name)(int kind, int index) {
    int i;
    if (kind < 0) return index >= 0 && index < GW_MODEL.nx ? GW_MODEL.x_names[index] : NULL;
    if (kind == GW_VAR_OUTPUT) /* y[index]: an output, or a start value's quantity after init */
        for (i = 0; i < GW_MODEL.n_vars; i++)
            if (GW_MODEL.vars[i].kind == GW_VAR_START && GW_MODEL.vars[i].out_index == index &&
                !gw_variable_name(&GW_MODEL, kind, index))
                return GW_MODEL.vars[i].name;
    return gw_variable_name(&GW_MODEL, kind, index);
}

/* the model's default parameters (np) and start values (ns) */
GW_EXPORT void GW_LIB(defaults)(double *p, double *s);
GW_EXPORT void GW_LIB(defaults)(double *p, double *s) {
    int i;
    for (i = 0; i < GW_MODEL.np; i++) p[i] = GW_MODEL.p_start[i];
    for (i = 0; i < GW_MODEL.ns; i++) s[i] = GW_MODEL.s_start[i];
}

static gw_callbacks gw_lib_callbacks(gw_logger_fn logger) {
    gw_callbacks cb;
    cb.logger = logger;
    cb.allocate = gw_lib_alloc;
    cb.free = gw_lib_free;
    cb.env = NULL;
    return cb;
}

/* a context keeps the lanes' instances and the batch memory between runs (gw_ensemble.h) */
GW_EXPORT void *GW_LIB(new)(void);
GW_EXPORT void *GW_LIB(new)(void) {
    gw_callbacks cb = gw_lib_callbacks(NULL);
    return gw_ensemble_new(&GW_MODEL, &cb);
}

GW_EXPORT void GW_LIB(free)(void *ctx);
GW_EXPORT void GW_LIB(free)(void *ctx) { gw_ensemble_free((gw_ensemble_ctx *)ctx); }

/* `calls` batch-kernel calls at the order of rel_tol, every lane at x, u, p
 * (gw_ensemble_kernel_calls); 0, -1 for rel_tol not > 0 or calls < 0, -2 where the FMU's
 * runtime has no gw_ensemble_kernel_calls (an FMU built by an earlier gyrowheel) */
GW_EXPORT int GW_LIB(kernel_calls)(void *ctx, double rel_tol, long calls, const double *x,
                                   const double *u, const double *p);
GW_EXPORT int GW_LIB(kernel_calls)(void *ctx, double rel_tol, long calls, const double *x,
                                   const double *u, const double *p) {
#ifdef GW_ENSEMBLE_KERNEL_CALLS
    return gw_ensemble_kernel_calls((gw_ensemble_ctx *)ctx, rel_tol, calls, x, u, p) == GW_OK ? 0 : -1;
#else
    (void)ctx, (void)rel_tol, (void)calls, (void)x, (void)u, (void)p;
    return -2;
#endif
}

/* one run (gw_ensemble_job's fields as arguments; span: t_start, t_end; tol: rel_tol, abs_tol,
 * max_step); ctx NULL: memory made and freed in this run */
GW_EXPORT int GW_LIB(run)(void *ctx, long n, const double *p, const double *s,
                          const double *span, const double *tol, int *status, double *t_final,
                          double *x_final, double *y_final, unsigned long *steps,
                          gw_logger_fn logger, int n_grid, const double *t_grid, double *y_grid,
                          long *n_rows, int *flags);
GW_EXPORT int GW_LIB(run)(void *ctx, long n, const double *p, const double *s,
                          const double *span, const double *tol, int *status, double *t_final,
                          double *x_final, double *y_final, unsigned long *steps,
                          gw_logger_fn logger, int n_grid, const double *t_grid, double *y_grid,
                          long *n_rows, int *flags) {
    gw_callbacks cb = gw_lib_callbacks(logger);
    gw_ensemble_job job;
    job.n = n; job.p = p; job.s = s; job.t_start = span[0]; job.t_end = span[1];
    job.rel_tol = tol[0]; job.abs_tol = tol[1]; job.max_step = tol[2];
    job.status = status; job.t_final = t_final; job.x_final = x_final; job.y_final = y_final;
    job.steps = steps;
    job.n_grid = n_grid; job.t_grid = t_grid; job.y_grid = y_grid; job.n_rows = n_rows;
    job.flags = flags;
    return (int)(ctx ? gw_ensemble_run_in((gw_ensemble_ctx *)ctx, logger, NULL, &job)
                     : gw_ensemble_run(&GW_MODEL, &cb, &job));
}

/* ---- the packed run: a job's arrays at fixed places in one buffer ---------------------------
 * What Ensemble.run passes: five arguments instead of seventeen, ctypes converting each at
 * about 0.1 us.  The buffer's sections in this order (n trajectories, G = n_grid communication
 * points, ne' = max(ne, 1)):
 *   doubles   scalars (t_start, t_end, rel_tol, abs_tol, max_step), grid (G), p (n x np),
 *             s (n x ns), then the outputs t_final (n), x_final (n x nx), y_final (n x ny),
 *             y_grid (n x (G + 1) x ny, with a grid)
 *   C longs   steps (n), n_rows (n, with a grid), status (n)
 *   C ints    ints: what the run writes, status (n) and flags (n x ne')
 *   bytes     flags (n x ne', 0 or 1)
 *   end       the buffer's size in bytes, a whole number of doubles
 * status and flags in the types Python hands out, without a conversion there. */
#define GW_LIB_SECTIONS(X)                                                                      \
    X(scalars) X(grid) X(p) X(s) X(t_final) X(x_final) X(y_final) X(y_grid) X(steps) X(n_rows) \
    X(status) X(ints) X(flags) X(end)
#define GW_LIB_ENUM(name) GW_LIB_AT_##name,
#define GW_LIB_NAME(name) #name " "
enum { GW_LIB_SECTIONS(GW_LIB_ENUM) GW_LIB_N_SECTIONS };

/* at[k]: where section k starts, in bytes from the buffer's start */
static void gw_lib_layout(long n, int n_grid, size_t at[GW_LIB_N_SECTIONS]) {
    const size_t N = n > 0 ? (size_t)n : 0, G = n_grid > 0 ? (size_t)n_grid : 0;
    const size_t ne = GW_MODEL.ne > 0 ? (size_t)GW_MODEL.ne : 1, d = sizeof(double);
    const size_t ny = (size_t)GW_MODEL.ny;
    at[GW_LIB_AT_scalars] = 0;
    at[GW_LIB_AT_grid] = 5 * d;
    at[GW_LIB_AT_p] = at[GW_LIB_AT_grid] + G * d;
    at[GW_LIB_AT_s] = at[GW_LIB_AT_p] + N * (size_t)GW_MODEL.np * d;
    at[GW_LIB_AT_t_final] = at[GW_LIB_AT_s] + N * (size_t)GW_MODEL.ns * d;
    at[GW_LIB_AT_x_final] = at[GW_LIB_AT_t_final] + N * d;
    at[GW_LIB_AT_y_final] = at[GW_LIB_AT_x_final] + N * (size_t)GW_MODEL.nx * d;
    at[GW_LIB_AT_y_grid] = at[GW_LIB_AT_y_final] + N * ny * d;
    at[GW_LIB_AT_steps] = at[GW_LIB_AT_y_grid] + (G ? N * (G + 1) * ny * d : 0);
    at[GW_LIB_AT_n_rows] = at[GW_LIB_AT_steps] + N * sizeof(long);
    at[GW_LIB_AT_status] = at[GW_LIB_AT_n_rows] + (G ? N * sizeof(long) : 0);
    at[GW_LIB_AT_ints] = at[GW_LIB_AT_status] + N * sizeof(long);
    at[GW_LIB_AT_flags] = at[GW_LIB_AT_ints] + N * (1 + ne) * sizeof(int);
    at[GW_LIB_AT_end] = (at[GW_LIB_AT_flags] + N * ne + d - 1) / d * d;
}

/* the sections' names, in order, separated by spaces ("scalars grid p ... end") */
GW_EXPORT const char *GW_LIB(layout_names)(void);
GW_EXPORT const char *GW_LIB(layout_names)(void) { return GW_LIB_SECTIONS(GW_LIB_NAME); }

/* out[k]: where section k of the packed run of n trajectories and n_grid points starts, in
 * bytes; returns the number of sections */
GW_EXPORT int GW_LIB(layout)(long n, int n_grid, long *out);
GW_EXPORT int GW_LIB(layout)(long n, int n_grid, long *out) {
    size_t at[GW_LIB_N_SECTIONS];
    int k;
    gw_lib_layout(n, n_grid, at);
    for (k = 0; k < GW_LIB_N_SECTIONS; k++) out[k] = (long)at[k];
    return GW_LIB_N_SECTIONS;
}

/* the run of a job in a buffer of gw_lib_layout(n, n_grid) */
GW_EXPORT int GW_LIB(run_packed)(void *ctx, long n, int n_grid, double *f, gw_logger_fn logger);
GW_EXPORT int GW_LIB(run_packed)(void *ctx, long n, int n_grid, double *f, gw_logger_fn logger) {
    const size_t N = n > 0 ? (size_t)n : 0, G = n_grid > 0 ? (size_t)n_grid : 0;
    const size_t ne = GW_MODEL.ne > 0 ? (size_t)GW_MODEL.ne : 1;
    size_t at[GW_LIB_N_SECTIONS], j;
    char *b = (char *)f;
    long *steps, *status;
    int *ints, rc;
    unsigned char *flags;
    gw_lib_layout(n, n_grid, at);
    steps = (long *)(void *)(b + at[GW_LIB_AT_steps]);
    status = (long *)(void *)(b + at[GW_LIB_AT_status]);
    ints = (int *)(void *)(b + at[GW_LIB_AT_ints]);
    flags = (unsigned char *)(b + at[GW_LIB_AT_flags]);
    rc = GW_LIB(run)(ctx, n, (double *)(void *)(b + at[GW_LIB_AT_p]),
                     (double *)(void *)(b + at[GW_LIB_AT_s]), f, f + 2, ints,
                     (double *)(void *)(b + at[GW_LIB_AT_t_final]),
                     (double *)(void *)(b + at[GW_LIB_AT_x_final]),
                     (double *)(void *)(b + at[GW_LIB_AT_y_final]), (unsigned long *)steps, logger,
                     n_grid, G ? (double *)(void *)(b + at[GW_LIB_AT_grid]) : NULL,
                     G ? (double *)(void *)(b + at[GW_LIB_AT_y_grid]) : NULL,
                     G ? (long *)(void *)(b + at[GW_LIB_AT_n_rows]) : NULL, ints + N);
    for (j = 0; j < N; j++) status[j] = ints[j];
    for (j = 0; j < N * ne; j++) flags[j] = ints[N + j] != 0;
    return rc;
}

#endif /* GW_ENSEMBLE_ID */
