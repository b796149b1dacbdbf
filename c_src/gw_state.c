/*
 * gw_state.c -- saving and restoring an instance: one serialised blob, so that a saved
 * state and its serialised form share one code path (the FMI layer's fmi2Get/SetFMUstate
 * and fmi2(De)SerializeFMUstate both use it).  Byte layout, version 2, native byte order,
 * no padding:
 *
 *   offset  size       field
 *   0       4          magic "GWST"
 *   4       4          uint32 layout version (GW_STATE_VERSION)
 *   8       4          uint32 total size of the blob in bytes
 *   12      7*4        int32 nx, ns, nu, np, ny, ne, nc
 *   40      4          uint32 L = strlen(model token)
 *   44      L          model token (GUID), no terminating NUL
 *   then    7*4        int32 front[0] (FMI: its state), solver, stop_defined, tol_defined,
 *                            terminated, front[1] (FMI: last fmi2DoStep status), y_valid
 *           9*8        double t, t_start, t_stop, tolerance, last_successful_time,
 *                             rel_tol, abs_tol, max_step, h_adapt (adaptive step size)
 *           5*8        uint64 n_rhs, n_accepted, n_rejected, n_evt, n_events
 *           8*nx       double x
 *           8*ns       double s
 *           8*nu       double u
 *           8*np       double p
 *           8*ny       double y
 *           8*ne       double e (event indicators at t)
 *           8*nx       double x nominal
 *           ne         uint8 event flags
 *           2*8        double max_internal_steps, err_old (the PI controller's memory)
 *           8*nx       double xc (compensation of the state's summation)
 *
 * The two front-end ints are the front end's to give meaning to and to validate (the set-up
 * phase flag I->in_setup follows from them there).  Reading rejects a wrong magic, version,
 * size, model sizes or token with a logged reason.  Logging settings are not part of it.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <stdint.h>
#include <string.h>

#include "gw_instance.h"

#define GW_STATE_MAGIC "GWST"
#define GW_STATE_VERSION 2u
#define GW_STATE_HEADER 44 /* bytes before the model token */

/* ---- writer / reader ------------------------------------------------------------ */

typedef struct {
    unsigned char *buf; /* NULL: only count */
    size_t pos;
} gw_writer;

static void gw_put(gw_writer *w, const void *src, size_t n) {
    if (w->buf && n) memcpy(w->buf + w->pos, src, n);
    w->pos += n;
}
static void gw_put_u32(gw_writer *w, uint32_t v) { gw_put(w, &v, 4); }
static void gw_put_i32(gw_writer *w, int v) {
    int32_t x = (int32_t)v;
    gw_put(w, &x, 4);
}
static void gw_put_u64(gw_writer *w, unsigned long long v) {
    uint64_t x = (uint64_t)v;
    gw_put(w, &x, 8);
}
static void gw_put_f64(gw_writer *w, double v) { gw_put(w, &v, 8); }
static void gw_put_vec(gw_writer *w, const double *v, int n) {
    gw_put(w, v, (size_t)n * sizeof(double));
}

static void gw_write_state(const gw_instance *I, const int front[2], gw_writer *w, size_t total) {
    const gw_model *m = I->m;
    uint32_t L = (uint32_t)strlen(m->token);
    int i;
    gw_put(w, GW_STATE_MAGIC, 4);
    gw_put_u32(w, GW_STATE_VERSION);
    gw_put_u32(w, (uint32_t)total);
    gw_put_i32(w, m->nx);
    gw_put_i32(w, m->ns);
    gw_put_i32(w, m->nu);
    gw_put_i32(w, m->np);
    gw_put_i32(w, m->ny);
    gw_put_i32(w, m->ne);
    gw_put_i32(w, m->nc);
    gw_put_u32(w, L);
    gw_put(w, m->token, L);
    gw_put_i32(w, front[0]);
    gw_put_i32(w, I->solver);
    gw_put_i32(w, I->stop_defined);
    gw_put_i32(w, I->tol_defined);
    gw_put_i32(w, I->terminated);
    gw_put_i32(w, front[1]);
    gw_put_i32(w, I->y_valid);
    gw_put_f64(w, I->t);
    gw_put_f64(w, I->t_start);
    gw_put_f64(w, I->t_stop);
    gw_put_f64(w, I->tolerance);
    gw_put_f64(w, I->last_successful_time);
    gw_put_f64(w, I->rel_tol);
    gw_put_f64(w, I->abs_tol);
    gw_put_f64(w, I->max_step);
    gw_put_f64(w, I->h_adapt);
    gw_put_u64(w, I->n_rhs);
    gw_put_u64(w, I->n_accepted);
    gw_put_u64(w, I->n_rejected);
    gw_put_u64(w, I->n_evt);
    gw_put_u64(w, I->n_events);
    gw_put_vec(w, I->x, m->nx);
    gw_put_vec(w, I->s, m->ns);
    gw_put_vec(w, I->u, m->nu);
    gw_put_vec(w, I->p, m->np);
    gw_put_vec(w, I->y, m->ny);
    gw_put_vec(w, I->e, m->ne);
    gw_put_vec(w, I->nominal, m->nx);
    for (i = 0; i < m->ne; i++) {
        unsigned char f = I->flags[i] ? 1 : 0;
        gw_put(w, &f, 1);
    }
    gw_put_f64(w, I->max_internal_steps);
    gw_put_f64(w, I->err_old);
    gw_put_vec(w, I->xc, m->nx);
}

GW_API size_t gw_state_size(const gw_instance *I) {
    const int front[2] = {0, 0};
    gw_writer w = {NULL, 0};
    gw_write_state(I, front, &w, 0);
    return w.pos;
}

GW_API void gw_state_write(const gw_instance *I, const int front[2], unsigned char *buf) {
    gw_writer w;
    w.buf = buf;
    w.pos = 0;
    gw_write_state(I, front, &w, gw_state_size(I));
}

typedef struct {
    const unsigned char *buf;
    size_t pos;
} gw_reader;

static void gw_get(gw_reader *r, void *dst, size_t n) {
    if (dst && n) memcpy(dst, r->buf + r->pos, n);
    r->pos += n;
}
static uint32_t gw_get_u32(gw_reader *r) {
    uint32_t v;
    gw_get(r, &v, 4);
    return v;
}
static int gw_get_i32(gw_reader *r) {
    int32_t v;
    gw_get(r, &v, 4);
    return (int)v;
}
static unsigned long long gw_get_u64(gw_reader *r) {
    uint64_t v;
    gw_get(r, &v, 8);
    return (unsigned long long)v;
}
static double gw_get_f64(gw_reader *r) {
    double v;
    gw_get(r, &v, 8);
    return v;
}
static void gw_get_vec(gw_reader *r, double *v, int n) { gw_get(r, v, (size_t)n * sizeof(double)); }

GW_API int gw_state_check(gw_instance *I, const char *fn, const unsigned char *buf, size_t size) {
    const gw_model *m = I->m;
    const size_t expected = gw_state_size(I);
    gw_reader r;
    uint32_t version, total, L;
    int sizes[7], want[7], i;
    if (!buf) {
        GW_LOG_ERR(I, "%s: serialized state is NULL", fn);
        return 0;
    }
    if (size < GW_STATE_HEADER || memcmp(buf, GW_STATE_MAGIC, 4) != 0) {
        GW_LOG_ERR(I, "%s: not a gyrowheel FMU state (bad magic or too short: %lu bytes)", fn,
                   (unsigned long)size);
        return 0;
    }
    r.buf = buf;
    r.pos = 4;
    version = gw_get_u32(&r);
    if (version != GW_STATE_VERSION) {
        GW_LOG_ERR(I, "%s: FMU state layout version %u, this FMU reads version %u", fn,
                   (unsigned)version, (unsigned)GW_STATE_VERSION);
        return 0;
    }
    total = gw_get_u32(&r);
    for (i = 0; i < 7; i++) sizes[i] = gw_get_i32(&r);
    want[0] = m->nx;
    want[1] = m->ns;
    want[2] = m->nu;
    want[3] = m->np;
    want[4] = m->ny;
    want[5] = m->ne;
    want[6] = m->nc;
    for (i = 0; i < 7; i++)
        if (sizes[i] != want[i]) {
            GW_LOG_ERR(I,
                       "%s: FMU state sizes (nx=%d ns=%d nu=%d np=%d ny=%d ne=%d nc=%d) do not "
                       "match this model (nx=%d ns=%d nu=%d np=%d ny=%d ne=%d nc=%d)",
                       fn, sizes[0], sizes[1], sizes[2], sizes[3], sizes[4], sizes[5], sizes[6],
                       want[0], want[1], want[2], want[3], want[4], want[5], want[6]);
            return 0;
        }
    L = gw_get_u32(&r);
    if (L != strlen(m->token) || r.pos + L > size || memcmp(buf + r.pos, m->token, L) != 0) {
        GW_LOG_ERR(I, "%s: FMU state belongs to another model (token mismatch, expected %s)", fn,
                   m->token);
        return 0;
    }
    if (size != expected || (size_t)total != expected) {
        GW_LOG_ERR(I, "%s: FMU state has %lu bytes (header says %lu), expected %lu", fn,
                   (unsigned long)size, (unsigned long)total, (unsigned long)expected);
        return 0;
    }
    return 1;
}

/* a reader at the first field after the model token */
static gw_reader gw_state_body(const gw_instance *I, const unsigned char *buf) {
    gw_reader r;
    r.buf = buf;
    r.pos = GW_STATE_HEADER + strlen(I->m->token);
    return r;
}

GW_API void gw_state_front(const gw_instance *I, const unsigned char *buf, int front[2]) {
    gw_reader r = gw_state_body(I, buf);
    front[0] = gw_get_i32(&r);
    r.pos += 4 * 4; /* solver, stop_defined, tol_defined, terminated */
    front[1] = gw_get_i32(&r);
}

GW_API void gw_state_apply(gw_instance *I, const unsigned char *buf) {
    const gw_model *m = I->m;
    gw_reader r = gw_state_body(I, buf);
    int i;
    (void)gw_get_i32(&r); /* front[0] */
    I->solver = gw_get_i32(&r);
    I->stop_defined = gw_get_i32(&r);
    I->tol_defined = gw_get_i32(&r);
    I->terminated = gw_get_i32(&r);
    (void)gw_get_i32(&r); /* front[1] */
    I->y_valid = gw_get_i32(&r);
    I->t = gw_get_f64(&r);
    I->t_start = gw_get_f64(&r);
    I->t_stop = gw_get_f64(&r);
    I->tolerance = gw_get_f64(&r);
    I->last_successful_time = gw_get_f64(&r);
    I->rel_tol = gw_get_f64(&r);
    I->abs_tol = gw_get_f64(&r);
    I->max_step = gw_get_f64(&r);
    I->h_adapt = gw_get_f64(&r);
    I->n_rhs = gw_get_u64(&r);
    I->n_accepted = gw_get_u64(&r);
    I->n_rejected = gw_get_u64(&r);
    I->n_evt = gw_get_u64(&r);
    I->n_events = gw_get_u64(&r);
    gw_get_vec(&r, I->x, m->nx);
    gw_get_vec(&r, I->s, m->ns);
    gw_get_vec(&r, I->u, m->nu);
    gw_get_vec(&r, I->p, m->np);
    gw_get_vec(&r, I->y, m->ny);
    gw_get_vec(&r, I->e, m->ne);
    gw_get_vec(&r, I->nominal, m->nx);
    for (i = 0; i < m->ne; i++) {
        unsigned char f;
        gw_get(&r, &f, 1);
        I->flags[i] = f ? 1 : 0;
    }
    I->max_internal_steps = gw_get_f64(&r);
    I->err_old = gw_get_f64(&r);
    gw_get_vec(&r, I->xc, m->nx);
    memcpy(I->xc_x, I->x, (size_t)m->nx * sizeof(double));
    I->atol_eff = I->abs_tol > 0.0 ? I->abs_tol : GW_ATOL_PER_RTOL * I->rel_tol;
    I->pre_valid = 0; /* p came from the state */
    I->fcur_valid = 0;
    I->k7_valid = 0;
    I->dense_ready = 0;
    I->xdot_valid = 0;
    I->dir_valid = 0;
}

#endif /* GW_UNITY_BUILD */
