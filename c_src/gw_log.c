/*
 * gw_log.c -- logging through the front end's logger callback.
 *
 * Categories (modelDescription.xml <LogCategories>, FMI 2.0.4 section 2.2.4): logEvents,
 * logSolver, logStatusWarning, logStatusDiscard, logStatusError, logStatusFatal, logAll.
 * Rule: a message with a status other than GW_OK is the reason of that status and always
 * reaches the logger (if there is one), whatever the debug-logging settings (every
 * fmi2Warning, fmi2Discard, fmi2Error comes with its reason); GW_OK messages only when
 * logging is on and their category (or logAll) is enabled.  Callers test gw_log_enabled()
 * before formatting expensive messages.
 * The logger receives the formatted text; the FMI layer escapes it for importers
 * that treat the message as a format string.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "gw_instance.h"

GW_API const char *gw_log_category_name(int cat) {
    switch (cat) {
    case GW_LOG_EVENTS: return "logEvents";
    case GW_LOG_SOLVER: return "logSolver";
    case GW_LOG_WARNING: return "logStatusWarning";
    case GW_LOG_ERROR: return "logStatusError";
    case GW_LOG_FATAL: return "logStatusFatal";
    case GW_LOG_DISCARD: return "logStatusDiscard";
    default: return "logAll";
    }
}

GW_API int gw_log_enabled(const gw_instance *I, gw_log_category cat) {
    if (!I || !I->cb.logger || !I->logging_on) return 0;
    return (I->log_mask & ((1u << cat) | (1u << GW_LOG_ALL))) != 0;
}

GW_API void gw_log(const gw_instance *I, gw_status status, gw_log_category cat, const char *fmt,
                   ...) {
    va_list ap;
    char message[1024];
    int always = status != GW_OK;
    if (!I || !I->cb.logger) return;
    if (!always && !gw_log_enabled(I, cat)) return;
    if (status == GW_FATAL) cat = GW_LOG_FATAL;
    va_start(ap, fmt);
    vsnprintf(message, sizeof(message), fmt, ap);
    va_end(ap);
    I->cb.logger(I->cb.env, I->name ? I->name : "", status, gw_log_category_name(cat), message);
}

GW_API gw_status gw_set_logging(gw_instance *I, const char *fn, int on, size_t n,
                                const char *const categories[]) {
    size_t i;
    unsigned int mask = I->log_mask;
    const unsigned int all = (1u << GW_LOG_N) - 1u;
    if (n == 0) {
        I->logging_on = on ? 1 : 0;
        I->log_mask = on ? all : 0u;
        return GW_OK;
    }
    if (!categories) {
        GW_LOG_ERR(I, "%s: categories is NULL but nCategories = %lu", fn, (unsigned long)n);
        return GW_ERROR;
    }
    for (i = 0; i < n; i++) {
        int k, found = -1;
        for (k = 0; k < GW_LOG_N; k++)
            if (categories[i] && strcmp(categories[i], gw_log_category_name(k)) == 0) found = k;
        if (found < 0) {
            GW_LOG_ERR(I, "%s: unknown log category \"%s\"", fn,
                       categories[i] ? categories[i] : "(null)");
            return GW_ERROR;
        }
        if (found == GW_LOG_ALL)
            mask = on ? all : 0u;
        else if (on)
            mask |= 1u << found;
        else
            mask &= ~(1u << found);
    }
    I->log_mask = mask;
    /* logging is on as long as any category is enabled */
    I->logging_on = (on || mask != 0u) ? 1 : 0;
    return GW_OK;
}

#endif /* GW_UNITY_BUILD */
