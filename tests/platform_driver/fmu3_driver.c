/*
 * fmu3_driver.c -- a minimal FMI 3.0 Co-Simulation master in C99, fmu_driver.c's counterpart:
 * loads the shared library of an unpacked FMI 3.0 FMU, runs it as an importer does and prints
 * the values asked for at every communication point.  Built for each platform the tests run
 * an FMU's binary on (natively, under qemu-user, under Wine).
 *
 *   fmu3_driver LIBRARY TOKEN RESOURCES START STOP STEP TOL VR[,VR...] [SETTING...]
 *
 * LIBRARY    the FMU's binary (binaries/<platform tuple>/<modelIdentifier>.<so|dll|dylib>)
 * TOKEN      the modelDescription's instantiationToken
 * RESOURCES  the unpacked FMU's resources/ folder, a native path ending in its separator
 *            (FMI 3.0.2, section 2.3.1: resourcePath)
 * START, STOP, STEP, TOL   as fmu_driver's (fmi3EnterInitializationMode; TOL 0: none given)
 * VR,...     value references of the Float64 variables printed at every communication point
 * SETTING    r:VR=VALUE (fmi3SetFloat64), i:VR=VALUE (fmi3SetInt32) or e:VR=VALUE
 *            (fmi3SetInt64: enumerations, FMI 3.0.2 section 2.4.7.5), applied after
 *            instantiation, before initialization
 *
 * The instance is made with earlyReturnAllowed and without eventModeUsed (section 4.2.1):
 * the FMU handles its events inside fmi3DoStep and may return early.  Output (stdout), every
 * number with %.17g:
 *   one line per communication point:  TIME VALUE...
 *   when fmi3DoStep sets terminateSimulation (the FMU ended the run, e.g. at a terminating
 *   event):                            # terminate early=0|1 time=LAST_SUCCESSFUL_TIME
 *   followed by the line of the values at that time; the run then ends normally.
 * An early return without terminateSimulation continues from lastSuccessfulTime to the same
 * communication point.  The FMU's log messages go to stderr.  Exit status: 0 run to its end
 * (or to the FMU's termination), 1 an FMI call failed, 2 bad arguments or a library that
 * does not load.
 * Sources: FMI 3.0.2, sections 2.3.1 (instantiation), 4.2.1 (fmi3DoStep's outputs).
 */
#include "fmi3FunctionTypes.h"

typedef fmi3ValueReference driver_vr;
#define DRIVER_NAME "fmu3_driver"
#define DRIVER_WARNING fmi3Warning
#include "driver.h"

typedef struct {
    fmi3InstantiateCoSimulationTYPE *instantiate;
    fmi3FreeInstanceTYPE *free_instance;
    fmi3EnterInitializationModeTYPE *enter_initialization;
    fmi3ExitInitializationModeTYPE *exit_initialization;
    fmi3TerminateTYPE *terminate;
    fmi3SetFloat64TYPE *set_float64;
    fmi3SetInt32TYPE *set_int32;
    fmi3SetInt64TYPE *set_int64;
    fmi3GetFloat64TYPE *get_float64;
    fmi3DoStepTYPE *do_step;
} fmi3_api;

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                   fmi3String message) {
    (void)env;
    fprintf(stderr, "[%s] (status %d): %s\n", category ? category : "", (int)status,
            message ? message : "");
}

static int load_api(library_t lib, void *functions) {
    fmi3_api *api = functions;
    int ok = 1;
    LOAD(instantiate, "fmi3InstantiateCoSimulation");
    LOAD(free_instance, "fmi3FreeInstance");
    LOAD(enter_initialization, "fmi3EnterInitializationMode");
    LOAD(exit_initialization, "fmi3ExitInitializationMode");
    LOAD(terminate, "fmi3Terminate");
    LOAD(set_float64, "fmi3SetFloat64");
    LOAD(set_int32, "fmi3SetInt32");
    LOAD(set_int64, "fmi3SetInt64");
    LOAD(get_float64, "fmi3GetFloat64");
    LOAD(do_step, "fmi3DoStep");
    return ok;
}

static int print_values(const fmi3_api *api, fmi3Instance c, double t, const arguments *a) {
    fmi3Float64 values[MAX_VALUES];
    if (api->get_float64(c, a->vrs, (size_t)a->n, values, (size_t)a->n) > fmi3Warning) {
        fprintf(stderr, "fmu3_driver: fmi3GetFloat64 failed at t = %.17g\n", t);
        return 0;
    }
    print_row(t, values, a->n);
    return 1;
}

static int apply_settings(const fmi3_api *api, fmi3Instance c, const arguments *a) {
    int i;
    for (i = 0; i < a->n_settings; i++) {
        const setting *s = &a->settings[i];
        if (s->kind == 'r') {
            CALL("fmi3SetFloat64", api->set_float64(c, &s->vr, 1, &s->real, 1));
        } else if (s->kind == 'i') {
            fmi3Int32 v = (fmi3Int32)s->integer;
            CALL("fmi3SetInt32", api->set_int32(c, &s->vr, 1, &v, 1));
        } else {
            fmi3Int64 v = (fmi3Int64)s->integer;
            CALL("fmi3SetInt64", api->set_int64(c, &s->vr, 1, &v, 1));
        }
    }
    return 0;
}

/* the run on an instantiated FMU: settings, initialization, steps; 0 or 1 (exit status) */
static int simulate(const fmi3_api *api, fmi3Instance c, const arguments *a) {
    long steps = step_count(a), k;
    if (apply_settings(api, c, a) != 0) {
        return 1;
    }
    CALL("fmi3EnterInitializationMode",
         api->enter_initialization(c, a->tol > 0 ? fmi3True : fmi3False, a->tol, a->start,
                                   fmi3True, a->stop));
    CALL("fmi3ExitInitializationMode", api->exit_initialization(c));
    if (!print_values(api, c, a->start, a)) {
        return 1;
    }
    for (k = 1; k <= steps; k++) {
        double t = point(a, k - 1), next = point(a, k);
        fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
        fmi3Float64 last = t;
        do { /* an early return without termination: on from where the FMU stopped */
            fmi3Status status = api->do_step(c, last, next - last, fmi3True, &event, &terminate,
                                             &early, &last);
            if (status > fmi3Warning) {
                fprintf(stderr, "fmu3_driver: fmi3DoStep from t = %.17g returned %d\n", last,
                        (int)status);
                return 1;
            }
        } while (early && !terminate && last < next);
        if (terminate) {
            printf("# terminate early=%d time=%.17g\n", early ? 1 : 0, last);
            if (!print_values(api, c, last, a)) {
                return 1;
            }
            break;
        }
        if (!print_values(api, c, next, a)) {
            return 1;
        }
    }
    CALL("fmi3Terminate", api->terminate(c));
    return 0;
}

int main(int argc, char **argv) {
    arguments a;
    int rc;
    fmi3_api api = {0}; /* loaded by start */
    library_t lib;
    fmi3Instance c;

    rc = start(argc, argv, "ie", &a, load_api, &api, &lib);
    if (rc >= 0) {
        return rc;
    }
    c = api.instantiate("driver", a.token, a.resources, fmi3False, fmi3False, fmi3False, fmi3True,
                        NULL, 0, NULL, logger, NULL);
    if (c == NULL) {
        fprintf(stderr, "fmu3_driver: fmi3InstantiateCoSimulation failed\n");
        close_library(lib);
        return 1;
    }
    rc = simulate(&api, c, &a);
    api.free_instance(c);
    close_library(lib);
    fflush(stdout);
    return rc;
}
