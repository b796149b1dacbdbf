/*
 * test_ens_increments.c -- the ensemble's increments pass (gw_ens_increments, c_src/
 * gw_ensemble_passes.h: dx = sum_k X_k h^k and P'(h) of every lane, lanes innermost) against
 * solver taylor's one-lane gw_taylor_increment, bit for bit, lane by lane, as compiled in the
 * ensemble library: appended to its unity file (gyrowheel.taylor.ensemble.library_source), with
 * its flags (-O3 -ffp-contract=fast; the x86-64-v3 clones fuse multiply-adds), so that the compiler's
 * contraction of each is what the library runs.  Random series of 13 components (blocks of 8
 * and the rest; the pass's chains of 4 and single ones), orders 7 .. 24, coefficients over 60
 * binades, step sizes 2^-6 .. 2^2, zero and negative-zero coefficients.  Run by
 * tests/test_ensemble.py::test_increments_pass_equals_the_one_lane_increment.
 * (Were the pass's dq started at q, GCC would share one product between two sums: dx apart in
 * 1.2% of the components, P'(h) in 20%, the inline lane-steps apart from
 * GW_ENSEMBLE_LANE_STEPS=1's.)
 */
#include <stdio.h>

static unsigned long long test_rs = 88172645463325252ULL;

static double test_uniform(void) {
    test_rs ^= test_rs << 13;
    test_rs ^= test_rs >> 7;
    test_rs ^= test_rs << 17;
    return (double)(test_rs >> 11) / 9007199254740992.0;
}

int main(void) {
    enum { W = GW_ENSEMBLE_LANES, NX = 13, PMAX = 24 };
    static double w[NX * (PMAX + 1) * W], X[NX * (PMAX + 1)], h[W], qx[NX * W], qd[NX * W], dx[NX],
        dp[NX];
    long n = 0, bad_dx = 0, bad_dp = 0;
    int it, i, k, l;
    for (it = 0; it < 60000; it++) {
        const int order = 7 + it % (PMAX - 6);
        for (i = 0; i < NX; i++)
            for (k = 0; k <= order; k++)
                for (l = 0; l < W; l++) {
                    double v = (test_uniform() - 0.5) * ldexp(1.0, -(int)(60.0 * test_uniform()));
                    if (it % 7 == 3 && k == order) v = (l & 1) ? -0.0 : 0.0;
                    w[(size_t)i * W + (size_t)k * NX * W + (size_t)l] = v;
                }
        for (l = 0; l < W; l++) h[l] = exp2(8.0 * test_uniform() - 6.0);
        gw_ens_increments(w, W, (size_t)NX * W, NX, order, h, qx, qd);
        for (l = 0; l < W; l++) {
            for (i = 0; i < NX; i++)
                for (k = 0; k <= order; k++)
                    X[i * (order + 1) + k] = w[(size_t)i * W + (size_t)k * NX * W + (size_t)l];
            gw_taylor_increment(X, order, 1, 0, NX, h[l], dx, dp);
            for (i = 0; i < NX; i++) {
                const int ex = memcmp(&dx[i], &qx[i * W + l], sizeof(double)) != 0,
                          ep = memcmp(&dp[i], &qd[i * W + l], sizeof(double)) != 0;
                n++;
                if ((ex || ep) && bad_dx + bad_dp < 5)
                    printf("order %d component %d lane %d h %a: dx %a / %a, P'(h) %a / %a\n", order, i, l,
                           h[l], dx[i], qx[i * W + l], dp[i], qd[i * W + l]);
                bad_dx += ex;
                bad_dp += ep;
            }
        }
    }
    printf("test_ens_increments: %ld components, dx differ %ld, P'(h) differ %ld\n", n, bad_dx, bad_dp);
    return bad_dx != 0 || bad_dp != 0;
}
