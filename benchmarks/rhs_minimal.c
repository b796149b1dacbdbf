/* The minimal hand-written right-hand side (minimal_wheel.h) behind the same opaque boundary as
 * the generated model (rhs_model.c): its own translation unit, called through a pointer; with
 * libm's sin and cos (rhs_minimal) and with the runtime's gw_sincos (rhs_minimal_fast, the
 * generated code's: c_src/gw_sincos.h). */
#include "gw_sincos.h"
#include "minimal_wheel.h"

void rhs_minimal(const void *w, const double *x, double *xdot);
void rhs_minimal_fast(const void *w, const double *x, double *xdot);
void rhs_minimal_init(void *w, const double *p);
unsigned long rhs_minimal_size(void);

void rhs_minimal(const void *w, const double *x, double *xdot) {
    minimal_wheel_rhs((const minimal_wheel *)w, x, xdot);
}
void rhs_minimal_fast(const void *w, const double *x, double *xdot) {
    double sa, ca, sb, cb;
    gw_sincos2(x[2], x[3], &sa, &ca, &sb, &cb);
    minimal_wheel_rhs_trig((const minimal_wheel *)w, x, xdot, sa, ca, sb, cb);
}
void rhs_minimal_init(void *w, const double *p) { minimal_wheel_init((minimal_wheel *)w, p); }
unsigned long rhs_minimal_size(void) { return (unsigned long)sizeof(minimal_wheel); }
