/*
 * test_fmi3_partials.c -- fmi3GetDirectionalDerivative and fmi3GetAdjointDerivative of the
 * FMI 3.0 runtime (c_src/gw_fmu3.c) with toy_me.c (forced Duffing oscillator with a local
 * state, exact `dir`), linked beside the FMI 2.0 runtime (c_src/gw_fmu.c, same model) in one
 * program: every directional derivative equals fmi2GetDirectionalDerivative's and the
 * analytic Jacobian; adjoints agree with directional derivatives (unit seeds exactly,
 * v^T (J w) == (v^T J) w to 1e-15); refusals (sizes, value references, time, states) are
 * logged; every function of what the FMU does not have (clocks, configuration mode, ...)
 * returns fmi3Error with its reason and leaves the instance in the Error state.  Built with
 * -DTOY_ME_ARRAYS: array variables among the unknowns and knowns give their elements' scalar
 * results bit for bit.
 */
#include "harness.h"
#include "me_importer.h"

#include "fmi3Functions.h"

#ifndef TOY_ME_ARRAYS
#error "build with -DTOY_ME_ARRAYS (toy_me.c's array variables xs and ef)"
#endif
enum { VR_XS = 70, VR_EF = 71 };

/* FMI 3.0's logger into the harness's log (one line per message, tagged "fmi3") */
static void h3_logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                      fmi3String message) {
    h_logger(env, "fmi3", (fmi2Status)status, category, message);
}

#define EXPECT_ERROR3(call, msg)                                                             \
    do {                                                                                     \
        log_clear();                                                                         \
        CHECK_STATUS((fmi2Status)(call), fmi2Error);                                         \
        CHECK_LOG(msg);                                                                      \
    } while (0)
#define OK3(call) CHECK_STATUS((fmi2Status)(call), fmi2OK)

enum { NU = 9, NK = 4 };

/* FMI 2 in Continuous-Time Mode after initialisation with the model's defaults
 * (x0 = (1, 0, 0), f = 0, c = 0.5) */
static fmi2Component fmi2_ct_mode(void) {
    const setup defaults = {0.5, 0.0, -0.5, -10.0};
    fmi2Component c2 = me("fmi2");
    to_ct_mode(c2, &defaults);
    return c2;
}

static fmi3Instance fmi3_instance(int cs) {
    fmi3Instance c3 = cs ? fmi3InstantiateCoSimulation("fmi3", TOKEN, NULL, fmi3False, fmi3False,
                                                       fmi3False, fmi3False, NULL, 0, NULL,
                                                       h3_logger, NULL)
                         : fmi3InstantiateModelExchange("fmi3", TOKEN, NULL, fmi3False, fmi3False,
                                                        NULL, h3_logger);
    CHECK(c3 != NULL);
    return c3;
}

static void fmi3_initialise(fmi3Instance c3) {
    OK3(fmi3EnterInitializationMode(c3, fmi3False, 0.0, 0.0, fmi3False, 0.0));
    OK3(fmi3ExitInitializationMode(c3));
}

/* FMI 3 directional derivatives == FMI 2's == analytic, unit seeds and a combined one; the
 * adjoint of every unit seed is a row of the same J, exactly */
static void check_against_fmi2(fmi2Component c2, fmi3Instance c3, const double *x, double f) {
    double D[8][4], d2[NU], d3[NU], a3[NK], seed[NK];
    int i, j;
    me_analytic_jacobian(0.5, x, f, D);
    for (j = 0; j < NK; j++) {
        memset(seed, 0, sizeof(seed));
        seed[j] = 1.0;
        CHECK_STATUS(fmi2GetDirectionalDerivative(c2, UNK, NU, KNOWN, NK, seed, d2), fmi2OK);
        OK3(fmi3GetDirectionalDerivative(c3, UNK, NU, KNOWN, NK, seed, NK, d3, NU));
        for (i = 0; i < NU; i++) CHECK(d3[i] == d2[i]);
        for (i = 0; i < 8; i++) CHECK_NEAR(d3[i], D[i][j], 1e-14);
        CHECK(d3[8] == (j == 2 ? 1.0 : 0.0)); /* w as an unknown: the identity */
    }
    for (i = 0; i < NU; i++) {
        double row[NU] = {0};
        row[i] = 1.0;
        OK3(fmi3GetAdjointDerivative(c3, UNK, NU, KNOWN, NK, row, NU, a3, NK));
        for (j = 0; j < NK; j++) {
            memset(seed, 0, sizeof(seed));
            seed[j] = 1.0;
            OK3(fmi3GetDirectionalDerivative(c3, UNK, NU, KNOWN, NK, seed, NK, d3, NU));
            CHECK(a3[j] == d3[i]);
        }
    }
    {
        fmi3ValueReference kn[5] = {VR_F, VR_W, VR_POS, VR_VEL, VR_POS};
        double sd[5] = {0.5, -2.0, 1.5, 0.25, -0.5};
        CHECK_STATUS(fmi2GetDirectionalDerivative(c2, UNK, NU, kn, 5, sd, d2), fmi2OK);
        OK3(fmi3GetDirectionalDerivative(c3, UNK, NU, kn, 5, sd, 5, d3, NU));
        for (i = 0; i < NU; i++) CHECK(d3[i] == d2[i]);
    }
}

/* v^T (J w) == (v^T J) w for seeds of every sign and scale, knowns repeated */
static void check_adjoint_identity(fmi3Instance c3) {
    const fmi3ValueReference kn[5] = {VR_F, VR_W, VR_POS, VR_VEL, VR_POS};
    double worst = 0.0;
    int trial, i;
    for (trial = 0; trial < 20; trial++) {
        double v[NU], w[5], jw[NU], vj[5], lhs = 0.0, rhs = 0.0, scale = 0.0;
        for (i = 0; i < NU; i++) v[i] = sin(1.7 * (trial + 1) + 0.9 * i) * pow(10.0, trial % 5 - 2);
        for (i = 0; i < 5; i++) w[i] = cos(2.3 * (trial + 1) - 1.1 * i);
        OK3(fmi3GetDirectionalDerivative(c3, UNK, NU, kn, 5, w, 5, jw, NU));
        OK3(fmi3GetAdjointDerivative(c3, UNK, NU, kn, 5, v, NU, vj, 5));
        for (i = 0; i < NU; i++) {
            lhs += v[i] * jw[i];
            scale += fabs(v[i] * jw[i]);
        }
        for (i = 0; i < 5; i++) {
            rhs += vj[i] * w[i];
            scale += fabs(vj[i] * w[i]);
        }
        if (fabs(lhs - rhs) / (scale > 0.0 ? scale : 1.0) > worst)
            worst = fabs(lhs - rhs) / (scale > 0.0 ? scale : 1.0);
    }
    CHECK(worst <= 1e-15);
    fprintf(stderr, "adjoint identity v^T (J w) - (v^T J) w: worst relative %.3g\n", worst);
}

/* Arrays among the unknowns ([ef, w, xs] = [energy, force, w, pos, vel, w]) and knowns
 * ([f, xs] = [f, pos, vel, w]): both functions give the scalars' results bit for bit, seeds and
 * sensitivities element by element (FMI 3.0.2 section 2.2.12); v^T (J w) == (v^T J) w; wrong
 * sizes and an output array as a known refused.  Leaves c3 in the Error state. */
static void check_arrays(fmi3Instance c3) {
    const fmi3ValueReference ua[3] = {VR_EF, VR_W, VR_XS}, ka[2] = {VR_F, VR_XS};
    const fmi3ValueReference us[6] = {VR_ENERGY, VR_FORCE, VR_W, VR_POS, VR_VEL, VR_W};
    const fmi3ValueReference ks[4] = {VR_F, VR_POS, VR_VEL, VR_W};
    double v[6], w[4], ja[6], js[6], va[4], vs[4], lhs = 0.0, rhs = 0.0, scale = 0.0;
    int i;
    for (i = 0; i < 6; i++) v[i] = sin(1.3 + 0.7 * i);
    for (i = 0; i < 4; i++) w[i] = cos(0.4 - 1.9 * i);
    OK3(fmi3GetDirectionalDerivative(c3, ua, 3, ka, 2, w, 4, ja, 6));
    OK3(fmi3GetDirectionalDerivative(c3, us, 6, ks, 4, w, 4, js, 6));
    CHECK(memcmp(ja, js, sizeof(ja)) == 0);
    OK3(fmi3GetAdjointDerivative(c3, ua, 3, ka, 2, v, 6, va, 4));
    OK3(fmi3GetAdjointDerivative(c3, us, 6, ks, 4, v, 6, vs, 4));
    CHECK(memcmp(va, vs, sizeof(va)) == 0);
    for (i = 0; i < 6; i++) lhs += v[i] * ja[i], scale += fabs(v[i] * ja[i]);
    for (i = 0; i < 4; i++) rhs += va[i] * w[i], scale += fabs(va[i] * w[i]);
    CHECK(scale > 0.0 && fabs(lhs - rhs) / scale <= 1e-15);
    EXPECT_ERROR3(fmi3GetDirectionalDerivative(c3, ua, 3, ka, 2, w, 4, ja, 3),
                  "fmi3GetDirectionalDerivative: nSensitivity = 3, but the unknowns have 6 values");
    EXPECT_ERROR3(fmi3GetAdjointDerivative(c3, ua, 3, ka, 2, v, 3, va, 4),
                  "fmi3GetAdjointDerivative: nSeed = 3, but the unknowns have 6 values");
    EXPECT_ERROR3(fmi3GetDirectionalDerivative(c3, &ua[2], 1, &ua[0], 1, w, 2, ja, 3),
                  "fmi3GetDirectionalDerivative: known energy (vr=20) is not");
}

/* refusals: each fmi3Error with its reason; the instance is then in Error state (where the
 * derivatives are still answered, as in FMI 2), so each starts from a fresh initialisation */
static void check_refusals(void) {
    const fmi3ValueReference time_vr = 0, bad = 999, settings = VR_SOLVER, param = VR_C;
    double seed[NU] = {1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0}, out[NU];
    fmi3Instance c3 = fmi3_instance(0);
    EXPECT_ERROR3(fmi3GetDirectionalDerivative(c3, UNK, 1, KNOWN, 1, seed, 1, out, 1),
                  "fmi3GetDirectionalDerivative: illegal call in state Instantiated");
    OK3(fmi3Reset(c3));
    EXPECT_ERROR3(fmi3GetAdjointDerivative(c3, UNK, 1, KNOWN, 1, seed, 1, out, 1),
                  "fmi3GetAdjointDerivative: illegal call in state Instantiated");
    OK3(fmi3Reset(c3));
    fmi3_initialise(c3);
#define REFUSED(call, msg)                                                                   \
    do {                                                                                     \
        EXPECT_ERROR3(call, msg);                                                            \
        OK3(fmi3Reset(c3));                                                                  \
        fmi3_initialise(c3);                                                                 \
    } while (0)
    REFUSED(fmi3GetDirectionalDerivative(c3, UNK, NU, KNOWN, NK, seed, NK - 1, out, NU),
            "fmi3GetDirectionalDerivative: nSeed = 3, but the knowns have 4 values");
    REFUSED(fmi3GetDirectionalDerivative(c3, UNK, NU, KNOWN, NK, seed, NK, out, NU + 1),
            "fmi3GetDirectionalDerivative: nSensitivity = 10, but the unknowns have 9 values");
    REFUSED(fmi3GetAdjointDerivative(c3, UNK, NU, KNOWN, NK, seed, NK, out, NK),
            "fmi3GetAdjointDerivative: nSeed = 4, but the unknowns have 9 values");
    REFUSED(fmi3GetAdjointDerivative(c3, UNK, NU, KNOWN, NK, seed, NU, out, NU),
            "fmi3GetAdjointDerivative: nSensitivity = 9, but the knowns have 4 values");
    REFUSED(fmi3GetDirectionalDerivative(c3, UNK, 1, &time_vr, 1, seed, 1, out, 1),
            "fmi3GetDirectionalDerivative: known time (vr=0) is not a continuous state or a "
            "Float64 input");
    REFUSED(fmi3GetAdjointDerivative(c3, &time_vr, 1, KNOWN, 1, seed, 1, out, 1),
            "fmi3GetAdjointDerivative: time (vr=0) is not an unknown (a Float64 output");
    REFUSED(fmi3GetDirectionalDerivative(c3, &bad, 1, KNOWN, 1, seed, 1, out, 1),
            "fmi3GetDirectionalDerivative: unknown value reference 999 (unknowns[0])");
    REFUSED(fmi3GetAdjointDerivative(c3, UNK, 1, &bad, 1, seed, 1, out, 1),
            "fmi3GetAdjointDerivative: unknown value reference 999 (knowns[0])");
    REFUSED(fmi3GetDirectionalDerivative(c3, UNK, 1, &settings, 1, seed, 1, out, 1),
            "known solver (vr=40) is not a continuous state");
    REFUSED(fmi3GetDirectionalDerivative(c3, UNK, 1, &param, 1, seed, 1, out, 1),
            "known c (vr=1) is not a continuous state or a Float64 input (parameters are knowns "
            "only in Initialization Mode");
    REFUSED(fmi3GetAdjointDerivative(c3, &param, 1, KNOWN, 1, seed, 1, out, 1),
            "fmi3GetAdjointDerivative: c (vr=1) is not an unknown");
    REFUSED(fmi3GetDirectionalDerivative(c3, UNK, NU, KNOWN, NK, NULL, NK, out, NU),
            "fmi3GetDirectionalDerivative: NULL array for 4 knowns");
    REFUSED(fmi3GetAdjointDerivative(c3, UNK, NU, KNOWN, NK, seed, NU, NULL, NK),
            "fmi3GetAdjointDerivative: NULL array for 4 knowns");
    {
        double nan_seed[NU] = {0.0, NAN, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0}, huge[NK];
        double keep[NU] = {7.0, 7.0, 7.0, 7.0, 7.0, 7.0, 7.0, 7.0, 7.0};
        REFUSED(fmi3GetAdjointDerivative(c3, UNK, NU, KNOWN, NK, nan_seed, NU, out, NK),
                "fmi3GetAdjointDerivative: seed[1] for der(vel) is not finite");
        REFUSED(fmi3GetDirectionalDerivative(c3, UNK, NU, KNOWN, NK, nan_seed, NK, out, NU),
                "fmi3GetDirectionalDerivative: seed[1] for vel is not finite");
        /* overflow: refused, nothing written */
        huge[0] = huge[1] = huge[2] = huge[3] = 1e308;
        EXPECT_ERROR3(fmi3GetDirectionalDerivative(c3, UNK, 2, KNOWN, NK, huge, NK, keep, 2),
                      "the directional derivative of der(vel) is not finite");
        CHECK(keep[0] == 7.0 && keep[1] == 7.0);
        OK3(fmi3Reset(c3));
        fmi3_initialise(c3);
        for (int i = 0; i < NU; i++) nan_seed[i] = 1e308;
        EXPECT_ERROR3(fmi3GetAdjointDerivative(c3, UNK, NU, KNOWN, NK, nan_seed, NU, keep, NK),
                      "fmi3GetAdjointDerivative: the adjoint derivative with respect to pos is "
                      "not finite");
        CHECK(keep[0] == 7.0 && keep[3] == 7.0);
        OK3(fmi3Reset(c3));
        fmi3_initialise(c3);
    }
    /* empty lists: fmi3OK, nothing touched */
    OK3(fmi3GetDirectionalDerivative(c3, NULL, 0, NULL, 0, NULL, 0, NULL, 0));
    OK3(fmi3GetAdjointDerivative(c3, NULL, 0, NULL, 0, NULL, 0, NULL, 0));
#undef REFUSED
    fmi3FreeInstance(c3);
}

/* one call of each function of what the FMU does not have (k = 0..15; -1 after the last) */
static fmi3Status call_absent(int k, fmi3Instance c, const char **name) {
    const fmi3ValueReference vr[1] = {VR_POS};
    fmi3Float64 f64[1] = {0.0};
    fmi3UInt64 u1[1] = {0}, u2[1] = {0};
    fmi3IntervalQualifier q[1];
    fmi3Clock clk[1] = {fmi3False};
    size_t n = 0, e1[1], e2[1];
    fmi3ValueReference ind[1];
    fmi3DependencyKind dk[1];
    switch (k) {
#define ABSENT0(i, fn) case i: *name = #fn; return fn(c)
#define ABSENT(i, fn, ...) case i: *name = #fn; return fn(c, __VA_ARGS__)
    ABSENT0(0, fmi3EnterConfigurationMode);
    ABSENT0(1, fmi3ExitConfigurationMode);
    ABSENT(2, fmi3GetClock, vr, 1, clk);
    ABSENT(3, fmi3SetClock, vr, 1, clk);
    ABSENT(4, fmi3GetIntervalDecimal, vr, 1, f64, q);
    ABSENT(5, fmi3GetIntervalFraction, vr, 1, u1, u2, q);
    ABSENT(6, fmi3GetShiftDecimal, vr, 1, f64);
    ABSENT(7, fmi3GetShiftFraction, vr, 1, u1, u2);
    ABSENT(8, fmi3SetIntervalDecimal, vr, 1, f64);
    ABSENT(9, fmi3SetIntervalFraction, vr, 1, u1, u2);
    ABSENT(10, fmi3SetShiftDecimal, vr, 1, f64);
    ABSENT(11, fmi3SetShiftFraction, vr, 1, u1, u2);
    ABSENT0(12, fmi3EvaluateDiscreteStates);
    ABSENT(13, fmi3ActivateModelPartition, vr[0], 0.0);
    ABSENT(14, fmi3GetNumberOfVariableDependencies, vr[0], &n);
    ABSENT(15, fmi3GetVariableDependencies, vr[0], e1, ind, e2, dk, 1);
#undef ABSENT0
#undef ABSENT
    default: *name = NULL; return fmi3OK;
    }
}

/* every absent function: fmi3Error, its reason logged ("<function>: ..."), the instance in
 * the Error state after (Model Exchange and Co-Simulation, before and after initialisation);
 * a NULL instance: fmi3Error, no crash */
static void check_absent(void) {
    const char *name;
    int k, cs, initialised;
    for (cs = 0; cs < 2; cs++)
        for (initialised = 0; initialised < 2; initialised++) {
            fmi3Instance c3 = fmi3_instance(cs);
            for (k = 0; call_absent(k, c3, &name), name; k++) {
                char prefix[64];
                OK3(fmi3Reset(c3));
                if (initialised) fmi3_initialise(c3);
                snprintf(prefix, sizeof(prefix), "%s: ", name);
                EXPECT_ERROR3(call_absent(k, c3, &name), prefix);
                CHECK(strstr(h_log, "this FMU") != NULL);
                /* in the Error state now: initialising is illegal */
                EXPECT_ERROR3(fmi3EnterInitializationMode(c3, fmi3False, 0.0, 0.0, fmi3False,
                                                          0.0),
                              "illegal call in state Error");
            }
            CHECK(k == 16);
            fmi3FreeInstance(c3);
        }
    for (k = 0; k < 16; k++) CHECK_STATUS((fmi2Status)call_absent(k, NULL, &name), fmi2Error);
    /* the clock getter and setter of an empty list: fmi3OK, as every typed getter/setter */
    {
        fmi3Instance c3 = fmi3_instance(1);
        OK3(fmi3GetClock(c3, NULL, 0, NULL));
        OK3(fmi3SetClock(c3, NULL, 0, NULL));
        fmi3FreeInstance(c3);
    }
}

int main(void) {
    double x0[NX] = {1.0, 0.0, 0.0};
    fmi2Component c2 = fmi2_ct_mode();
    fmi3Instance c3 = fmi3_instance(0);
    fmi3_initialise(c3);
    /* FMI 3 in Event Mode after initialisation, FMI 2 in Continuous-Time Mode at that point */
    check_against_fmi2(c2, c3, x0, 0.0);
    check_adjoint_identity(c3);
    /* Terminated: still answered (FMI 3.0.2 section 2.3.7) */
    OK3(fmi3Terminate(c3));
    CHECK_STATUS(fmi2Terminate(c2), fmi2OK);
    check_against_fmi2(c2, c3, x0, 0.0);
    check_arrays(c3);
    fmi3FreeInstance(c3);
    fmi2FreeInstance(c2);
    /* Co-Simulation in Step Mode (eventModeUsed false) */
    c2 = fmi2Instantiate("fmi2cs", fmi2CoSimulation, TOKEN, "", &h_callbacks, fmi2False,
                         fmi2False);
    CHECK_STATUS(fmi2SetupExperiment(c2, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c2), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c2), fmi2OK);
    c3 = fmi3_instance(1);
    fmi3_initialise(c3);
    check_against_fmi2(c2, c3, x0, 0.0);
    fmi3FreeInstance(c3);
    fmi2FreeInstance(c2);
    check_refusals();
    check_absent();
    return h_finish("test_fmi3_partials");
}
