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

#endif /* GW_FRONT_H */
