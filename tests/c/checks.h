/*
 * checks.h -- the check macros of the C tests, free of any FMI type: counters, CHECK,
 * CHECK_NEAR.  harness.h (the importer's view) builds on it; test_core.c uses it alone.
 */
#ifndef GW_TEST_CHECKS_H
#define GW_TEST_CHECKS_H

#include <math.h>
#include <stdio.h>

static int h_failures = 0, h_checks = 0;

#define CHECK(cond)                                                                          \
    do {                                                                                     \
        h_checks++;                                                                          \
        if (!(cond)) {                                                                       \
            h_failures++;                                                                    \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);        \
        }                                                                                    \
    } while (0)
#define CHECK_NEAR(a, b, tol)                                                                \
    do {                                                                                     \
        double a_ = (a), b_ = (b);                                                           \
        h_checks++;                                                                          \
        if (!(fabs(a_ - b_) <= (tol))) {                                                     \
            h_failures++;                                                                    \
            fprintf(stderr, "%s:%d: %s = %.17g, expected %.17g (tol %g, diff %g)\n",        \
                    __FILE__, __LINE__, #a, a_, b_, (double)(tol), fabs(a_ - b_));           \
        }                                                                                    \
    } while (0)

#endif
