/*
 * driver.h -- what the platform drivers (fmu_driver.c for FMI 2.0, fmu3_driver.c for FMI 3.0)
 * share: loading the FMU's shared library (dlopen/dlsym on POSIX, LoadLibraryW/GetProcAddress
 * on Windows), their command line and their output.  Each driver defines driver_vr (its FMI
 * version's value reference type), DRIVER_NAME and DRIVER_WARNING (its fmi<N>Warning) before
 * including it.
 *
 *   DRIVER LIBRARY TOKEN RESOURCES START STOP STEP TOL VR[,VR...] [SETTING...]
 *   DRIVER --cpu
 *
 * SETTING is KIND:VR=VALUE, KIND one of the driver's kinds: r (a real) or an integer kind.
 * Output (stdout), every number with %.17g (enough digits to give back the double): one line
 * TIME VALUE... per communication point.
 */
#ifndef DRIVER_H
#define DRIVER_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
    char kind; /* 'r' or one of the driver's integer kinds */
    driver_vr vr;
    double real;
    long integer;
} setting;

typedef struct {
    const char *library, *token, *resources;
    double start, stop, step, tol;
    driver_vr vrs[MAX_VALUES];
    int n;
    setting settings[MAX_SETTINGS];
    int n_settings;
} arguments;

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
        fprintf(stderr, DRIVER_NAME ": the library lacks %s\n", name);
        return 0;
    }
    memcpy(slot, &f, size);
    return 1;
}

#define LOAD(field, name) ok = symbol(lib, name, &api->field, sizeof api->field) && ok

/* the library at `path` with its functions stored into *api by `load`; NULL after saying why */
static library_t open_fmu(const char *path, int (*load)(library_t, void *), void *api) {
    library_t lib = open_library(path);
    if (lib == NULL) {
        fprintf(stderr, DRIVER_NAME ": cannot load %s\n", path);
        return NULL;
    }
    if (!load(lib, api)) {
        close_library(lib);
        return NULL;
    }
    return lib;
}

/* `call` (an FMI function's status), ending the calling function with 1 when it failed */
#define CALL(what, call)                                                                        \
    do {                                                                                        \
        if ((call) > DRIVER_WARNING) {                                                          \
            fprintf(stderr, DRIVER_NAME ": %s failed\n", what);                                 \
            return 1;                                                                           \
        }                                                                                       \
    } while (0)

static int parse_double(const char *text, double *out) {
    char *end;
    *out = strtod(text, &end);
    return end != text && *end == '\0';
}

static int parse_vr(const char *text, char stop, driver_vr *vr, const char **rest) {
    char *end;
    unsigned long v = strtoul(text, &end, 10);
    if (end == text || *end != stop || v > 0xFFFFFFFFul) {
        return 0;
    }
    *vr = (driver_vr)v;
    *rest = end + 1;
    return 1;
}

/* "VR,VR,..." -> vrs; the count, or -1 for bad text */
static int parse_vrs(const char *text, driver_vr *vrs) {
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

/* KIND:VR=VALUE with KIND 'r' or one of `integer_kinds` */
static int parse_setting(const char *text, const char *integer_kinds, setting *s) {
    const char *rest;
    char *end;
    if (text[0] == '\0' || (text[0] != 'r' && !strchr(integer_kinds, text[0])) || text[1] != ':') {
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

/* argv -> *a; 0, or 2 (the exit status) after saying what is wrong */
static int parse_arguments(int argc, char **argv, const char *integer_kinds, arguments *a) {
    int i;
    a->n_settings = argc - 9;
    if (argc < 9 || a->n_settings > MAX_SETTINGS) {
        fprintf(stderr, "usage: " DRIVER_NAME " LIBRARY TOKEN RESOURCES START STOP STEP TOL "
                        "VR[,VR...] [KIND:VR=VALUE ...], KIND r or one of %s\n", integer_kinds);
        return 2;
    }
    a->library = argv[1];
    a->token = argv[2];
    a->resources = argv[3];
    if (!parse_double(argv[4], &a->start) || !parse_double(argv[5], &a->stop) ||
        !parse_double(argv[6], &a->step) || !parse_double(argv[7], &a->tol) || !(a->step > 0) ||
        !(a->stop >= a->start)) {
        fprintf(stderr, DRIVER_NAME ": need numbers START, STOP >= START, STEP > 0 and TOL\n");
        return 2;
    }
    a->n = parse_vrs(argv[8], a->vrs);
    if (a->n < 1) {
        fprintf(stderr, DRIVER_NAME ": bad value references (at most %d): %s\n", MAX_VALUES, argv[8]);
        return 2;
    }
    for (i = 0; i < a->n_settings; i++) {
        if (!parse_setting(argv[9 + i], integer_kinds, &a->settings[i])) {
            fprintf(stderr, DRIVER_NAME ": bad setting (KIND:VR=VALUE, KIND r or one of %s): %s\n",
                    integer_kinds, argv[9 + i]);
            return 2;
        }
    }
    return 0;
}

static void print_row(double t, const double *values, int n) {
    int i;
    printf("%.17g", t);
    for (i = 0; i < n; i++) {
        printf(" %.17g", values[i]);
    }
    printf("\n");
}

/* the communication points of [start, stop] with step `step`: k = 0 .. steps */
static long step_count(const arguments *a) {
    return (long)((a->stop - a->start) / a->step + 0.5);
}

static double point(const arguments *a, long k) {
    return k == step_count(a) ? a->stop : a->start + (double)k * a->step;
}

/* --cpu: prints "avx2=0|1 fma=0|1", what __builtin_cpu_supports (the compiler's runtime, as
 * linked into this program) says of this CPU (x86 only) */
static int print_cpu(void) {
#if (defined(__GNUC__) || defined(__clang__)) && (defined(__x86_64__) || defined(__i386__))
    printf("avx2=%d fma=%d\n", __builtin_cpu_supports("avx2") != 0,
           __builtin_cpu_supports("fma") != 0);
    return 0;
#else
    fprintf(stderr, DRIVER_NAME ": --cpu answers on x86 only\n");
    return 2;
#endif
}

/* main's start: --cpu answered, the arguments parsed into *a, the FMU's library opened into
 * *lib with its functions loaded by `load` into *api; -1 to go on, else main's exit status */
static int start(int argc, char **argv, const char *integer_kinds, arguments *a,
                 int (*load)(library_t, void *), void *api, library_t *lib) {
    int rc;
    if (argc == 2 && strcmp(argv[1], "--cpu") == 0) {
        return print_cpu();
    }
    rc = parse_arguments(argc, argv, integer_kinds, a);
    if (rc != 0) {
        return rc;
    }
    *lib = open_fmu(a->library, load, api);
    return *lib == NULL ? 2 : -1;
}

#endif /* DRIVER_H */
