/* A plain C DOP853 around the minimal hand-written right-hand side (benchmarks/minimal_wheel.h):
 * the work-precision benchmark's peer "what a user could write by hand" (docs/performance.md,
 * docs/accuracy.md).  Hairer's dop853.f step and controller (SAFE = 0.9, FAC1 = 0.333,
 * FAC2 = 6: h_new / h in [1/3, 6], BETA = 0; Hairer's initial step), the same tableau as the
 * runtime (c_src/gw_dop853_tableau.h), no events, no dense output.  Built as a shared library
 * for benchmarks/work_precision.py by benchmarks/peers.py (PlainDop853), as, from the top of the
 * repository,
 *   cc -std=c99 -O2 -fno-math-errno -shared -fPIC -I c_src benchmarks/plain_dop853.c
 *      -o plain_dop853.so -lm
 * Error norm: RMS of err_i / (atol + rtol max(|x_i|, |xnew_i|)) (Hairer's ITOL = 0). */
#include <math.h>

#include "gw_dop853_tableau.h"
#include "minimal_wheel.h"

#define N 8

int plain_dop853(const double *p, double *x, double t0, double t_end, double rtol, double atol,
                 long *stats);

static double norm_rms(const double *v, const double *sk) {
    double s = 0.0;
    int i;
    for (i = 0; i < N; i++) s += (v[i] / sk[i]) * (v[i] / sk[i]);
    return sqrt(s / N);
}

/* stats: accepted, rejected, right-hand side evaluations.  0 on success. */
int plain_dop853(const double *p, double *x, double t0, double t_end, double rtol, double atol,
                 long *stats) {
    minimal_wheel w;
    double K[13][N], xt[N], xn[N], sk[N], t = t0, h, hmax = t_end - t0;
    int i, j, s, reject = 0;
    long nacc = 0, nrej = 0, nfev = 0;
    minimal_wheel_init(&w, p);
    minimal_wheel_rhs(&w, x, K[0]);
    nfev++;
    { /* Hairer's initial step (order 8) */
        double dnf, dny, der2, der12, h1;
        for (i = 0; i < N; i++) sk[i] = atol + rtol * fabs(x[i]);
        dnf = norm_rms(K[0], sk);
        dny = norm_rms(x, sk);
        h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : 0.01 * dny / dnf;
        if (h > hmax) h = hmax;
        for (i = 0; i < N; i++) xt[i] = x[i] + h * K[0][i];
        minimal_wheel_rhs(&w, xt, K[1]);
        nfev++;
        for (i = 0; i < N; i++) xt[i] = K[1][i] - K[0][i];
        der2 = norm_rms(xt, sk) / h;
        der12 = der2 > dnf ? der2 : dnf;
        h1 = der12 <= 1e-15 ? (h * 1e-3 > 1e-6 ? h * 1e-3 : 1e-6) : pow(0.01 / der12, 1.0 / 8.0);
        h = 100.0 * h < h1 ? 100.0 * h : h1;
        if (h > hmax) h = hmax;
    }
    while (t < t_end) {
        double err5 = 0.0, err3 = 0.0, deno, err, fac;
        int last = 0;
        if (t + 1.01 * h >= t_end) {
            h = t_end - t;
            last = 1;
        }
        for (s = 1; s < 12; s++) {
            for (i = 0; i < N; i++) {
                double acc = 0.0;
                for (j = 0; j < s; j++) acc += dop_a[s][j] * K[j][i];
                xt[i] = x[i] + h * acc;
            }
            minimal_wheel_rhs(&w, xt, K[s]);
        }
        nfev += 11;
        for (i = 0; i < N; i++) {
            double incr = 0.0, e5 = 0.0, e3, ski;
            for (j = 0; j < 12; j++) {
                incr += dop_b[j] * K[j][i];
                e5 += dop_e5[j] * K[j][i];
            }
            xn[i] = x[i] + h * incr;
            e3 = incr - dop_bhh0 * K[0][i] - dop_bhh8 * K[8][i] - dop_bhh11 * K[11][i];
            ski = atol + rtol * (fabs(x[i]) > fabs(xn[i]) ? fabs(x[i]) : fabs(xn[i]));
            err5 += (e5 / ski) * (e5 / ski);
            err3 += (e3 / ski) * (e3 / ski);
        }
        deno = err5 + 0.01 * err3;
        if (deno <= 0.0) deno = 1.0;
        err = fabs(h) * err5 * sqrt(1.0 / (N * deno));
        fac = pow(err, 0.125) / 0.9; /* Hairer: FAC11 / SAFE, h_new = h / fac */
        if (fac < 1.0 / 6.0) fac = 1.0 / 6.0;
        if (fac > 1.0 / 0.333) fac = 1.0 / 0.333;
        if (err <= 1.0) {
            nacc++;
            for (i = 0; i < N; i++) x[i] = xn[i];
            t = last ? t_end : t + h;
            minimal_wheel_rhs(&w, x, K[0]);
            nfev++;
            if (reject && fac < 1.0) fac = 1.0;
            h = h / fac;
            if (h > hmax) h = hmax;
            reject = 0;
        } else {
            nrej++;
            h = h / fac; /* err > 1: fac > 1/0.9 */
            reject = 1;
        }
        if (!(h > 1e-14 * (fabs(t) > 1.0 ? fabs(t) : 1.0))) return 1;
    }
    stats[0] = nacc;
    stats[1] = nrej;
    stats[2] = nfev;
    return 0;
}
