/*
 * harness3.h -- the FMI 3.0 importer's view for the C tests: a capturing logger into the same
 * log as harness.h's (lines "[fmi3|status|category] message"), the status check, one-variable
 * get/set.  A driver may use both layers: an FMI 3.0 instance and an FMI 2.0 one of the same
 * toy model (gw_fmu.c and gw_fmu3.c linked into one program, their runtimes internal).
 */
#ifndef GW_TEST_HARNESS3_H
#define GW_TEST_HARNESS3_H

#include "harness.h"
#include "fmi3Functions.h"

static void h_logger3(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                      fmi3String message) {
    h_logger(env, "fmi3", (fmi2Status)status, category, message);
}

#define CHECK3_STATUS(call, expected) CHECK_STATUS((fmi2Status)(call), (fmi2Status)(expected))

/* fmi3 call `call` fails with fmi3Error, logs `reason` and leaves the instance in Error */
#define EXPECT3_ERROR(call, reason)                                                          \
    do {                                                                                     \
        log_clear();                                                                         \
        CHECK3_STATUS(call, fmi3Error);                                                      \
        CHECK_LOG(reason);                                                                   \
    } while (0)

static inline double getf3(fmi3Instance c, fmi3ValueReference vr) {
    double v = NAN;
    fmi3GetFloat64(c, &vr, 1, &v, 1);
    return v;
}
static inline fmi3Status setf3(fmi3Instance c, fmi3ValueReference vr, double v) {
    return fmi3SetFloat64(c, &vr, 1, &v, 1);
}
static inline fmi3Status seti64(fmi3Instance c, fmi3ValueReference vr, long long v) {
    fmi3Int64 x = v;
    return fmi3SetInt64(c, &vr, 1, &x, 1);
}
static inline int getb3(fmi3Instance c, fmi3ValueReference vr) {
    fmi3Boolean b = fmi3False;
    if (fmi3GetBoolean(c, &vr, 1, &b, 1) != fmi3OK) return -1;
    return b ? 1 : 0;
}

/* a Co-Simulation instance logging into h_log (checked non-NULL) */
static inline fmi3Instance cs3_new(const char *name, const char *token, int event_mode,
                                   int early_return) {
    fmi3Instance c = fmi3InstantiateCoSimulation(name, token, NULL, fmi3False, fmi3False,
                                                 event_mode ? fmi3True : fmi3False,
                                                 early_return ? fmi3True : fmi3False, NULL, 0,
                                                 NULL, h_logger3, NULL);
    CHECK(c != NULL);
    return c;
}

/* the result of one fmi3DoStep */
typedef struct {
    fmi3Status status;
    fmi3Boolean event_handling, terminate, early;
    double last;
} h_step3;

static inline h_step3 dostep3(fmi3Instance c, double t, double h) {
    h_step3 r;
    r.status = fmi3DoStep(c, t, h, fmi3True, &r.event_handling, &r.terminate, &r.early,
                          &r.last);
    return r;
}

#endif
