/* Times one evaluation of the generated right-hand side gw_ode (ns per call) and, in the same
 * run, the minimal hand-written closed form of the base wheel (rhs_minimal.c, minimal_wheel.h)
 * at the same states, with libm's sin/cos and with the runtime's gw_sincos2 (the generated code's):
 * prints "<generated ns> <minimal ns> <minimal with gw_sincos2 ns>" (minimal: "nan" when the
 * model is not the base wheel: nx != 8 or np != 6).  Built by benchmarks/paper_cost.py, effect_costs.py
 * and work_precision.py against a scene's generated sources, with benchmarks/rhs_model.c and
 * rhs_minimal.c (each in a translation unit of its own, called through pointers). */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "gw_model.h"

const gw_model *rhs_bench_model(void);
void rhs_minimal(const void *w, const double *x, double *xdot);
void rhs_minimal_fast(const void *w, const double *x, double *xdot);
void rhs_minimal_init(void *w, const double *p);
unsigned long rhs_minimal_size(void);

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts); /* CPU time: preemption by other jobs does not count */
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(int argc, char **argv) {
    const gw_model *m = rhs_bench_model();
    long n = argc > 1 ? atol(argv[1]) : 2000000L;
    gw_int sz_arg, sz_res, sz_iw, sz_w;
    double x0[64], xdot[64], pre[64], t = 0.0, acc = 0.0, t0, best = 1e30;
    const double *arg[16];
    double *res[16];
    gw_int *iw;
    double *w;
    int rep;
    if (m->nx > 64) return 2;
    m->ode.work(&sz_arg, &sz_res, &sz_iw, &sz_w);
    iw = calloc((size_t)sz_iw + 1, sizeof *iw);
    w = calloc((size_t)sz_w + 1, sizeof *w);
    { /* x0 = init(s_start, p_start) */
        gw_int a, r, i2, w2;
        gw_int *iw0; double *w0;
        m->init.work(&a, &r, &i2, &w2);
        iw0 = calloc((size_t)i2 + 1, sizeof *iw0); w0 = calloc((size_t)w2 + 1, sizeof *w0);
        arg[0] = m->s_start; arg[1] = m->p_start; res[0] = x0;
        m->init.eval(arg, res, iw0, w0, 0);
        free(iw0); free(w0);
    }
    arg[0] = &t; arg[1] = x0; arg[2] = m->u_start; arg[3] = m->p_start; res[0] = xdot;
    if (m->ode_pre.eval) { /* the parameter-only part, once (as the runtime does per parameter change) */
        gw_int a, r, i2, w2;
        gw_int *iwp; double *wp;
        const double *argp[4];
        double *resp[4];
        if (m->n_pre > 64) return 2;
        m->ode_pre.work(&a, &r, &i2, &w2);
        iwp = calloc((size_t)i2 + 1, sizeof *iwp); wp = calloc((size_t)w2 + 1, sizeof *wp);
        argp[0] = m->p_start; resp[0] = pre;
        m->ode_pre.eval(argp, resp, iwp, wp, 0);
        free(iwp); free(wp);
        arg[4] = pre;
    }
    for (rep = 0; rep < 5; rep++) {
        long i;
        t0 = now();
        for (i = 0; i < n; i++) {
            x0[m->nx - 1] += 1e-15; /* defeat hoisting */
            m->ode.eval(arg, res, iw, w, 0);
            acc += xdot[m->nx - 2];
        }
        t0 = (now() - t0) / (double)n * 1e9;
        if (t0 < best) best = t0;
    }
    if (m->nx == 8 && m->np == 6) { /* the base wheel: p = (M, R, k_diam, k_axial, beta_min, g) */
        const double pm[5] = {m->p_start[0], m->p_start[1], m->p_start[2], m->p_start[3], m->p_start[5]};
        double wbuf[64], best_min[2] = {1e30, 1e30}, x1[64], xdot_min[8];
        void (*volatile rhs[2])(const void *, const double *, double *) = {rhs_minimal, rhs_minimal_fast};
        int v;
        if (rhs_minimal_size() > sizeof wbuf) return 3;
        rhs_minimal_init(wbuf, pm);
        for (rep = 0; rep < 8; rep++) x1[rep] = x0[rep];
        for (rep = 0; rep < 10; rep++) { /* interleaved: libm, gw_sincos2, libm, ... */
            long i;
            v = rep % 2;
            t0 = now();
            for (i = 0; i < n; i++) {
                x1[7] += 1e-15;
                rhs[v](wbuf, x1, xdot_min);
                acc += xdot_min[6];
            }
            t0 = (now() - t0) / (double)n * 1e9;
            if (t0 < best_min[v]) best_min[v] = t0;
        }
        printf("%.2f %.2f %.2f\n", best, best_min[0], best_min[1]);
    } else {
        printf("%.2f nan nan\n", best);
    }
    fprintf(stderr, "checksum %g\n", acc);
    free(iw); free(w);
    return 0;
}
