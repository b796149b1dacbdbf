/*
 * fmu_driver.c -- a minimal FMI 2.0 Co-Simulation master in C99: loads the shared library of
 * an unpacked FMU, runs it as an importer does and prints the values asked for at every
 * communication point.  Built for each platform the tests run an FMU's binary on (natively,
 * under qemu-user, under Wine).  fmu3_driver.c is its FMI 3.0 counterpart; driver.h what
 * they share.
 *
 *   fmu_driver LIBRARY GUID RESOURCES_URI START STOP STEP TOL VR[,VR...] [SETTING...]
 *
 * LIBRARY        the FMU's binary (binaries/<platform>/<modelIdentifier>.<so|dll|dylib>)
 * GUID           the modelDescription's guid
 * RESOURCES_URI  the file: URI of the unpacked FMU's resources/ folder
 * START, STOP    the experiment's start and stop time (s); STEP the communication step (s);
 *                TOL the relative tolerance (fmi2SetupExperiment; 0: none given)
 * VR,...         value references of the Real variables printed at every communication point
 * SETTING        r:VR=VALUE (fmi2SetReal) or i:VR=VALUE (fmi2SetInteger, also enumerations),
 *                applied after instantiation, before initialization (start values, parameters)
 *
 * Output (stdout), every number with %.17g (enough digits to give back the double):
 *   one line per communication point:  TIME VALUE...
 *   when fmi2DoStep returns fmi2Discard (the FMU ended the run, e.g. at a terminating event):
 *                                      # discard terminated=0|1 time=LAST_SUCCESSFUL_TIME
 *   followed by the line of the values at that time; the run then ends normally.
 * The FMU's log messages go to stderr.  Exit status: 0 run to its end (or to the FMU's
 * termination), 1 an FMI call failed, 2 bad arguments or a library that does not load.
 *
 *   fmu_driver --cpu   prints "avx2=0|1 fma=0|1" (driver.h, print_cpu)
 * Sources: FMI 2.0.4, sections 2.1.5 (instantiation), 4.2 (Co-Simulation: fmi2DoStep,
 * fmi2GetBooleanStatus(fmi2Terminated), fmi2GetRealStatus(fmi2LastSuccessfulTime)).
 */
#include <stdarg.h>

#include "fmi2FunctionTypes.h"

typedef fmi2ValueReference driver_vr;
#define DRIVER_NAME "fmu_driver"
#define DRIVER_WARNING fmi2Warning
#include "driver.h"

typedef struct {
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *free_instance;
    fmi2SetupExperimentTYPE *setup_experiment;
    fmi2EnterInitializationModeTYPE *enter_initialization;
    fmi2ExitInitializationModeTYPE *exit_initialization;
    fmi2TerminateTYPE *terminate;
    fmi2SetRealTYPE *set_real;
    fmi2SetIntegerTYPE *set_integer;
    fmi2GetRealTYPE *get_real;
    fmi2DoStepTYPE *do_step;
    fmi2GetBooleanStatusTYPE *get_boolean_status;
    fmi2GetRealStatusTYPE *get_real_status;
} fmi2_api;

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    va_list args;
    (void)env;
    fprintf(stderr, "[%s] %s (status %d): ", category ? category : "", instance ? instance : "",
            (int)status);
    va_start(args, message);
    vfprintf(stderr, message, args);
    va_end(args);
    fputc('\n', stderr);
}

static int load_api(library_t lib, void *functions) {
    fmi2_api *api = functions;
    int ok = 1;
    LOAD(instantiate, "fmi2Instantiate");
    LOAD(free_instance, "fmi2FreeInstance");
    LOAD(setup_experiment, "fmi2SetupExperiment");
    LOAD(enter_initialization, "fmi2EnterInitializationMode");
    LOAD(exit_initialization, "fmi2ExitInitializationMode");
    LOAD(terminate, "fmi2Terminate");
    LOAD(set_real, "fmi2SetReal");
    LOAD(set_integer, "fmi2SetInteger");
    LOAD(get_real, "fmi2GetReal");
    LOAD(do_step, "fmi2DoStep");
    LOAD(get_boolean_status, "fmi2GetBooleanStatus");
    LOAD(get_real_status, "fmi2GetRealStatus");
    return ok;
}

static int print_values(const fmi2_api *api, fmi2Component c, double t, const arguments *a) {
    fmi2Real values[MAX_VALUES];
    if (api->get_real(c, a->vrs, (size_t)a->n, values) > fmi2Warning) {
        fprintf(stderr, "fmu_driver: fmi2GetReal failed at t = %.17g\n", t);
        return 0;
    }
    print_row(t, values, a->n);
    return 1;
}

/* the run on an instantiated FMU: setup, settings, initialization, steps; 0 or 1 (exit status) */
static int simulate(const fmi2_api *api, fmi2Component c, const arguments *a) {
    long steps = step_count(a), k;
    int i;
    CALL("fmi2SetupExperiment", api->setup_experiment(c, a->tol > 0 ? fmi2True : fmi2False, a->tol,
                                                        a->start, fmi2True, a->stop));
    for (i = 0; i < a->n_settings; i++) {
        const setting *s = &a->settings[i];
        if (s->kind == 'r') {
            CALL("fmi2SetReal", api->set_real(c, &s->vr, 1, &s->real));
        } else {
            fmi2Integer v = (fmi2Integer)s->integer;
            CALL("fmi2SetInteger", api->set_integer(c, &s->vr, 1, &v));
        }
    }
    CALL("fmi2EnterInitializationMode", api->enter_initialization(c));
    CALL("fmi2ExitInitializationMode", api->exit_initialization(c));
    if (!print_values(api, c, a->start, a)) {
        return 1;
    }
    for (k = 1; k <= steps; k++) {
        double t = point(a, k - 1), next = point(a, k);
        fmi2Status status = api->do_step(c, t, next - t, fmi2True);
        if (status == fmi2Discard) {
            fmi2Boolean terminated = fmi2False;
            fmi2Real last = t;
            CALL("fmi2GetBooleanStatus", api->get_boolean_status(c, fmi2Terminated, &terminated));
            CALL("fmi2GetRealStatus", api->get_real_status(c, fmi2LastSuccessfulTime, &last));
            printf("# discard terminated=%d time=%.17g\n", terminated ? 1 : 0, last);
            if (!print_values(api, c, last, a)) {
                return 1;
            }
            break;
        }
        if (status > fmi2Warning) {
            fprintf(stderr, "fmu_driver: fmi2DoStep from t = %.17g returned %d\n", t, (int)status);
            return 1;
        }
        if (!print_values(api, c, next, a)) {
            return 1;
        }
    }
    CALL("fmi2Terminate", api->terminate(c));
    return 0;
}

int main(int argc, char **argv) {
    arguments a;
    int rc;
    fmi2_api api = {0}; /* loaded by start */
    library_t lib;
    fmi2Component c;
    fmi2CallbackFunctions callbacks;
    callbacks.logger = logger;
    callbacks.allocateMemory = calloc;
    callbacks.freeMemory = free;
    callbacks.stepFinished = NULL;
    callbacks.componentEnvironment = NULL;

    rc = start(argc, argv, "i", &a, load_api, &api, &lib);
    if (rc >= 0) {
        return rc;
    }
    c = api.instantiate("driver", fmi2CoSimulation, a.token, a.resources, &callbacks, fmi2False,
                        fmi2False);
    if (c == NULL) {
        fprintf(stderr, "fmu_driver: fmi2Instantiate failed\n");
        close_library(lib);
        return 1;
    }
    rc = simulate(&api, c, &a);
    api.free_instance(c);
    close_library(lib);
    fflush(stdout);
    return rc;
}
