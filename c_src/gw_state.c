/*
 * gw_state.c -- saving and restoring an instance: one serialised blob, so that a saved
 * state and its serialised form share one code path (the FMI layer's fmi2Get/SetFMUstate
 * and fmi2(De)SerializeFMUstate both use it).  Byte layout, version 3, native byte order,
 * no padding (version 2 of fmi-robust plus the solvers' budget, controller memory and
 * compensation; version 1 had neither the CRC nor t_events):
 *
 *   offset  size       field
 *   0       4          magic "GWST"
 *   4       4          uint32 layout version (GW_STATE_VERSION)
 *   8       4          uint32 total size of the blob in bytes
 *   12      7*4        int32 nx, ns, nu, np, ny, ne, nc
 *   40      4          uint32 L = strlen(model token)
 *   44      L          model token (GUID), no terminating NUL
 *   then    9*4        int32 front[0] (FMI: its state), solver, stop_defined, tol_defined,
 *                            terminated, front[1] (FMI: last fmi2DoStep status and more),
 *                            y_valid, rel_tol_set, abs_tol_set
 *           11*8       double t, t_start, t_stop, tolerance, last_successful_time,
 *                             rel_tol, abs_tol, max_step, max_internal_steps (the budget
 *                             of internal steps per call), h_adapt (adaptive step size),
 *                             err_old (the PI controller's memory: error norm of the last
 *                             accepted step, 0: none)
 *           5*8        uint64 n_rhs, n_accepted, n_rejected, n_evt, n_events
 *           8*nx       double x
 *           8*ns       double s
 *           8*nu       double u
 *           8*np       double p
 *           8*ny       double y
 *           8*ne       double e (event indicators at t, as of the last event update;
 *                             checked against those recomputed from t, x, u, p)
 *           8*nx       double x nominal
 *           8*ne       double t_events (time of each event's last firing)
 *           8*nx       double xc (compensation of the state's summation: x + xc is the
 *                             state to twice the working precision; 0 if x was written
 *                             since the solver left it)
 *           ne         uint8 per event: bit 0 its flag (it has fired); bit 1 it fires in the
 *                             instant whose update is pending (I->ev_fired of a gw_advance
 *                             that stopped before the update, GW_STOP_BEFORE_UPDATE: FMI 3.0
 *                             Co-Simulation's early return for Event Mode), so that the
 *                             update applied after a restore is the one located there.  No
 *                             other front end stops so: their bytes are 0 or 1
 *           4          uint32 CRC-32 (IEEE 802.3, as zlib's crc32) of every byte before it
 *
 * Reading (gw_state_check, gw_state_checks.c) refuses, with the reason logged: a wrong
 * magic, version, size, model sizes or token; a checksum that does not match (every
 * single-bit and burst error up to 32 bits in the blob is caught); and any field outside the range that fmi2Set* and
 * the core accept: non-finite numbers, a solver that does not exist, tolerances, max_step or
 * max_internal_steps outside their ranges (gw_core.h: abs_tol 0 is valid, the budget a
 * whole number), flags that are neither 0 nor 1 (event bytes above 3; bit 1 is checked
 * against the front end's word by gw_state_check_run), non-positive nominals, a negative step
 * size, err_old outside [0, 1] (an accepted step's error norm), a compensation xc_i larger
 * than an ulp of x_i (TwoSum leaves at most half of one).
 * So a restored state is one the instance could have reached itself.  The two front-end
 * ints are the front end's to give meaning to and to validate.  Logging settings are not
 * part of a state.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "gw_instance.h"

#define GW_STATE_MAGIC "GWST"
#define GW_STATE_VERSION 3u
#define GW_STATE_HEADER 44 /* bytes before the model token */
#define GW_STATE_NINT 9
#define GW_STATE_NDBL 11
#define GW_STATE_NU64 5
/* the bits of an event's byte */
#define GW_STATE_FLAG_FIRED 1u
#define GW_STATE_FLAG_PENDING 2u

/* ---- CRC-32 (reflected polynomial 0xEDB88320), bitwise: the blobs are small ------------ */

static uint32_t gw_crc32(const unsigned char *buf, size_t n) {
    uint32_t crc = 0xFFFFFFFFu;
    size_t i;
    int k;
    for (i = 0; i < n; i++) {
        crc ^= buf[i];
        for (k = 0; k < 8; k++) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    return crc ^ 0xFFFFFFFFu;
}

/* ---- the fields after the token, in layout order ---------------------------------------- */

/* The scalar fields as arrays: ints (front[0] and front[1] at 0 and 5), doubles, counters. */
typedef struct {
    int ints[GW_STATE_NINT];
    double dbl[GW_STATE_NDBL];
    unsigned long long u64[GW_STATE_NU64];
} gw_state_scalars;

enum { GW_SI_FRONT0, GW_SI_SOLVER, GW_SI_STOP_DEF, GW_SI_TOL_DEF, GW_SI_TERMINATED,
       GW_SI_FRONT1, GW_SI_Y_VALID, GW_SI_REL_SET, GW_SI_ABS_SET };
enum { GW_SD_T, GW_SD_T_START, GW_SD_T_STOP, GW_SD_TOLERANCE, GW_SD_LAST_TIME, GW_SD_REL_TOL,
       GW_SD_ABS_TOL, GW_SD_MAX_STEP, GW_SD_MAX_INTERNAL_STEPS, GW_SD_H, GW_SD_ERR_OLD };

static void gw_scalars_of(const gw_instance *I, const int front[2], gw_state_scalars *sc) {
    sc->ints[GW_SI_FRONT0] = front[0];
    sc->ints[GW_SI_SOLVER] = I->solver;
    sc->ints[GW_SI_STOP_DEF] = I->stop_defined;
    sc->ints[GW_SI_TOL_DEF] = I->tol_defined;
    sc->ints[GW_SI_TERMINATED] = I->terminated;
    sc->ints[GW_SI_FRONT1] = front[1];
    sc->ints[GW_SI_Y_VALID] = I->y_valid;
    sc->ints[GW_SI_REL_SET] = I->rel_tol_set;
    sc->ints[GW_SI_ABS_SET] = I->abs_tol_set;
    sc->dbl[GW_SD_T] = I->t;
    sc->dbl[GW_SD_T_START] = I->t_start;
    sc->dbl[GW_SD_T_STOP] = I->t_stop;
    sc->dbl[GW_SD_TOLERANCE] = I->tolerance;
    sc->dbl[GW_SD_LAST_TIME] = I->last_successful_time;
    sc->dbl[GW_SD_REL_TOL] = I->rel_tol;
    sc->dbl[GW_SD_ABS_TOL] = I->abs_tol;
    sc->dbl[GW_SD_MAX_STEP] = I->max_step;
    sc->dbl[GW_SD_MAX_INTERNAL_STEPS] = I->max_internal_steps;
    sc->dbl[GW_SD_H] = I->h_adapt;
    sc->dbl[GW_SD_ERR_OLD] = I->err_old;
    sc->u64[0] = I->n_rhs;
    sc->u64[1] = I->n_accepted;
    sc->u64[2] = I->n_rejected;
    sc->u64[3] = I->n_evt;
    sc->u64[4] = I->n_events;
}

/* the vectors of the layout, in order: x, s, u, p, y, e, nominal, t_events, xc */
#define GW_STATE_NVEC 9
#define GW_STATE_VEC_NOMINAL 6
#define GW_STATE_VEC_XC 8
static const char *const gw_vec_names[GW_STATE_NVEC] = {"x", "s", "u", "p", "y", "e", "nominal",
                                                        "t_events", "xc"};

static void gw_vectors_of(const gw_instance *I, double *vec[GW_STATE_NVEC], int len[GW_STATE_NVEC]) {
    const gw_model *m = I->m;
    vec[0] = I->x, len[0] = m->nx;
    vec[1] = I->s, len[1] = m->ns;
    vec[2] = I->u, len[2] = m->nu;
    vec[3] = I->p, len[3] = m->np;
    vec[4] = I->y, len[4] = m->ny;
    vec[5] = I->e, len[5] = m->ne;
    vec[6] = I->nominal, len[6] = m->nx;
    vec[7] = I->t_events, len[7] = m->ne;
    vec[8] = I->xc, len[8] = m->nx;
}

/* xc belongs to the x the solver left (I->xc_x); a front end that wrote x since (Model
 * Exchange) made it stale, and gw_advance would drop it: so does a saved state */
static int gw_xc_stale(const gw_instance *I) {
    return memcmp(I->x, I->xc_x, (size_t)I->m->nx * sizeof(double)) != 0;
}

/* ---- writer -------------------------------------------------------------------------------- */

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

static void gw_write_state(const gw_instance *I, const int front[2], gw_writer *w, size_t total) {
    const gw_model *m = I->m;
    uint32_t L = (uint32_t)strlen(m->token);
    gw_state_scalars sc;
    double *vec[GW_STATE_NVEC];
    int len[GW_STATE_NVEC], i;
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
    gw_scalars_of(I, front, &sc);
    for (i = 0; i < GW_STATE_NINT; i++) gw_put_i32(w, sc.ints[i]);
    gw_put(w, sc.dbl, sizeof(sc.dbl));
    for (i = 0; i < GW_STATE_NU64; i++) {
        uint64_t x = (uint64_t)sc.u64[i];
        gw_put(w, &x, 8);
    }
    gw_vectors_of(I, vec, len);
    for (i = 0; i < GW_STATE_NVEC; i++) {
        if (i == GW_STATE_VEC_XC && gw_xc_stale(I)) {
            const double zero = 0.0;
            int j;
            for (j = 0; j < len[i]; j++) gw_put(w, &zero, 8);
            continue;
        }
        gw_put(w, vec[i], (size_t)len[i] * sizeof(double));
    }
    for (i = 0; i < m->ne; i++) {
        unsigned char f = (unsigned char)((I->flags[i] ? GW_STATE_FLAG_FIRED : 0) |
                                          (I->update_pending && I->ev_fired[i] == 1
                                               ? GW_STATE_FLAG_PENDING : 0));
        gw_put(w, &f, 1);
    }
    if (w->buf) {
        uint32_t crc = gw_crc32(w->buf, w->pos);
        gw_put_u32(w, crc);
    } else {
        w->pos += 4;
    }
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

/* ---- reader -------------------------------------------------------------------------------- */

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

/* a reader at the first field after the model token */
static gw_reader gw_state_body(const gw_instance *I, const unsigned char *buf) {
    gw_reader r;
    r.buf = buf;
    r.pos = GW_STATE_HEADER + strlen(I->m->token);
    return r;
}

/* the scalar fields of a blob whose header was checked; r is left at the first vector */
static void gw_read_scalars(gw_reader *r, gw_state_scalars *sc) {
    int i;
    for (i = 0; i < GW_STATE_NINT; i++) sc->ints[i] = gw_get_i32(r);
    gw_get(r, sc->dbl, sizeof(sc->dbl));
    for (i = 0; i < GW_STATE_NU64; i++) {
        uint64_t x;
        gw_get(r, &x, 8);
        sc->u64[i] = (unsigned long long)x;
    }
}

/* header: magic, version, sizes, token, total size, checksum; 1 or reason logged */
static int gw_state_check_header(gw_instance *I, const char *fn, const unsigned char *buf,
                                 size_t size) {
    const gw_model *m = I->m;
    const size_t expected = gw_state_size(I);
    gw_reader r;
    uint32_t version, total, L, crc;
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
    memcpy(&crc, buf + size - 4, 4);
    if (crc != gw_crc32(buf, size - 4)) {
        GW_LOG_ERR(I, "%s: FMU state is corrupt: its CRC-32 checksum does not match its content",
                   fn);
        return 0;
    }
    return 1;
}

GW_API void gw_state_front(const gw_instance *I, const unsigned char *buf, int front[2]) {
    gw_reader r = gw_state_body(I, buf);
    gw_state_scalars sc;
    gw_read_scalars(&r, &sc);
    front[0] = sc.ints[GW_SI_FRONT0];
    front[1] = sc.ints[GW_SI_FRONT1];
}

GW_API void gw_state_apply(gw_instance *I, const unsigned char *buf) {
    const gw_model *m = I->m;
    gw_reader r = gw_state_body(I, buf);
    gw_state_scalars sc;
    double *vec[GW_STATE_NVEC];
    int len[GW_STATE_NVEC], i;
    gw_read_scalars(&r, &sc);
    I->solver = sc.ints[GW_SI_SOLVER];
    I->stop_defined = sc.ints[GW_SI_STOP_DEF];
    I->tol_defined = sc.ints[GW_SI_TOL_DEF];
    I->terminated = sc.ints[GW_SI_TERMINATED];
    I->y_valid = sc.ints[GW_SI_Y_VALID];
    I->rel_tol_set = sc.ints[GW_SI_REL_SET];
    I->abs_tol_set = sc.ints[GW_SI_ABS_SET];
    I->t = sc.dbl[GW_SD_T];
    I->t_start = sc.dbl[GW_SD_T_START];
    I->t_stop = sc.dbl[GW_SD_T_STOP];
    I->tolerance = sc.dbl[GW_SD_TOLERANCE];
    I->last_successful_time = sc.dbl[GW_SD_LAST_TIME];
    I->rel_tol = sc.dbl[GW_SD_REL_TOL];
    I->abs_tol = sc.dbl[GW_SD_ABS_TOL];
    I->max_step = sc.dbl[GW_SD_MAX_STEP];
    I->max_internal_steps = sc.dbl[GW_SD_MAX_INTERNAL_STEPS];
    gw_solver_select(I); /* auto: the solver the saved settings pick */
    I->h_adapt = sc.dbl[GW_SD_H];
    I->err_old = sc.dbl[GW_SD_ERR_OLD];
    I->n_rhs = sc.u64[0];
    I->n_accepted = sc.u64[1];
    I->n_rejected = sc.u64[2];
    I->n_evt = sc.u64[3];
    I->n_events = sc.u64[4];
    gw_vectors_of(I, vec, len);
    for (i = 0; i < GW_STATE_NVEC; i++) gw_get(&r, vec[i], (size_t)len[i] * sizeof(double));
    I->update_pending = 0;
    for (i = 0; i < m->ne; i++) {
        unsigned char f;
        gw_get(&r, &f, 1);
        I->flags[i] = (f & GW_STATE_FLAG_FIRED) != 0;
        I->ev_fired[i] = (f & GW_STATE_FLAG_PENDING) != 0; /* 1: fires when the update is applied */
        I->update_pending |= I->ev_fired[i];
    }
    memcpy(I->xc_x, I->x, (size_t)m->nx * sizeof(double)); /* xc belongs to this x */
    gw_update_atol_eff(I);
    /* what follows from the rest is computed, not taken from the blob: the outputs when next
     * read (y = out(t, x, u, p)), after the initialisation the nominals (nom(p), checked by
     * gw_state_check_run) */
    I->y_valid = 0;
    if (!I->in_setup) gw_eval_nom(I, I->nominal);
    I->pre_valid = 0; /* p came from the state */
    I->fcur_valid = 0;
    I->k7_valid = 0;
    I->dense_ready = 0;
    I->xdot_valid = 0;
    I->dir_valid = 0;
}

#endif /* GW_UNITY_BUILD */
