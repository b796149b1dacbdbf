/*
 * gw_log.c -- logging through the importer's logger callback.
 *
 * Categories (modelDescription.xml <LogCategories>): logEvents, logSolver,
 * logStatusWarning, logStatusError, logStatusFatal, logAll.
 * Rule: fmi2Error / fmi2Fatal messages always reach the logger (if there is one);
 * every other message only when debug logging is on and its category (or logAll)
 * is enabled.  Callers test gw_log_enabled() before formatting expensive messages.
 */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "gw_instance.h"

static const char *category_name(int cat) {
    switch (cat) {
    case GW_LOG_EVENTS: return "logEvents";
    case GW_LOG_SOLVER: return "logSolver";
    case GW_LOG_WARNING: return "logStatusWarning";
    case GW_LOG_ERROR: return "logStatusError";
    case GW_LOG_FATAL: return "logStatusFatal";
    default: return "logAll";
    }
}

int gw_log_enabled(const gw_instance *I, gw_log_category cat) {
    if (!I || !I->cb.logger || !I->logging_on) return 0;
    return (I->log_mask & ((1u << cat) | (1u << GW_LOG_ALL))) != 0;
}

/* Format into buf and escape '%' (the importer treats the message as a format). */
static void format_message(char *buf, size_t size, const char *fmt, va_list ap) {
    char raw[1024];
    size_t i, j = 0;
    vsnprintf(raw, sizeof(raw), fmt, ap);
    for (i = 0; raw[i] != '\0' && j + 2 < size; i++) {
        if (raw[i] == '%') buf[j++] = '%';
        buf[j++] = raw[i];
    }
    buf[j] = '\0';
}

static void vlog_cb(const gw_callbacks *cb, const char *name, fmi2Status status,
                    const char *category, const char *fmt, va_list ap) {
    char buf[2048];
    if (!cb || !cb->logger) return;
    format_message(buf, sizeof(buf), fmt, ap);
    cb->logger(cb->componentEnvironment, name ? name : "", status, category, buf);
}

void gw_log_cb(const gw_callbacks *cb, const char *name, fmi2Status status,
               const char *category, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vlog_cb(cb, name, status, category, fmt, ap);
    va_end(ap);
}

void gw_log(const gw_instance *I, fmi2Status status, gw_log_category cat, const char *fmt, ...) {
    va_list ap;
    int always = (status == fmi2Error || status == fmi2Fatal);
    if (!I || !I->cb.logger) return;
    if (!always && !gw_log_enabled(I, cat)) return;
    if (status == fmi2Fatal) cat = GW_LOG_FATAL;
    va_start(ap, fmt);
    vlog_cb(&I->cb, I->name, status, category_name(cat), fmt, ap);
    va_end(ap);
}

fmi2Status gw_set_debug_logging(gw_instance *I, fmi2Boolean on, size_t n,
                                const fmi2String categories[]) {
    size_t i;
    unsigned int mask = I->log_mask;
    const unsigned int all = (1u << GW_LOG_N) - 1u;
    if (n == 0) {
        I->logging_on = on ? 1 : 0;
        I->log_mask = on ? all : 0u;
        return fmi2OK;
    }
    if (!categories) {
        GW_ERROR(I, "fmi2SetDebugLogging: categories is NULL but nCategories = %lu",
                 (unsigned long)n);
        return fmi2Error;
    }
    for (i = 0; i < n; i++) {
        int k, found = -1;
        for (k = 0; k < GW_LOG_N; k++)
            if (categories[i] && strcmp(categories[i], category_name(k)) == 0) found = k;
        if (found < 0) {
            GW_ERROR(I, "fmi2SetDebugLogging: unknown log category \"%s\"",
                     categories[i] ? categories[i] : "(null)");
            return fmi2Error;
        }
        if (found == GW_LOG_ALL)
            mask = on ? all : 0u;
        else if (on)
            mask |= 1u << found;
        else
            mask &= ~(1u << found);
    }
    I->log_mask = mask;
    /* debug logging is on as long as any category is enabled */
    I->logging_on = (on || mask != 0u) ? 1 : 0;
    return fmi2OK;
}
