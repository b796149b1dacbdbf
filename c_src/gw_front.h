/*
 * gw_front.h -- what the FMI 2.0 and FMI 3.0 layers share, free of either interface's types:
 * message escaping and hashing (the loggers' repeat counting), the name of the terminating
 * event that ended a run, and the copy of model values that refuses non-finite ones.  Part of
 * both unity files (gw_fmu.c, gw_fmu3.c), after the core.
 */
#ifndef GW_FRONT_H
#define GW_FRONT_H

#include "gw_instance.h"

/* raw with every '%' doubled into buf (size bytes, always terminated): importers may treat a
 * message as a printf format */
GW_INTERNAL void gw_front_escape(char *buf, size_t size, const char *raw);
/* FNV-1a, 64 bit, of a message and its status (a run of identical messages is counted) */
GW_INTERNAL unsigned long long gw_front_hash(const char *text, int status);
/* name of the terminating event that stopped the simulation, or "a terminating event" */
GW_INTERNAL const char *gw_front_stop_reason(const gw_instance *I);
/* copy n values to dst only if every one is finite; else leaves dst untouched, logs which value
 * is not (names[i] or what; the message starts with fn) and returns I->nonfinite_status */
GW_INTERNAL gw_status gw_front_copy_finite(gw_instance *I, const char *fn, double *dst,
                                           const double *src, size_t n, const char *what,
                                           const char *const *names);


/* ---- variables (gw_fmi2_variables.c, gw_fmi3_variables.c) ---------------------------------- */
/* what reading v needs first: outputs current (gw_update_outputs), state derivatives current
 * (gw_update_derivatives), event indicators in I->e_me (gw_front_indicators); 0 for NULL */
enum { GW_NEED_OUTPUTS = 1, GW_NEED_DERIVATIVES = 2, GW_NEED_INDICATORS = 4 };
GW_INTERNAL int gw_front_needs(const gw_instance *I, const gw_variable *v);
/* I->e_me = evt(t, x, u, p) at the current point (before the initialisation at x = init(s, p))
 * for variables of kind GW_VAR_INDICATOR; GW_ERROR with the reason logged if it fails */
GW_INTERNAL gw_status gw_front_indicators(gw_instance *I, const char *fn);
/* v's value into *d if finite; else logs it (I->nonfinite_status) and returns that status */
GW_INTERNAL gw_status gw_front_get_finite(gw_instance *I, const char *fn, const gw_variable *v,
                                          double *d);
/* Whether v may be set now, the value being valid: the rules of FMI 2.0.4 (sections 3.2.3,
 * 4.2.4) and FMI 3.0.2 (section 2.3.1), alike: a parameter before the initialisation ends, a
 * tunable one also where the interface allows (tunable_ok), an input where the interface allows
 * (input_ok), a start value or setting before the initialisation ends; states, derivatives and
 * computed values never (hint: how to set a state instead, "" if there is no way).  0 with the
 * reason logged (state: the interface's name of the current state). */
GW_INTERNAL int gw_front_settable(gw_instance *I, const char *fn, const gw_variable *v,
                                  int input_ok, int tunable_ok, const char *state,
                                  const char *hint);

/* ---- Co-Simulation steps (gw_fmi2_cs.c, gw_fmi3_cs.c) ---------------------------------------- */
/* The arguments of a communication step from tc by h: finite, h > 0 and not lost in tc's
 * rounding, tc the instance's time, tc + h not beyond the stop time.  GW_OK with *t_end = tc + h,
 * or GW_ERROR with the reason logged. */
GW_INTERNAL gw_status gw_front_step_check(gw_instance *I, const char *fn, double tc, double h,
                                          double *t_end);
/* the solver's counters at a step's start, for gw_front_step_log */
typedef struct {
    unsigned long long rhs, accepted, rejected;
} gw_front_counts;
GW_INTERNAL void gw_front_counts_take(const gw_instance *I, gw_front_counts *c);
/* the step's solver line (category logSolver, if enabled): times, counts since c0, status */
GW_INTERNAL void gw_front_step_log(gw_instance *I, const char *fn, double tc, double h,
                                   const gw_front_counts *c0, const char *status);

#endif /* GW_FRONT_H */
