/*
 * solver_counts.h -- helpers for the solver tests (test_stiff.c, test_solvers_osc.c):
 * fmi2DoStep with the logSolver category on, and the counts of that log summed up.
 * The runtime logs per fmi2DoStep
 *   "fmi2DoStep ... accepted=A rejected=R rhs=F ..."
 * and, for the Rosenbrock solver, per communication step
 *   "rosenbrock ... jacobians=J (analytic|finite differences, rhs=FJ) lu=L".
 * Test code only (include after harness.h).
 */
#ifndef GW_TEST_SOLVER_COUNTS_H
#define GW_TEST_SOLVER_COUNTS_H

typedef struct {
    unsigned long long accepted, rejected, rhs, jac, jac_rhs, lu;
    int fd_jacobian, analytic_jacobian, dosteps;
} counts;

static void counts_add_log(counts *n) {
    const char *p = h_log;
    while ((p = strstr(p, "accepted=")) != NULL) {
        unsigned long long a = 0, r = 0, f = 0;
        if (sscanf(p, "accepted=%llu rejected=%llu rhs=%llu", &a, &r, &f) == 3) {
            n->accepted += a;
            n->rejected += r;
            n->rhs += f;
            n->dosteps++;
        }
        p++;
    }
    p = h_log;
    while ((p = strstr(p, "jacobians=")) != NULL) {
        unsigned long j = 0, fj = 0, l = 0;
        char kind[40] = "";
        if (sscanf(p, "jacobians=%lu (%39[^,], rhs=%lu) lu=%lu", &j, kind, &fj, &l) == 4) {
            n->jac += j;
            n->jac_rhs += fj;
            n->lu += l;
            if (strcmp(kind, "analytic") == 0) n->analytic_jacobian = 1;
            if (strcmp(kind, "finite differences") == 0) n->fd_jacobian = 1;
        }
        p++;
    }
}

static void log_solver_on(fmi2Component c) {
    fmi2String cat[1] = {"logSolver"};
    CHECK_STATUS(fmi2SetDebugLogging(c, fmi2True, 1, cat), fmi2OK);
}

/* One fmi2DoStep, its log counted (the log is cleared before and after). */
static fmi2Status counted_step(fmi2Component c, double t, double h, counts *n) {
    fmi2Status st;
    log_clear();
    st = fmi2DoStep(c, t, h, fmi2True);
    if (n) counts_add_log(n);
    log_clear();
    return st;
}

static void counts_print(const char *what, const counts *n) {
    fprintf(stderr,
            "COUNTS %s: accepted=%llu rejected=%llu rhs=%llu jacobians=%llu jac_rhs=%llu "
            "lu=%llu\n",
            what, n->accepted, n->rejected, n->rhs, n->jac, n->jac_rhs, n->lu);
}

#endif
