/*
 * gw_solver.h -- one interface for all internal integrators of the runtime.
 *
 *   gw_integrate(I, t_end)  integrates from (I->t, I->x) exactly to t_end with the
 *                           solver selected in I->solver, locating events (gw_events.c)
 *                           on the dense output of every accepted step.
 *
 * Solvers (gw_solver enumeration of gw_model.h):
 *   GW_SOLVER_EULER   explicit Euler, fixed step: n = ceil(h / max_step) equal substeps
 *   GW_SOLVER_RK4     classical Runge-Kutta 4, fixed step, same grid
 *   GW_SOLVER_DOPRI5  Dormand-Prince 5(4), error control (RMS norm of
 *                     err_i / (abs_tol*nominal_i + rel_tol*max(|x_i|,|xnew_i|))),
 *                     FSAL, step size bounded by max_step and carried between steps
 *   GW_SOLVER_DOP853  Dormand-Prince 8(5,3) (Hairer's DOP853): 12 stages + FSAL,
 *                     Hairer's combined 5th/3rd-order error estimate with the same
 *                     weights, for tight tolerances
 *   GW_SOLVER_ROSENBROCK  RODAS4 (Hairer & Wanner): linearly implicit, 6 stages,
 *                     order 4(3), stiffly accurate, L-stable, for stiff problems.
 *                     Jacobian: the model's `jac` function; if the model has none,
 *                     forward differences (nx RHS evaluations, increment
 *                     sqrt(eps)*max(|x_j|, nominal_j)).  d f/d t by a forward difference
 *                     (one RHS evaluation per step).  W = I/(gamma h) - J is LU-factored
 *                     with partial pivoting (dense, in the instance's work arrays); J is
 *                     evaluated once per accepted step, a rejected step only refactors.
 *                     Error = weighted RMS norm of the embedded difference, same weights.
 * All adaptive solvers land exactly on t_end, respect max_step, carry the step size
 * between communication steps in I->h_adapt (the only solver memory kept between
 * steps, serialised with the FMU state) and fail with "step size underflow" below
 * gw_h_min.
 * Dense output: DOPRI5's 4th-order continuous extension; DOP853's 7th-order one (3
 * extra stages, evaluated only when an event needs them); RODAS4's 3rd-order one;
 * cubic Hermite for the fixed step solvers (all in the nested form of gw_dense_eval).
 *
 * Declarations live in gw_instance.h (gw_integrate, gw_dense_prepare, gw_dense_eval);
 * this header only documents the module and the constants it uses.
 */
#ifndef GW_SOLVER_H
#define GW_SOLVER_H

#include "gw_instance.h"

#define GW_DOPRI5_SAFETY 0.9
#define GW_DOPRI5_FAC_MIN 0.2  /* largest decrease of h per step */
#define GW_DOPRI5_FAC_MAX 10.0 /* largest increase of h per step */
#define GW_MAX_EVENTS_PER_STEP 1000

/* smallest step size allowed at time t before "step size underflow" */
GW_INTERNAL double gw_h_min(double t);

#endif /* GW_SOLVER_H */
