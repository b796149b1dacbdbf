/*
 * test_ens_passes.c -- the ensemble's step size passes (c_src/gw_ensemble_passes.h) on made-up
 * series of 4 lanes, against the one-lane formulas of solver taylor (gw_taylor_step and
 * gw_taylor_step_size, written out here operation by operation):
 *   gw_ens_norms       N_{p-1}, N_p of every lane bit for bit (a NaN coefficient sticks as the
 *                      norm), and d1 = 0 exactly where every order-0 and order-1 coefficient of
 *                      the lane is finite (NaN where one is inf or NaN)
 *                      and every lane's step size bit for bit gw_fm_step's (the 4-lane gw_fm_step4
 *                      against the scalar form), zero norms (no bound from that order) included,
 *                      and within 6e-6 of the exact rule computed with libm's log and exp
 *   gw_ens_defects     every lane's defect bit for bit as gw_taylor_defect's (0 where every
 *                      component's num <= den, without a division; else the
 *                      largest r_i, HUGE_VAL when one is NaN or infinite), a NaN r_i before a
 *                      finite one included (the pass kept the later finite r: a step accepted
 *                      that solver taylor rejects and retries shorter)
 * Run by tests/test_ensemble.py (gcc and clang).
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "gw_solver_taylor_step.h"

#define GW_ENSEMBLE_LANES 4
#include "gw_ensemble_passes.h"

enum { W = 4, NX = 5, ORDER = 9 };

static int failures;

static void expect(int ok, const char *what, int lane) {
    if (!ok) {
        failures++;
        fprintf(stderr, "%s (lane %d)\n", what, lane);
    }
}

static int same(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }

/* the increments and updates are tested through the library (tests/test_ensemble_runs.py) */
void (*const unused_passes[])(void) = {(void (*)(void))gw_ens_increments,
                                       (void (*)(void))gw_ens_sum_updates};

int main(void) {
    static double w[NX * (ORDER + 1) * W], fsn[NX * W], dp[NX * W], x[NX * W], anom[NX * W];
    double scale[W], err[W];
    const double rtol = 1e-9;
    double n1[W], n2[W], d1[W], h[W], lc[W], worst = 0.0;
    int n_zero = 0, n_sub = 0, n_quick = 0, n_big = 0;
    const double r1 = 1.0 / (ORDER - 1), r2 = 1.0 / ORDER;
    int i, k, l, round;
    for (round = 0; round < 200; round++) {
        for (i = 0; i < NX; i++)
            for (l = 0; l < W; l++) {
                fsn[i * W + l] = 1e-3 * (1 + l) * (1 + i);
                for (k = 0; k <= ORDER; k++) /* coefficients spread over many decades */
                    w[(i * (ORDER + 1) + k) * W + l] =
                        sin(1.0 + round * 0.37 + i * 1.3 + k * 0.71 + l * 2.9) *
                        pow(10.0, -((round * 7 + k * 3 + l) % 40) + 5.0);
            }
        if (round % 5 == 1) /* lane 1: orders p-1 and p zero (no bound from them) */
            for (i = 0; i < NX; i++) w[(i * (ORDER + 1) + ORDER - 1) * W + 1] = w[(i * (ORDER + 1) + ORDER) * W + 1] = 0.0;
        if (round % 5 == 3) /* lane 3: orders p-1 and p subnormal (the norms too) */
            for (i = 0; i < NX; i++) w[(i * (ORDER + 1) + ORDER - 1) * W + 3] = w[(i * (ORDER + 1) + ORDER) * W + 3] = 3e-318 * (i + 1);
        if (round % 7 == 5 && round % 6 != 2) /* lane 0: a state (order 0) not finite */
            w[(3 * (ORDER + 1) + 0) * W + 0] = round % 2 ? INFINITY : NAN;
        if (round % 3 == 0) w[(2 * (ORDER + 1) + 1) * W + 2] = round % 2 ? INFINITY : -INFINITY;
        if (round % 4 == 0) w[(4 * (ORDER + 1) + 1) * W + 3] = NAN;
        if (round % 6 == 2) /* a NaN coefficient of order p-1 (lane 0) or p (lane 2) before finite ones */
            w[(1 * (ORDER + 1) + ORDER - 1) * W + 0] = w[(0 * (ORDER + 1) + ORDER) * W + 2] = NAN;
        for (l = 0; l < W; l++) lc[l] = -2.5 - 0.1 * l;
        gw_ens_norms(w, (ORDER + 1) * W, W, fsn, NX, ORDER, lc, n1, n2, d1, h);
        for (l = 0; l < W; l++) {
            double m1 = 0.0, m2 = 0.0;
            int finite = 1;
            for (i = 0; i < NX; i++) { /* gw_taylor_step */
                const double *xi = w + (size_t)i * (ORDER + 1) * W + l;
                const double rsc = 1.0 / (fabs(xi[0]) + fsn[i * W + l]);
                const double a = fabs(xi[(ORDER - 1) * W]) * rsc, b = fabs(xi[ORDER * W]) * rsc;
                m1 = a > m1 || a != a ? a : m1;
                m2 = b > m2 || b != b ? b : m2;
                finite &= isfinite(xi[0]) && isfinite(xi[W]);
            }
            expect(same(n1[l], m1) && same(n2[l], m2), "norms differ from gw_taylor_step's", l);
            if (round % 6 == 2 && (l == 0 || l == 2)) /* the NaN is the norm, not a later finite value */
                expect(l == 0 ? isnan(n1[l]) && !isnan(n2[l]) : isnan(n2[l]) && !isnan(n1[l]),
                       "a NaN coefficient did not stick as the norm", l);
            expect(finite ? d1[l] == 0.0 : isnan(d1[l]), "orders 0, 1 finiteness flag wrong", l);
        }
        for (l = 0; l < W; l++) { /* gw_taylor_step_size, and the exact rule in libm */
            const double l1 = n1[l] > 0.0 ? -log(n1[l]) * r1 : HUGE_VAL,
                         l2 = n2[l] > 0.0 ? -log(n2[l]) * r2 : HUGE_VAL;
            const double exact = exp((l2 < l1 ? l2 : l1) + lc[l] * log(2.0));
            expect(same(h[l], gw_fm_step(n1[l], n2[l], r1, r2, lc[l])),
                   "step size differs from gw_taylor_step_size's", l);
            if (isfinite(n1[l]) && isfinite(n2[l])) {
                const double rel = isinf(exact) ? (isinf(h[l]) ? 0.0 : 1.0) : fabs(h[l] / exact - 1.0);
                worst = rel > worst ? rel : worst;
                n_zero += n1[l] == 0.0 && n2[l] == 0.0;
                n_sub += n1[l] > 0.0 && n1[l] < DBL_MIN;
            }
        }
        for (l = 0; l < W; l++) { /* an attempt's P'(h), xnew and weights near f(t1, P(h)) */
            /* lane 3 every other round: a defect above 1 (the pass's quotients beside lanes
             * whose defect is 0 without them) */
            scale[l] = (l == 3 && round % 2 ? 1e9 : 1e-3) * (1 + l) / (ORDER + 1);
            for (i = 0; i < NX; i++) {
                const double f1 = w[(i * (ORDER + 1) + 1) * W + l];
                dp[i * W + l] = f1 * (1.0 + 1e-9 * sin(round + i + 3.0 * l));
                x[i * W + l] = cos(round * 0.3 + i + l);
                anom[i * W + l] = 1e-11 * (1 + i);
            }
        }
        /* a NaN r in one component before finite ones: xnew NaN (lane 0), P'(h) NaN (lane 1),
         * inf / inf (lane 2: xnew and the difference infinite); lane 3 as made above */
        x[1 * W + 0] = NAN;
        dp[0 * W + 1] = round % 2 ? NAN : dp[0 * W + 1];
        x[2 * W + 2] = INFINITY;
        dp[2 * W + 2] = round % 3 ? -INFINITY : dp[2 * W + 2];
        gw_ens_defects(w, (ORDER + 1) * W, W, dp, x, anom, NX, rtol, scale, err);
        for (l = 0; l < W; l++) { /* gw_taylor_defect's two loops over the components */
            double e = 0.0;
            for (i = 0; i < NX; i++) { /* the usual case first: every num <= den, defect 0 */
                const double num = fabs(w[(i * (ORDER + 1) + 1) * W + l] - dp[i * W + l]) * scale[l],
                             den = rtol * fabs(x[i * W + l]) + anom[i * W + l];
                if (!(num <= den && den > 0.0 && den < HUGE_VAL)) break;
            }
            n_quick += i == NX;
            for (i = i == NX ? NX : 0; i < NX; i++) {
                const double r = fabs(w[(i * (ORDER + 1) + 1) * W + l] - dp[i * W + l]) * scale[l] /
                                 (rtol * fabs(x[i * W + l]) + anom[i * W + l]);
                if (!(r <= e)) {
                    e = r;
                    if (r != r) break;
                }
            }
            e = isfinite(e) ? e : HUGE_VAL;
            n_big += e > 1.0 && e < HUGE_VAL;
            expect(same(err[l], e), "defect differs from gw_taylor_defect's", l);
        }
    }
    /* the short log2 and 2^y against the exact rule (order 9 here; zero norms: h = inf;
     * subnormal norms scaled) */
    expect(n_quick > 0 && n_big > 0, "defects: both the quick case and a defect > 1 tested", -1);
    expect(worst > 0.0 && worst < 6e-6 && n_zero > 0 && n_sub > 0, "step size off the exact rule", -1);
    fprintf(stderr, "step size within %.3g of the exact rule\n", worst);
    { /* every order solver taylor uses, p = p0 + 4 in [7, 30] (gw_taylor_order, GW_TAYLOR_MAX_ORDER):
       * norms over the whole double range, subnormals and zeros among them (measured: 5.4e-6 at
       * order 7, 4.1e-6 at 30; orders 3..6, never used, reach 8.8e-6) */
        int p, k;
        double worst_p = 0.0;
        unsigned s = 12345u;
        for (p = 7; p <= 30; p++)
            for (k = 0; k < 20000; k++) {
                double a, b, y, exact, hh;
                s = s * 1103515245u + 12345u;
                a = k % 7 == 0 ? 0.0 : ldexp(1.0 + (s >> 8) / 16777216.0, (int)(s % 2098u) - 1074);
                s = s * 1103515245u + 12345u;
                b = k % 5 == 0 ? 4.9e-324 * (1 + s % 1000u) : ldexp(1.0 + (s >> 8) / 16777216.0, (int)(s % 2098u) - 1074);
                y = fmin(a > 0.0 ? -log2(a) / (p - 1) : HUGE_VAL, -log2(b) / p) - (s % 1000u) / 100.0;
                if (!(fabs(y) < 990.0)) continue;
                exact = exp2(y);
                hh = gw_fm_step(a, b, 1.0 / (p - 1), 1.0 / p, y - fmin(a > 0.0 ? -log2(a) / (p - 1) : HUGE_VAL, -log2(b) / p));
                worst_p = fmax(worst_p, fabs(hh / exact - 1.0));
            }
        expect(worst_p > 0.0 && worst_p < 6e-6, "step size off the exact rule at an order in 7..30", -1);
        fprintf(stderr, "orders 7..30: step size within %.3g of the exact rule\n", worst_p);
    }
    fprintf(stderr, "test_ens_passes: %d failures\n", failures);
    return failures != 0;
}
