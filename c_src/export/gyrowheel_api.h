/*
 * gyrowheel_api.h -- types shared by every model exported with `gyrowheel export-c`.
 *
 * Each exported model has its own header <model>.h whose functions are prefixed with the
 * model's name (paper_earth_create, euler_disk_create, ...); the types and codes they use are
 * defined here, once, so that a program can include the headers of several models and handle
 * their errors alike.  Every export ships a copy of this file; the copies are identical for one
 * GYROWHEEL_API_VERSION (a mismatch stops the compilation).  docs/c_api.md describes the API.
 */
#if defined(GYROWHEEL_API_VERSION) && GYROWHEEL_API_VERSION != 1
#error "gyrowheel_api.h: headers of two different gyrowheel C API versions in one program"
#endif

#ifndef GYROWHEEL_API_H
#define GYROWHEEL_API_H

#include <stddef.h>

#define GYROWHEEL_API_VERSION 1

#ifdef __cplusplus
extern "C" {
#endif

/* Exported functions keep default visibility even under -fvisibility=hidden. */
#if defined(__GNUC__) && !defined(_WIN32)
#define GYROWHEEL_EXPORT __attribute__((visibility("default")))
#else
#define GYROWHEEL_EXPORT
#endif

/* Result of a call.  >= 0: success; < 0: an error, explained by <model>_last_error(instance)
 * (one line naming the function, the variable and the value) and, per code, by
 * <model>_status_string(code). */
typedef enum {
    GYROWHEEL_OK = 0,
    GYROWHEEL_FIRED = 1,      /* advance: reached t; an event that does not end the run fired on
                                 the way (see <model>_get_event) */
    GYROWHEEL_TERMINATED = 2, /* advance: a terminating event (the wheel fell) stopped the run at
                                 the event time, <model>_time(); the state there is readable */
    GYROWHEEL_ERR_ARGUMENT = -1,   /* NULL pointer, index or kind out of range, name given twice */
    GYROWHEEL_ERR_NAME = -2,       /* no variable of that name (of the kinds the call accepts) */
    GYROWHEEL_ERR_NOT_FINITE = -3, /* a value given is NaN or infinite */
    GYROWHEEL_ERR_INVALID = -4,    /* a finite value the model or solver refuses (M <= 0, an
                                      initial state past the fall, an unknown solver, ...) */
    GYROWHEEL_ERR_TIME = -5,       /* advance to a time before the current one, or not finite */
    GYROWHEEL_ERR_TERMINATED = -6, /* advance after the run ended: reset or restore a state */
    GYROWHEEL_ERR_NOT_READY = -7,  /* the instance's last create/reset failed: reset it */
    GYROWHEEL_ERR_SIMULATION = -8, /* integration failed (step size underflow, non-finite
                                      derivatives or outputs, step budget); the instance is back
                                      at its state before the call */
    GYROWHEEL_ERR_STATE = -9,      /* a saved-state buffer that is corrupt, truncated, of another
                                      model or API version; the instance is unchanged */
    GYROWHEEL_ERR_BUFFER = -10,    /* a caller's buffer is too small */
    GYROWHEEL_ERR_MEMORY = -11     /* the allocator returned NULL */
} gyrowheel_status;

/* Kinds of variables, each with its own index range 0 .. <model>_count(kind) - 1. */
typedef enum {
    GYROWHEEL_KIND_PARAMETER = 0, /* fixed for a run: set by create / reset */
    GYROWHEEL_KIND_INITIAL = 1,   /* initial values (positions, angles, angle rates): create /
                                     reset; the initial state follows from them */
    GYROWHEEL_KIND_INPUT = 2,     /* set at any time, constant over one advance */
    GYROWHEEL_KIND_STATE = 3,     /* the continuous state the solver integrates */
    GYROWHEEL_KIND_OUTPUT = 4,    /* computed from the state (the FMU's outputs) */
    GYROWHEEL_KIND_EVENT = 5      /* event flags, 1 once the event has fired */
} gyrowheel_kind;

/* One row of a model's names/units table (static storage, never freed). */
typedef struct {
    const char *name;        /* as in the FMU and the scene file, e.g. "beta" */
    const char *unit;        /* SI, FMI spelling: "rad", "rad/s", "m/s2", "N.m", "1" */
    const char *description; /* one line */
} gyrowheel_variable;

/* Solvers (values of the FMU's `solver` parameter). */
typedef enum {
    GYROWHEEL_SOLVER_EULER = 1,      /* explicit Euler, fixed step max_step */
    GYROWHEEL_SOLVER_RK4 = 2,        /* classic Runge-Kutta 4, fixed step max_step */
    GYROWHEEL_SOLVER_DOPRI5 = 3,     /* Dormand-Prince 5(4), adaptive, dense output */
    GYROWHEEL_SOLVER_ROSENBROCK = 4, /* RODAS4, linearly implicit, for stiff scenes */
    GYROWHEEL_SOLVER_DOP853 = 5,     /* Dormand-Prince 8(5,3), adaptive, dense output */
    GYROWHEEL_SOLVER_TAYLOR = 6,     /* Taylor series of adaptive order; needs the model's Taylor
                                        kernel (a scene with solver taylor or auto) */
    GYROWHEEL_SOLVER_AUTO = 7        /* taylor where the model has the Taylor kernel and no update
                                        events, else dop853
                                        (the default of a scene that names no solver) */
} gyrowheel_solver;

/* Integrator settings of a run; <model>_default_settings gives the scene's. */
typedef struct {
    double start_time; /* s, finite */
    int solver;        /* gyrowheel_solver */
    double rel_tol;    /* 1, in [10 eps = 2.2204460492503131e-15, 1]: relative tolerance of the adaptive solvers */
    double abs_tol;    /* 1, 0 or in [1e-30, 1]: absolute tolerance, scaled by each state's
                          nominal value; 0: rel_tol / 100 (follows the tolerance) */
    double max_step;   /* s, > 0: bound of internal steps; THE step of euler and rk4 */
    long max_internal_steps; /* 1, in [1, 2^31 - 1]: budget of internal steps of one advance
                                (an advance that would need more is refused at once, or stopped
                                when the budget runs out, the instance back where it was);
                                0: the scene's (GW_DEFAULT_MAX_INTERNAL_STEPS, 10^6) */
} gyrowheel_settings;

/* An allocator (optional; NULL means malloc/free).  allocate returns size bytes aligned for any
 * type, or NULL; ctx is handed to both unchanged (an arena per instance needs no global state).
 * All memory is taken in create and given back in free: advance and the other calls never
 * allocate. */
typedef struct {
    void *(*allocate)(void *ctx, size_t size);
    void (*free)(void *ctx, void *ptr);
    void *ctx;
} gyrowheel_allocator;

/* Messages of an instance (events, solver notes, the reasons of errors), when a logger is set. */
typedef enum {
    GYROWHEEL_LOG_INFO = 0,
    GYROWHEEL_LOG_WARNING = 1,
    GYROWHEEL_LOG_ERROR = 2
} gyrowheel_log_level;
typedef void (*gyrowheel_logger)(void *env, gyrowheel_log_level level, const char *message);

/* Work counters since the run was (re)initialised. */
typedef struct {
    unsigned long long rhs_evaluations; /* right-hand side evaluations */
    unsigned long long steps_accepted;
    unsigned long long steps_rejected;
    unsigned long long events; /* event firings */
} gyrowheel_statistics;

#ifdef __cplusplus
}
#endif

#endif /* GYROWHEEL_API_H */
