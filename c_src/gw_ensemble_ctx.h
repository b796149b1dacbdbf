/*
 * gw_ensemble_ctx.h -- the memory of the ensemble path kept between runs (part of gw_ensemble.c,
 * included by it once, after the gw_ensemble struct): the context's lanes' instances and batch
 * arrays, gw_ensemble_new and gw_ensemble_free (gw_ensemble.h).  Every allocation through the
 * caller's callbacks.
 */
#ifndef GW_ENSEMBLE_CTX_H
#define GW_ENSEMBLE_CTX_H

static void *gw_ens_alloc(const gw_callbacks *cb, size_t n) {
    void *p = cb->allocate(n > 0 ? n : 1, sizeof(double));
    if (p) memset(p, 0, (n > 0 ? n : 1) * sizeof(double));
    return p;
}

/* What a run needs beyond the job, kept between runs (gw_ensemble_new): the lanes' instances
 * (made when a job first needs them; each trajectory resets its lane's instance, as within a
 * run) and the batch memory, its series blocks sized for orders up to GW_TAYLOR_MAX_ORDER.
 * Made and freed by every run, they were most of a run's fixed cost (0.034 ms of C at N = 4,
 * half of it allocating, zeroing and freeing). */
struct gw_ensemble_ctx {
    gw_ensemble E;
    gw_callbacks cb; /* allocate and free of everything here; the logger is each run's */
};
enum { GW_ENS_ARRAYS = 13 };

/* the batch memory's arrays and their lengths (doubles) */
static void gw_ens_arrays(gw_ensemble *E, double **a[GW_ENS_ARRAYS], size_t n[GW_ENS_ARRAYS]) {
    const gw_model *m = E->m;
    const size_t L = GW_ENS_LANES, nx = (size_t)m->nx * L;
    int k;
    a[0] = &E->wb[0], a[1] = &E->wb[1], a[2] = &E->c, a[3] = &E->x, a[4] = &E->u, a[5] = &E->p;
    a[6] = &E->fsn, a[7] = &E->anom, a[8] = &E->dp, a[9] = &E->qx;
    a[10] = &E->xa, a[11] = &E->xca, a[12] = &E->xcn;
    n[0] = n[1] = (size_t)m->taylor.n_var * (GW_TAYLOR_MAX_ORDER + 1) * L;
    n[2] = (size_t)m->taylor.n_cst * L, n[4] = (size_t)m->nu * L, n[5] = (size_t)m->np * L;
    for (k = 3; k < GW_ENS_ARRAYS; k++)
        if (k != 4 && k != 5) n[k] = nx;
}

GW_API void gw_ensemble_free(gw_ensemble_ctx *C) {
    double **a[GW_ENS_ARRAYS];
    size_t n[GW_ENS_ARRAYS];
    int k;
    if (!C) return;
    for (k = 0; k < GW_ENS_LANES; k++)
        if (C->E.lane[k].I) gw_instance_free(C->E.lane[k].I);
    gw_ens_arrays(&C->E, a, n);
    for (k = 0; k < GW_ENS_ARRAYS; k++)
        if (*a[k]) C->cb.free(*a[k]);
    C->cb.free(C);
}

GW_API gw_ensemble_ctx *gw_ensemble_new(const gw_model *m, const gw_callbacks *cb) {
    gw_ensemble_ctx *C = (gw_ensemble_ctx *)cb->allocate(1, sizeof *C);
    double **a[GW_ENS_ARRAYS];
    size_t n[GW_ENS_ARRAYS];
    int k, ok = 1;
    (void)gw_tlb_jet; /* unused: the batch reads gw_tlb_series's layout in place (GW_ENS_SO) */
    if (!C) return NULL;
    memset(C, 0, sizeof *C);
    C->cb = *cb;
    C->E.m = m;
    gw_ens_arrays(&C->E, a, n);
    for (k = 0; k < GW_ENS_ARRAYS; k++) ok &= (*a[k] = (double *)gw_ens_alloc(cb, n[k])) != NULL;
    for (k = 0; ok && k < 2; k++) /* room: n_var >= the kernel's row + 1 series (gw_tlb_jet) */
        C->E.wa[k] = (double *)(void *)(((uintptr_t)C->E.wb[k] + GW_ENS_ALIGN - 1u) &
                                        ~(uintptr_t)(GW_ENS_ALIGN - 1u));
    if (ok) return C;
    gw_ensemble_free(C);
    return NULL;
}

#endif /* GW_ENSEMBLE_CTX_H */
