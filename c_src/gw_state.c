/*
 * gw_state.c -- FMU states: fmi2Get/Set/FreeFMUstate and their serialisation.
 *
 * An FMU state is one serialised blob (so get/set and (de)serialise share one
 * code path).  Byte layout, version 1, native byte order, no padding:
 *
 *   offset  size       field
 *   0       4          magic "GWST"
 *   4       4          uint32 layout version (GW_STATE_VERSION)
 *   8       4          uint32 total size of the blob in bytes
 *   12      7*4        int32 nx, ns, nu, np, ny, ne, nc
 *   40      4          uint32 L = strlen(model token)
 *   44      L          model token (GUID), no terminating NUL
 *   then    7*4        int32 fmi state, solver, stop_defined, tol_defined, terminated,
 *                            last fmi2DoStep status, y_valid
 *           9*8        double t, t_start, t_stop, tolerance, last_successful_time,
 *                             rel_tol, abs_tol, max_step, h_adapt (DOPRI5 step size)
 *           5*8        uint64 n_rhs, n_accepted, n_rejected, n_evt, n_events
 *           8*nx       double x
 *           8*ns       double s
 *           8*nu       double u
 *           8*np       double p
 *           8*ny       double y
 *           8*ne       double e (event indicators at t)
 *           8*nx       double x nominal
 *           ne         uint8 event flags
 *
 * The fmi state may also be a Model Exchange one (EventMode, ContinuousTimeMode); a
 * state of one interface's own modes is refused by an instance of the other interface
 * (the modes both share -- Instantiated, InitializationMode, Terminated, Error -- hold
 * nothing interface-specific, so the layout needs no interface field).
 *
 * Reading rejects a wrong magic, version, size, model sizes or token with
 * fmi2Error and a logged reason.  Logging settings are not part of the state.
 */
#include <stdint.h>
#include <string.h>

#include "gw_instance.h"

#define GW_STATE_MAGIC "GWST"
#define GW_STATE_VERSION 1u

#define MASK_FMUstate                                                                       \
    (GW_ST_INSTANTIATED | GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED |      \
     GW_ST_TERMINATED | GW_ST_ERROR | GW_ST_EVENT_MODE | GW_ST_CONT_TIME_MODE)

typedef struct {
    size_t size;
    unsigned char data[]; /* size bytes */
} gw_blob;

/* ---- writer / reader ------------------------------------------------------------ */

typedef struct {
    unsigned char *buf; /* NULL: only count */
    size_t pos;
} writer;

static void put(writer *w, const void *src, size_t n) {
    if (w->buf && n) memcpy(w->buf + w->pos, src, n);
    w->pos += n;
}
static void put_u32(writer *w, uint32_t v) { put(w, &v, 4); }
static void put_i32(writer *w, int v) {
    int32_t x = (int32_t)v;
    put(w, &x, 4);
}
static void put_u64(writer *w, unsigned long long v) {
    uint64_t x = (uint64_t)v;
    put(w, &x, 8);
}
static void put_f64(writer *w, double v) { put(w, &v, 8); }
static void put_vec(writer *w, const double *v, int n) { put(w, v, (size_t)n * sizeof(double)); }

static void write_state(const gw_instance *I, writer *w, size_t total) {
    const gw_model *m = I->m;
    uint32_t L = (uint32_t)strlen(m->token);
    int i;
    put(w, GW_STATE_MAGIC, 4);
    put_u32(w, GW_STATE_VERSION);
    put_u32(w, (uint32_t)total);
    put_i32(w, m->nx);
    put_i32(w, m->ns);
    put_i32(w, m->nu);
    put_i32(w, m->np);
    put_i32(w, m->ny);
    put_i32(w, m->ne);
    put_i32(w, m->nc);
    put_u32(w, L);
    put(w, m->token, L);
    put_i32(w, I->state);
    put_i32(w, I->solver);
    put_i32(w, I->stop_defined);
    put_i32(w, I->tol_defined);
    put_i32(w, I->terminated);
    put_i32(w, I->last_dostep_status);
    put_i32(w, I->y_valid);
    put_f64(w, I->t);
    put_f64(w, I->t_start);
    put_f64(w, I->t_stop);
    put_f64(w, I->tolerance);
    put_f64(w, I->last_successful_time);
    put_f64(w, I->rel_tol);
    put_f64(w, I->abs_tol);
    put_f64(w, I->max_step);
    put_f64(w, I->h_adapt);
    put_u64(w, I->n_rhs);
    put_u64(w, I->n_accepted);
    put_u64(w, I->n_rejected);
    put_u64(w, I->n_evt);
    put_u64(w, I->n_events);
    put_vec(w, I->x, m->nx);
    put_vec(w, I->s, m->ns);
    put_vec(w, I->u, m->nu);
    put_vec(w, I->p, m->np);
    put_vec(w, I->y, m->ny);
    put_vec(w, I->e, m->ne);
    put_vec(w, I->nominal, m->nx);
    for (i = 0; i < m->ne; i++) {
        unsigned char f = I->flags[i] ? 1 : 0;
        put(w, &f, 1);
    }
}

static size_t state_size(const gw_instance *I) {
    writer w = {NULL, 0};
    write_state(I, &w, 0);
    return w.pos;
}

typedef struct {
    const unsigned char *buf;
    size_t size, pos;
} reader;

static void get(reader *r, void *dst, size_t n) {
    if (dst && n) memcpy(dst, r->buf + r->pos, n);
    r->pos += n;
}
static uint32_t get_u32(reader *r) {
    uint32_t v;
    get(r, &v, 4);
    return v;
}
static int get_i32(reader *r) {
    int32_t v;
    get(r, &v, 4);
    return (int)v;
}
static unsigned long long get_u64(reader *r) {
    uint64_t v;
    get(r, &v, 8);
    return (unsigned long long)v;
}
static double get_f64(reader *r) {
    double v;
    get(r, &v, 8);
    return v;
}
static void get_vec(reader *r, double *v, int n) { get(r, v, (size_t)n * sizeof(double)); }

/* Validate the header of a serialised state (logs the reason). */
static int check_header(gw_instance *I, const char *fn, const unsigned char *buf, size_t size) {
    const gw_model *m = I->m;
    const size_t expected = state_size(I);
    reader r;
    uint32_t version, total, L;
    int sizes[7], want[7], i;
    if (!buf) {
        GW_ERROR(I, "%s: serialized state is NULL", fn);
        return 0;
    }
    if (size < 44 || memcmp(buf, GW_STATE_MAGIC, 4) != 0) {
        GW_ERROR(I, "%s: not a gyrowheel FMU state (bad magic or too short: %lu bytes)", fn,
                 (unsigned long)size);
        return 0;
    }
    r.buf = buf;
    r.size = size;
    r.pos = 4;
    version = get_u32(&r);
    if (version != GW_STATE_VERSION) {
        GW_ERROR(I, "%s: FMU state layout version %u, this FMU reads version %u", fn,
                 (unsigned)version, (unsigned)GW_STATE_VERSION);
        return 0;
    }
    total = get_u32(&r);
    for (i = 0; i < 7; i++) sizes[i] = get_i32(&r);
    want[0] = m->nx;
    want[1] = m->ns;
    want[2] = m->nu;
    want[3] = m->np;
    want[4] = m->ny;
    want[5] = m->ne;
    want[6] = m->nc;
    for (i = 0; i < 7; i++)
        if (sizes[i] != want[i]) {
            GW_ERROR(I,
                     "%s: FMU state sizes (nx=%d ns=%d nu=%d np=%d ny=%d ne=%d nc=%d) do not "
                     "match this model (nx=%d ns=%d nu=%d np=%d ny=%d ne=%d nc=%d)",
                     fn, sizes[0], sizes[1], sizes[2], sizes[3], sizes[4], sizes[5], sizes[6],
                     want[0], want[1], want[2], want[3], want[4], want[5], want[6]);
            return 0;
        }
    L = get_u32(&r);
    if (L != strlen(m->token) || r.pos + L > size || memcmp(buf + r.pos, m->token, L) != 0) {
        GW_ERROR(I, "%s: FMU state belongs to another model (token mismatch, expected %s)", fn,
                 m->token);
        return 0;
    }
    if (size != expected || (size_t)total != expected) {
        GW_ERROR(I, "%s: FMU state has %lu bytes (header says %lu), expected %lu", fn,
                 (unsigned long)size, (unsigned long)total, (unsigned long)expected);
        return 0;
    }
    return 1;
}

static int valid_fmi_state(int s) {
    return s == GW_ST_INSTANTIATED || s == GW_ST_INIT_MODE || s == GW_ST_STEP_COMPLETE ||
           s == GW_ST_STEP_FAILED || s == GW_ST_TERMINATED || s == GW_ST_ERROR ||
           s == GW_ST_EVENT_MODE || s == GW_ST_CONT_TIME_MODE;
}

/* Apply a validated state to the instance. */
static int apply_state(gw_instance *I, const char *fn, const unsigned char *buf, size_t size) {
    const gw_model *m = I->m;
    reader r;
    int i, st;
    r.buf = buf;
    r.size = size;
    r.pos = 44 + strlen(m->token);
    st = get_i32(&r);
    if (!valid_fmi_state(st)) {
        GW_ERROR(I, "%s: FMU state holds an invalid instance state %d", fn, st);
        return 0;
    }
    if (((st & (GW_ST_EVENT_MODE | GW_ST_CONT_TIME_MODE)) && I->fmu_type != fmi2ModelExchange) ||
        ((st & (GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED)) && I->fmu_type != fmi2CoSimulation)) {
        GW_ERROR(I, "%s: FMU state of a %s instance cannot be set into a %s instance", fn,
                 I->fmu_type == fmi2ModelExchange ? "Co-Simulation" : "Model Exchange",
                 I->fmu_type == fmi2ModelExchange ? "Model Exchange" : "Co-Simulation");
        return 0;
    }
    I->state = st;
    I->solver = get_i32(&r);
    I->stop_defined = get_i32(&r);
    I->tol_defined = get_i32(&r);
    I->terminated = get_i32(&r);
    I->last_dostep_status = get_i32(&r);
    I->y_valid = get_i32(&r);
    I->t = get_f64(&r);
    I->t_start = get_f64(&r);
    I->t_stop = get_f64(&r);
    I->tolerance = get_f64(&r);
    I->last_successful_time = get_f64(&r);
    I->rel_tol = get_f64(&r);
    I->abs_tol = get_f64(&r);
    I->max_step = get_f64(&r);
    I->h_adapt = get_f64(&r);
    I->n_rhs = get_u64(&r);
    I->n_accepted = get_u64(&r);
    I->n_rejected = get_u64(&r);
    I->n_evt = get_u64(&r);
    I->n_events = get_u64(&r);
    get_vec(&r, I->x, m->nx);
    get_vec(&r, I->s, m->ns);
    get_vec(&r, I->u, m->nu);
    get_vec(&r, I->p, m->np);
    get_vec(&r, I->y, m->ny);
    get_vec(&r, I->e, m->ne);
    get_vec(&r, I->nominal, m->nx);
    for (i = 0; i < m->ne; i++) {
        unsigned char f;
        get(&r, &f, 1);
        I->flags[i] = f ? 1 : 0;
    }
    I->fcur_valid = 0;
    I->k7_valid = 0;
    I->dense_ready = 0;
    I->xdot_valid = 0;
    I->dir_valid = 0;
    return 1;
}

static gw_blob *blob_alloc(const gw_instance *I, size_t size) {
    gw_blob *b = (gw_blob *)gw_alloc(I, 1, sizeof(gw_blob) + size);
    if (b) b->size = size;
    return b;
}

/* ---- FMI functions ------------------------------------------------------------ */

/* The blob *FMUstate if it has the right size, else a new one (the old one freed). */
static gw_blob *blob_reuse(gw_instance *I, const char *fn, fmi2FMUstate *FMUstate, size_t size) {
    gw_blob *b = (gw_blob *)*FMUstate;
    if (b && b->size != size) {
        gw_free(I, b);
        b = NULL;
        *FMUstate = NULL;
    }
    if (!b) b = blob_alloc(I, size);
    if (!b) GW_ERROR(I, "%s: out of memory", fn);
    return b;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    gw_instance *I = (gw_instance *)c;
    gw_blob *b;
    size_t size;
    writer w;
    if (!gw_begin(I, "fmi2GetFMUstate", MASK_FMUstate)) return fmi2Error;
    if (!FMUstate) {
        GW_ERROR(I, "fmi2GetFMUstate: FMUstate is NULL");
        return gw_end(I, fmi2Error);
    }
    size = state_size(I);
    b = blob_reuse(I, "fmi2GetFMUstate", FMUstate, size);
    if (!b) return gw_end(I, fmi2Error);
    w.buf = b->data;
    w.pos = 0;
    write_state(I, &w, size);
    *FMUstate = (fmi2FMUstate)b;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    gw_instance *I = (gw_instance *)c;
    const gw_blob *b = (const gw_blob *)FMUstate;
    if (!gw_begin(I, "fmi2SetFMUstate", MASK_FMUstate)) return fmi2Error;
    if (!b) {
        GW_ERROR(I, "fmi2SetFMUstate: FMUstate is NULL");
        return gw_end(I, fmi2Error);
    }
    if (!check_header(I, "fmi2SetFMUstate", b->data, b->size) ||
        !apply_state(I, "fmi2SetFMUstate", b->data, b->size))
        return gw_end(I, fmi2Error);
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    gw_instance *I = (gw_instance *)c;
    if (!gw_begin(I, "fmi2FreeFMUstate", MASK_FMUstate)) return fmi2Error;
    if (FMUstate && *FMUstate) {
        gw_free(I, *FMUstate);
        *FMUstate = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    gw_instance *I = (gw_instance *)c;
    const gw_blob *b = (const gw_blob *)FMUstate;
    if (!gw_begin(I, "fmi2SerializedFMUstateSize", MASK_FMUstate)) return fmi2Error;
    if (!b || !size) {
        GW_ERROR(I, "fmi2SerializedFMUstateSize: FMUstate or size is NULL");
        return gw_end(I, fmi2Error);
    }
    *size = b->size;
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
    gw_instance *I = (gw_instance *)c;
    const gw_blob *b = (const gw_blob *)FMUstate;
    if (!gw_begin(I, "fmi2SerializeFMUstate", MASK_FMUstate)) return fmi2Error;
    if (!b || !serializedState) {
        GW_ERROR(I, "fmi2SerializeFMUstate: FMUstate or serializedState is NULL");
        return gw_end(I, fmi2Error);
    }
    if (size < b->size) {
        GW_ERROR(I, "fmi2SerializeFMUstate: buffer of %lu bytes, %lu needed",
                 (unsigned long)size, (unsigned long)b->size);
        return gw_end(I, fmi2Error);
    }
    memcpy(serializedState, b->data, b->size);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    gw_instance *I = (gw_instance *)c;
    gw_blob *b;
    if (!gw_begin(I, "fmi2DeSerializeFMUstate", MASK_FMUstate)) return fmi2Error;
    if (!FMUstate) {
        GW_ERROR(I, "fmi2DeSerializeFMUstate: FMUstate is NULL");
        return gw_end(I, fmi2Error);
    }
    if (!check_header(I, "fmi2DeSerializeFMUstate", (const unsigned char *)serializedState, size))
        return gw_end(I, fmi2Error);
    b = blob_reuse(I, "fmi2DeSerializeFMUstate", FMUstate, size);
    if (!b) return gw_end(I, fmi2Error);
    memcpy(b->data, serializedState, size);
    *FMUstate = (fmi2FMUstate)b;
    return fmi2OK;
}
