/*
 * fmu_driver.c -- a minimal FMI 2.0 Co-Simulation master in C99: loads the shared library of
 * an unpacked FMU (dlopen/dlsym on POSIX, LoadLibraryW/GetProcAddress on Windows), runs it as
 * an importer does and prints the values asked for at every communication point.  Built for
 * each platform the tests run an FMU's binary on (natively, under qemu-user, under Wine).
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
 *   fmu_driver --cpu   prints "avx2=0|1 fma=0|1": what __builtin_cpu_supports (the compiler's
 *                      runtime, as linked into this program) says of this CPU (x86 only)
 * Sources: FMI 2.0.4, sections 2.1.5 (instantiation), 4.2 (Co-Simulation: fmi2DoStep,
 * fmi2GetBooleanStatus(fmi2Terminated), fmi2GetRealStatus(fmi2LastSuccessfulTime)).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2FunctionTypes.h"

#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
typedef HMODULE library_t;
#else
#include <dlfcn.h>
typedef void *library_t;
#endif

#define MAX_VALUES 64
#define MAX_SETTINGS 64

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

typedef struct {
    char kind; /* 'r' or 'i' */
    fmi2ValueReference vr;
    double real;
    long integer;
} setting;

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

static library_t open_library(const char *path) {
#ifdef _WIN32
    wchar_t wide[4096];
    if (MultiByteToWideChar(CP_ACP, 0, path, -1, wide, (int)(sizeof wide / sizeof wide[0])) == 0) {
        return NULL;
    }
    return LoadLibraryW(wide);
#else
    return dlopen(path, RTLD_NOW | RTLD_LOCAL);
#endif
}

static void close_library(library_t lib) {
#ifdef _WIN32
    FreeLibrary(lib);
#else
    dlclose(lib);
#endif
}

/* the function `name` of `lib` stored into *slot (a function pointer of any type); memcpy, as
 * ISO C has no conversion between object and function pointers */
static int symbol(library_t lib, const char *name, void *slot, size_t size) {
#ifdef _WIN32
    FARPROC f = GetProcAddress(lib, name);
#else
    void *f = dlsym(lib, name);
#endif
    if (f == NULL || size != sizeof f) {
        fprintf(stderr, "fmu_driver: the library lacks %s\n", name);
        return 0;
    }
    memcpy(slot, &f, size);
    return 1;
}

#define LOAD(field, name) ok = symbol(lib, name, &api->field, sizeof api->field) && ok

static int load_api(library_t lib, fmi2_api *api) {
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

static int parse_double(const char *text, double *out) {
    char *end;
    *out = strtod(text, &end);
    return end != text && *end == '\0';
}

static int parse_vr(const char *text, char stop, fmi2ValueReference *vr, const char **rest) {
    char *end;
    unsigned long v = strtoul(text, &end, 10);
    if (end == text || *end != stop || v > 0xFFFFFFFFul) {
        return 0;
    }
    *vr = (fmi2ValueReference)v;
    *rest = end + 1;
    return 1;
}

/* "VR,VR,..." -> vrs; the count, or -1 for bad text */
static int parse_vrs(const char *text, fmi2ValueReference *vrs) {
    int n = 0;
    while (n < MAX_VALUES) {
        const char *rest;
        const char *comma = strchr(text, ',');
        if (!parse_vr(text, comma ? ',' : '\0', &vrs[n], &rest)) {
            return -1;
        }
        n++;
        if (!comma) {
            return n;
        }
        text = rest;
    }
    return -1;
}

static int parse_setting(const char *text, setting *s) {
    const char *rest;
    char *end;
    if ((text[0] != 'r' && text[0] != 'i') || text[1] != ':') {
        return 0;
    }
    s->kind = text[0];
    if (!parse_vr(text + 2, '=', &s->vr, &rest)) {
        return 0;
    }
    if (s->kind == 'r') {
        return parse_double(rest, &s->real);
    }
    s->integer = strtol(rest, &end, 10);
    return end != rest && *end == '\0';
}

static int print_values(const fmi2_api *api, fmi2Component c, double t,
                        const fmi2ValueReference *vrs, int n) {
    fmi2Real values[MAX_VALUES];
    int i;
    if (api->get_real(c, vrs, (size_t)n, values) > fmi2Warning) {
        fprintf(stderr, "fmu_driver: fmi2GetReal failed at t = %.17g\n", t);
        return 0;
    }
    printf("%.17g", t);
    for (i = 0; i < n; i++) {
        printf(" %.17g", values[i]);
    }
    printf("\n");
    return 1;
}

#define CALL(what, call)                                                                        \
    do {                                                                                        \
        if ((call) > fmi2Warning) {                                                             \
            fprintf(stderr, "fmu_driver: %s failed\n", what);                                   \
            return 1;                                                                           \
        }                                                                                       \
    } while (0)

/* the run on an instantiated FMU: setup, settings, initialization, steps; 0 or 1 (exit status) */
static int simulate(const fmi2_api *api, fmi2Component c, const double *times, double tol,
                    const fmi2ValueReference *vrs, int n, const setting *settings, int n_settings) {
    double start = times[0], stop = times[1], step = times[2];
    long steps, k;
    int i;
    CALL("fmi2SetupExperiment", api->setup_experiment(c, tol > 0 ? fmi2True : fmi2False, tol,
                                                        start, fmi2True, stop));
    for (i = 0; i < n_settings; i++) {
        const setting *s = &settings[i];
        if (s->kind == 'r') {
            CALL("fmi2SetReal", api->set_real(c, &s->vr, 1, &s->real));
        } else {
            fmi2Integer v = (fmi2Integer)s->integer;
            CALL("fmi2SetInteger", api->set_integer(c, &s->vr, 1, &v));
        }
    }
    CALL("fmi2EnterInitializationMode", api->enter_initialization(c));
    CALL("fmi2ExitInitializationMode", api->exit_initialization(c));
    if (!print_values(api, c, start, vrs, n)) {
        return 1;
    }
    steps = (long)((stop - start) / step + 0.5);
    for (k = 1; k <= steps; k++) {
        double t = start + (double)(k - 1) * step;
        double next = k == steps ? stop : start + (double)k * step;
        fmi2Status status = api->do_step(c, t, next - t, fmi2True);
        if (status == fmi2Discard) {
            fmi2Boolean terminated = fmi2False;
            fmi2Real last = t;
            CALL("fmi2GetBooleanStatus", api->get_boolean_status(c, fmi2Terminated, &terminated));
            CALL("fmi2GetRealStatus", api->get_real_status(c, fmi2LastSuccessfulTime, &last));
            printf("# discard terminated=%d time=%.17g\n", terminated ? 1 : 0, last);
            if (!print_values(api, c, last, vrs, n)) {
                return 1;
            }
            break;
        }
        if (status > fmi2Warning) {
            fprintf(stderr, "fmu_driver: fmi2DoStep from t = %.17g returned %d\n", t, (int)status);
            return 1;
        }
        if (!print_values(api, c, next, vrs, n)) {
            return 1;
        }
    }
    CALL("fmi2Terminate", api->terminate(c));
    return 0;
}

static int print_cpu(void) {
#if (defined(__GNUC__) || defined(__clang__)) && (defined(__x86_64__) || defined(__i386__))
    printf("avx2=%d fma=%d\n", __builtin_cpu_supports("avx2") != 0,
           __builtin_cpu_supports("fma") != 0);
    return 0;
#else
    fprintf(stderr, "fmu_driver: --cpu answers on x86 only\n");
    return 2;
#endif
}

int main(int argc, char **argv) {
    fmi2ValueReference vrs[MAX_VALUES];
    setting settings[MAX_SETTINGS];
    double times[3], tol;
    int n, n_settings = argc - 9, i, rc;
    fmi2_api api;
    library_t lib;
    fmi2Component c;
    fmi2CallbackFunctions callbacks;
    callbacks.logger = logger;
    callbacks.allocateMemory = calloc;
    callbacks.freeMemory = free;
    callbacks.stepFinished = NULL;
    callbacks.componentEnvironment = NULL;

    if (argc == 2 && strcmp(argv[1], "--cpu") == 0) {
        return print_cpu();
    }
    if (argc < 9 || n_settings > MAX_SETTINGS) {
        fprintf(stderr, "usage: fmu_driver LIBRARY GUID RESOURCES_URI START STOP STEP TOL "
                        "VR[,VR...] [r:VR=VALUE|i:VR=VALUE ...]\n");
        return 2;
    }
    for (i = 0; i < 3; i++) {
        if (!parse_double(argv[4 + i], &times[i])) {
            fprintf(stderr, "fmu_driver: not a number: %s\n", argv[4 + i]);
            return 2;
        }
    }
    if (!(times[2] > 0) || !(times[1] >= times[0]) || !parse_double(argv[7], &tol)) {
        fprintf(stderr, "fmu_driver: need STEP > 0, STOP >= START and a number TOL\n");
        return 2;
    }
    n = parse_vrs(argv[8], vrs);
    if (n < 1) {
        fprintf(stderr, "fmu_driver: bad value references (at most %d): %s\n", MAX_VALUES, argv[8]);
        return 2;
    }
    for (i = 0; i < n_settings; i++) {
        if (!parse_setting(argv[9 + i], &settings[i])) {
            fprintf(stderr, "fmu_driver: bad setting (r:VR=VALUE or i:VR=VALUE): %s\n", argv[9 + i]);
            return 2;
        }
    }
    lib = open_library(argv[1]);
    if (lib == NULL) {
        fprintf(stderr, "fmu_driver: cannot load %s\n", argv[1]);
        return 2;
    }
    if (!load_api(lib, &api)) {
        close_library(lib);
        return 2;
    }
    c = api.instantiate("driver", fmi2CoSimulation, argv[2], argv[3], &callbacks, fmi2False,
                        fmi2False);
    if (c == NULL) {
        fprintf(stderr, "fmu_driver: fmi2Instantiate failed\n");
        close_library(lib);
        return 1;
    }
    rc = simulate(&api, c, times, tol, vrs, n, settings, n_settings);
    api.free_instance(c);
    close_library(lib);
    fflush(stdout);
    return rc;
}
