/* The minimal hand-written right-hand side (minimal_wheel.h) behind the same opaque boundary as
 * the generated model (rhs_model.c): its own translation unit, called through a pointer. */
#include "minimal_wheel.h"

void rhs_minimal(const void *w, const double *x, double *xdot);
void rhs_minimal_init(void *w, const double *p);
unsigned long rhs_minimal_size(void);

void rhs_minimal(const void *w, const double *x, double *xdot) {
    minimal_wheel_rhs((const minimal_wheel *)w, x, xdot);
}
void rhs_minimal_init(void *w, const double *p) { minimal_wheel_init((minimal_wheel *)w, p); }
unsigned long rhs_minimal_size(void) { return (unsigned long)sizeof(minimal_wheel); }
