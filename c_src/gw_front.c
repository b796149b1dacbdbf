/*
 * gw_front.c -- the pieces the FMI 2.0 and FMI 3.0 layers share (gw_front.h).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>
#include <string.h>

#include "gw_front.h"

GW_INTERNAL void gw_front_escape(char *buf, size_t size, const char *raw) {
    size_t i, j = 0;
    for (i = 0; raw[i] != '\0' && j + 2 < size; i++) {
        if (raw[i] == '%') buf[j++] = '%';
        buf[j++] = raw[i];
    }
    buf[j] = '\0';
}

GW_INTERNAL unsigned long long gw_front_hash(const char *text, int status) {
    unsigned long long h = 14695981039346656037ULL ^ (unsigned long long)(unsigned)status;
    for (; *text; text++) {
        h ^= (unsigned char)*text;
        h *= 1099511628211ULL;
    }
    return h;
}

GW_INTERNAL GW_MAYBE_UNUSED const char *gw_front_stop_reason(const gw_instance *I) {
    const gw_model *m = I->m;
    int i;
    for (i = 0; i < m->ne; i++)
        if (gw_event_ended(I, i) && m->event_names && m->event_names[i])
            return m->event_names[i];
    return "a terminating event";
}

GW_INTERNAL gw_status gw_front_copy_finite(gw_instance *I, const char *fn, double *dst,
                                           const double *src, size_t n, const char *what,
                                           const char *const *names) {
    size_t i;
    for (i = 0; i < n; i++)
        if (!isfinite(src[i])) {
            GW_LOG_NONFINITE(I, "%s: %s %s is not finite (%g) at t=%.17g; nothing returned", fn,
                             what, names && names[i] ? names[i] : "", src[i], I->t);
            return I->nonfinite_status;
        }
    if (n > 0) memcpy(dst, src, n * sizeof(double));
    return GW_OK;
}

#endif /* GW_UNITY_BUILD */
