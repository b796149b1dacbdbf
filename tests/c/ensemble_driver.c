/*
 * ensemble_driver.c -- one job of a model's ensemble library through its C entry point
 * (<id>_ensemble_run, c_src/gw_ensemble_lib.c), its results printed: a program that runs where
 * Python cannot load the library (another machine type under qemu-user).
 *
 * One translation unit: ENSEMBLE_UNITY names the library's unity file (what
 * gyrowheel.taylor.ensemble.library_source writes), included first, so the driver calls the
 * library's functions with their own types.  Build, e.g. for 64-bit ARM:
 *
 *   zig cc -target aarch64-linux-gnu -std=c99 -O3 -ffp-contract=fast -I<FMU sources/>
 *       -DENSEMBLE_UNITY='"paper_earth_ensemble.c"' ensemble_driver.c -lm
 *
 * Usage: driver T_END REL_TOL NAME V1 V2 ...: one trajectory per value Vk of the start value
 * NAME, the rest the model's defaults, from 0 to T_END [s].  Prints one line per trajectory,
 * "status t_final x_final[0] ... x_final[nx-1] steps", the numbers with 17 significant digits
 * (a double read back exactly); abs_tol and max_step are Ensemble.run's defaults.  Exit 0 if
 * the run was made (a trajectory's own failure is its status), 1 if not, 2 for bad arguments.
 */
#include ENSEMBLE_UNITY

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DRIVER_KIND_START 1 /* gw_kind of a start value (gyrowheel.taylor.ensemble.KIND_START) */

int main(int argc, char **argv) {
    int sizes[8], nx, np, ns, k, rc, start = -1;
    long n, j;
    double span[2], tol[3], *p, *s, *t_final, *x_final, *y_final;
    int *status;
    unsigned long *steps;
    if (argc < 5) {
        fprintf(stderr, "usage: %s T_END REL_TOL START_NAME V1 [V2 ...]\n", argv[0]);
        return 2;
    }
    GW_LIB(sizes)(sizes);
    nx = sizes[0], ns = sizes[1], np = sizes[3];
    for (k = 0; k < ns; k++) {
        const char *name = GW_LIB(name)(DRIVER_KIND_START, k);
        if (name && strcmp(name, argv[3]) == 0) start = k;
    }
    if (start < 0) {
        fprintf(stderr, "%s: no start value named %s\n", argv[0], argv[3]);
        return 2;
    }
    n = argc - 4;
    span[0] = 0.0, span[1] = strtod(argv[1], NULL);
    /* abs_tol and max_step as Ensemble.run's defaults: rel_tol 1e-2, the span */
    tol[0] = strtod(argv[2], NULL), tol[1] = tol[0] * 1e-2, tol[2] = span[1] - span[0];
    p = calloc((size_t)(n * (np > 0 ? np : 1)), sizeof *p);
    s = calloc((size_t)(n * (ns > 0 ? ns : 1)), sizeof *s);
    t_final = calloc((size_t)n, sizeof *t_final);
    x_final = calloc((size_t)(n * nx), sizeof *x_final);
    y_final = calloc((size_t)(n * (sizes[4] > 0 ? sizes[4] : 1)), sizeof *y_final);
    status = calloc((size_t)n, sizeof *status);
    steps = calloc((size_t)n, sizeof *steps);
    if (!p || !s || !t_final || !x_final || !y_final || !status || !steps) {
        fprintf(stderr, "%s: out of memory\n", argv[0]);
        return 2;
    }
    for (j = 0; j < n; j++) {
        GW_LIB(defaults)(p + j * np, s + j * ns);
        s[j * ns + start] = strtod(argv[4 + j], NULL);
    }
    rc = GW_LIB(run)(NULL, n, p, s, span, tol, status, t_final, x_final, y_final, steps, NULL, 0, NULL,
                     NULL, NULL, NULL);
    for (j = 0; j < n; j++) {
        printf("%d %.17g", status[j], t_final[j]);
        for (k = 0; k < nx; k++) printf(" %.17g", x_final[j * nx + k]);
        printf(" %lu\n", steps[j]);
    }
    free(p), free(s), free(t_final), free(x_final), free(y_final), free(status), free(steps);
    return rc == GW_FATAL ? 1 : 0; /* nothing was run (no memory) */
}
