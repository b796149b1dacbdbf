/*
 * test_me_dirder.c -- fmi2GetDirectionalDerivative of the runtime linked statically with
 * toy_me.c (forced Duffing oscillator with a local state, exact `dir`): in Continuous-Time
 * Mode against the analytic Jacobian and central differences of fmi2GetDerivatives /
 * fmi2GetReal, combined and repeated seeds, in Event Mode, Initialization Mode and
 * Co-Simulation.  Prints the worst relative difference to central differences (checked by
 * tests/test_c_model_exchange.py).  Its errors: test_me.c.
 */
#include "harness.h"
#include "me_importer.h"

/* all 9 unknowns at (x, f) in CT mode */
static void eval_unknowns(fmi2Component c, const double *x, double f, double *out) {
    CHECK_STATUS(fmi2SetContinuousStates(c, x, NX), fmi2OK);
    CHECK_STATUS(setr(c, VR_F, f), fmi2OK);
    CHECK_STATUS(fmi2GetReal(c, UNK, 9, out), fmi2OK);
}

static double rel_err(double a, double b) {
    double s = fabs(a) > fabs(b) ? fabs(a) : fabs(b);
    return fabs(a - b) / (s > 1.0 ? s : 1.0);
}

static void test_directional_derivatives(void) {
    const double cpar = 0.5, f = 0.3;
    setup s = {cpar, f, -5.0, -10.0};
    fmi2Component c = me("dir");
    double x[NX] = {0.7, -0.45, 0.35}, D[8][4], dv[9], seed[4], worst_fd = 0.0;
    int i, j;
    to_ct_mode(c, &s);
    CHECK_STATUS(fmi2SetTime(c, 1.5), fmi2OK);
    CHECK_STATUS(fmi2SetContinuousStates(c, x, NX), fmi2OK);
    me_analytic_jacobian(cpar, x, f, D);
    for (j = 0; j < 4; j++) {
        double xp[NX], xm[NX], fp = f, fm = f, yp[9], ym[9], hstep;
        memset(seed, 0, sizeof(seed));
        seed[j] = 1.0;
        CHECK_STATUS(fmi2GetDirectionalDerivative(c, UNK, 9, KNOWN, 4, seed, dv), fmi2OK);
        for (i = 0; i < 8; i++) CHECK_NEAR(dv[i], D[i][j], 1e-14);
        CHECK_NEAR(dv[8], j == 2 ? 1.0 : 0.0, 0.0); /* w as unknown: identity row */
        /* central finite differences of GetDerivatives / GetReal */
        memcpy(xp, x, sizeof(xp));
        memcpy(xm, x, sizeof(xm));
        hstep = 1e-5;
        if (j < 3) {
            xp[j] += hstep;
            xm[j] -= hstep;
        } else {
            fp += hstep;
            fm -= hstep;
        }
        eval_unknowns(c, xp, fp, yp);
        eval_unknowns(c, xm, fm, ym);
        if (j < 3) { /* GetDerivatives agrees with der(...) */
            double dxp[NX];
            CHECK_STATUS(fmi2GetDerivatives(c, dxp, NX), fmi2OK);
            CHECK(dxp[0] == ym[0] && dxp[1] == ym[1] && dxp[2] == ym[2]);
        }
        for (i = 0; i < 9; i++) {
            double fd = (yp[i] - ym[i]) / (2.0 * hstep), e = rel_err(dv[i], fd);
            if (e > worst_fd) worst_fd = e;
            CHECK(e < 1e-6);
        }
        eval_unknowns(c, x, f, yp); /* back to the point */
    }
    fprintf(stderr, "directional derivatives vs central differences: worst relative %.3g\n",
            worst_fd);
    /* a combined seed, knowns in another order and repeated */
    {
        fmi2ValueReference kn[5] = {VR_F, VR_W, VR_POS, VR_VEL, VR_POS};
        double sd[5] = {0.5, -2.0, 1.5, 0.25, -0.5};
        CHECK_STATUS(fmi2GetDirectionalDerivative(c, UNK, 9, kn, 5, sd, dv), fmi2OK);
        for (i = 0; i < 8; i++)
            CHECK_NEAR(dv[i], 0.5 * D[i][3] - 2.0 * D[i][2] + 1.0 * D[i][0] + 0.25 * D[i][1],
                       1e-14);
        CHECK_NEAR(dv[8], -2.0, 0.0);
        CHECK_STATUS(fmi2GetDirectionalDerivative(c, UNK, 0, kn, 0, sd, dv), fmi2OK);
    }
    /* in Event Mode, Initialization Mode, and in Co-Simulation */
    CHECK_STATUS(fmi2EnterEventMode(c), fmi2OK);
    seed[0] = 1.0;
    CHECK_STATUS(fmi2GetDirectionalDerivative(c, UNK + 5, 1, KNOWN, 1, seed, dv), fmi2OK);
    CHECK_NEAR(dv[0], D[5][0], 1e-14);
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    log_clear();
    EXPECT_ERROR(fmi2GetDirectionalDerivative(c, UNK, 1, KNOWN, 1, seed, dv),
                 "fmi2GetDirectionalDerivative: illegal call in state Instantiated");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    configure(c, &s);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    {
        double x0[NX] = {1.0, 0.0, 0.0}, D0[8][4];
        me_analytic_jacobian(cpar, x0, f, D0);
        CHECK_STATUS(fmi2GetDirectionalDerivative(c, UNK, 8, KNOWN, 1, seed, dv), fmi2OK);
        for (i = 0; i < 8; i++) CHECK_NEAR(dv[i], D0[i][0], 1e-14);
    }
    fmi2FreeInstance(c);

    c = fmi2Instantiate("dir_cs", fmi2CoSimulation, TOKEN, "", &h_callbacks, fmi2False,
                        fmi2False);
    CHECK(c != NULL);
    configure(c, &s);
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.5, fmi2True), fmi2OK);
    {
        double xc[NX];
        fmi2ValueReference svr[3] = {VR_POS, VR_VEL, VR_W};
        CHECK_STATUS(fmi2GetReal(c, svr, 3, xc), fmi2OK);
        me_analytic_jacobian(cpar, xc, f, D);
        for (j = 0; j < 4; j++) {
            memset(seed, 0, sizeof(seed));
            seed[j] = 1.0;
            CHECK_STATUS(fmi2GetDirectionalDerivative(c, UNK, 9, KNOWN, 4, seed, dv), fmi2OK);
            for (i = 0; i < 8; i++) CHECK_NEAR(dv[i], D[i][j], 1e-14);
        }
        /* the state derivative variables in CS: ode at the current point */
        CHECK_NEAR(getr(c, VR_DPOS), xc[1], 0.0);
        CHECK_NEAR(getr(c, VR_DW), f * xc[1], 1e-15);
    }
    /* CS behaviour unchanged: ME functions refused */
    {
        double r[NX];
        EXPECT_ERROR(fmi2GetDerivatives(c, r, NX),
                     "fmi2GetDerivatives: Model Exchange is not supported by this instance");
    }
    fmi2FreeInstance(c);
}

int main(void) {
    test_directional_derivatives();
    return h_finish("test_me_dirder");
}
