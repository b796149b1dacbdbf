/* fm_check.h -- what the math tests share (tests/c/test_fastmath.c, test_fastexp.c): the
 * counters of checks and failures, check(), and a fixed, portable sequence of uniform doubles
 * in [0, 1) (xorshift64*).  Included once per test program. */
#ifndef FM_CHECK_H
#define FM_CHECK_H

#include <stdio.h>

static int n_checks, n_failures;

static unsigned long long rng_state = 0x9E3779B97F4A7C15ULL;
static double uniform01(void) {
    rng_state ^= rng_state >> 12;
    rng_state ^= rng_state << 25;
    rng_state ^= rng_state >> 27;
    return (double)((rng_state * 0x2545F4914F6CDD1DULL) >> 11) * 0x1.0p-53;
}

static void check(int ok, const char *what, double x) {
    n_checks++;
    if (!ok) {
        n_failures++;
        fprintf(stderr, "%s (x=%.17g)\n", what, x);
    }
}

#endif /* FM_CHECK_H */
