/*
 * gw_core.c -- the simulation core (gw_core.h) as one piece: its files in dependency order.
 * Included by a unity file (gw_fmu.c for an FMU) after the model, never compiled alone.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include "gw_instance.c"
#include "gw_eval.c"
#include "gw_log.c"
#include "gw_values.c"
#include "gw_simulation.c"
#include "gw_events.c"
#include "gw_state.c"
#include "gw_state_checks.c"
#include "gw_budget.c"
#include "gw_solver.c"
#include "gw_solver_fixed.c"
#include "gw_solver_dopri5.c"
#include "gw_solver_dop853.c"
#include "gw_solver_rodas4.c"
#include "gw_solver_taylor.c"

#endif /* GW_UNITY_BUILD */
