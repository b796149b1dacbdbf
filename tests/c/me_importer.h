/*
 * me_importer.h -- toy_me.c (forced Duffing oscillator with a local state, TERMINATE event
 * "hit", WARN event "slow", exact `dir`) as a Model Exchange importer sees it: its token, sizes
 * and value references, the unknowns and knowns of its directional derivatives, and the steps
 * every test of test_me.c and test_me_dirder.c starts from.
 * Test code only (include after harness.h).
 */
#ifndef GW_TEST_ME_IMPORTER_H
#define GW_TEST_ME_IMPORTER_H

#define TOKEN "{70y0-me00-0000-0000-000000000004}"
#define NX 3
#define NE 2

enum { VR_K = 0, VR_C = 1, VR_POS_LIM = 2, VR_VEL_LIM = 3, VR_USE_FORCE = 4, VR_POS = 10,
       VR_VEL = 11, VR_W = 12, VR_ENERGY = 20, VR_FORCE = 21, VR_WPOS = 22, VR_F = 30,
       VR_SOLVER = 40, VR_HIT = 50, VR_SLOW = 51, VR_DPOS = 60, VR_DVEL = 61, VR_DW = 62 };

/* the error is returned, its reason logged; the instance is then in Error state */
#define EXPECT_ERROR(call, msg)                                                              \
    do {                                                                                     \
        log_clear();                                                                         \
        CHECK_STATUS(call, fmi2Error);                                                       \
        CHECK_LOG(msg);                                                                      \
    } while (0)

/* the parameters of one run; everything else default */
typedef struct {
    double c, f, pos_lim, vel_lim;
} setup;

static void configure(fmi2Component c, const setup *s) {
    CHECK_STATUS(setr(c, VR_C, s->c), fmi2OK);
    CHECK_STATUS(setr(c, VR_F, s->f), fmi2OK);
    CHECK_STATUS(setr(c, VR_POS_LIM, s->pos_lim), fmi2OK);
    CHECK_STATUS(setr(c, VR_VEL_LIM, s->vel_lim), fmi2OK);
}

/* Instantiated -> InitializationMode -> EventMode -> ContinuousTimeMode */
static void to_ct_mode(fmi2Component c, const setup *s) {
    fmi2EventInfo ei;
    configure(c, s);
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    memset(&ei, 0xff, sizeof(ei));
    CHECK_STATUS(fmi2NewDiscreteStates(c, &ei), fmi2OK);
    CHECK(ei.newDiscreteStatesNeeded == fmi2False);
    CHECK(ei.terminateSimulation == fmi2False);
    CHECK(ei.nominalsOfContinuousStatesChanged == fmi2False);
    CHECK(ei.valuesOfContinuousStatesChanged == fmi2False);
    CHECK(ei.nextEventTimeDefined == fmi2False);
    CHECK_STATUS(fmi2EnterContinuousTimeMode(c), fmi2OK);
}

static fmi2Component me(const char *name) {
    fmi2Component c =
        fmi2Instantiate(name, fmi2ModelExchange, TOKEN, "", &h_callbacks, fmi2False, fmi2True);
    CHECK(c != NULL);
    return c;
}

/* analytic D of toy_me at x, f (k = 1, use_force = 1, parameter c): rows der(pos), der(vel),
 * der(w), pos, vel, energy, force, wpos; columns pos, vel, w, f */
static inline void me_analytic_jacobian(double c, const double *x, double f, double D[8][4]) {
    memset(D, 0, 8 * 4 * sizeof(double));
    D[0][1] = 1.0;
    D[1][0] = -1.0 - 3.0 * c * x[0] * x[0];
    D[1][3] = 1.0;
    D[2][1] = f;
    D[2][3] = x[1];
    D[3][0] = 1.0;
    D[4][1] = 1.0;
    D[5][0] = x[0] + c * x[0] * x[0] * x[0];
    D[5][1] = x[1];
    D[6][3] = 1.0;
    D[7][0] = x[2];
    D[7][2] = x[0];
}

/* unknowns: der(pos), der(vel), der(w), pos, vel, energy, force, wpos (rows of D), w */
static const fmi2ValueReference UNK[9] = {VR_DPOS, VR_DVEL, VR_DW, VR_POS, VR_VEL,
                                          VR_ENERGY, VR_FORCE, VR_WPOS, VR_W};
static const fmi2ValueReference KNOWN[4] = {VR_POS, VR_VEL, VR_W, VR_F};

#endif
