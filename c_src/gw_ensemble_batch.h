/*
 * gw_ensemble_batch.h -- the batch's step, lane-innermost (part of gw_ensemble.c, included by it
 * once, after gw_ens_after and the lanes' helpers).
 *
 * After the batch kernel every active lane concludes its pending attempt (the defect check) and
 * attempts its next step from the new series.  The arithmetic over the series, the norms of the
 * step size, the defects, the increments' Horner sums and the compensated updates, runs for all
 * lanes at once, loops over the lanes innermost on the structure-of-arrays series, so that the
 * compiler vectorises them (gw_ensemble_passes.h); the same operations in the same order as the
 * one-lane code of solver taylor (gw_taylor_step, gw_taylor_defect, gw_taylor_increment,
 * gw_sum_update), so each lane's numbers are those of its single run bit for bit.
 *
 * The control: the ordinary lane-step (its attempt accepted by the defect check, finite, no event
 * indicator changing sign, its next attempt within max_step, the budget and the guards, not
 * landing on the call's target) is concluded and attempted here inline (gw_ens_fast_accept,
 * gw_ens_fast_attempt: the bookkeeping of gw_taylor_conclude_err, gw_accept_step,
 * gw_taylor_attempt_size and gw_next_attempt for that case, nothing else), the lane's states
 * staying in the batch's columns (L->soa); every other lane-step (a rejection, an event, a
 * communication point, a landing step, the budget, an error, a new trajectory) goes through the
 * solver code after gw_ens_sync has put the lane's states back into its instance.  The per-lane
 * calls were about 20% of a run at rel_tol 1e-4, the updates' strided stores 3.5%.
 */
#ifndef GW_ENSEMBLE_BATCH_H
#define GW_ENSEMBLE_BATCH_H

/* 1: each lane's numbers from the one-lane code instead of the passes (through I->tl_w), every
 * lane-step through the solver code, for tests/test_ensemble_runs.py::
 * test_ensemble_lane_innermost_passes_equal_the_per_lane_code */
#ifndef GW_ENSEMBLE_LANE_STEPS
#define GW_ENSEMBLE_LANE_STEPS 0
#endif

#include "gw_ensemble_passes.h"

/* Lane l's states from the batch's columns into its instance, where the solver code reads them:
 * soa 1, a pending attempt of the passes: x, xc in E->xa, E->xca, xnew, xcnew in E->x, E->xcn;
 * soa 2, a step accepted here (no attempt yet): x, xc in E->x, E->xcn. */
static void gw_ens_sync(gw_ensemble *E, int l) {
    gw_lane *L = &E->lane[l];
    gw_instance *I = L->I;
    const size_t W = GW_ENS_LANES;
    int i;
    if (!L->soa) return;
    for (i = 0; i < E->m->nx; i++) {
        const size_t at = (size_t)i * W + (size_t)l;
        if (L->soa == 1) {
            I->x[i] = E->xa[at];
            I->xc[i] = E->xca[at];
            I->xnew[i] = E->x[at];
            I->xcnew[i] = E->xcn[at];
        } else {
            I->x[i] = E->x[at];
            I->xc[i] = E->xcn[at];
        }
    }
    L->soa = 0;
}

/* Lane L's pending attempt (its states in the columns, soa 1) concluded as gw_taylor_conclude_err
 * and gw_accept_step conclude an accepted, finite step without an event that ends before the
 * call's target (their other effects: none in that case); the accepted state stays in the columns
 * (soa 2).  0 if the lane-step is not
 * that ordinary one (nothing changed: the solver code concludes it). */
static int gw_ens_fast_accept(gw_ensemble *E, gw_lane *L, double target, double err, double d1) {
    gw_instance *I = L->I;
    const int ne = E->m->ne;
    int i;
    if (GW_ENSEMBLE_LANE_STEPS || L->soa != 1 || !(err <= 1.0) || d1 != 0.0 || I->k7_valid ||
        (ne > 0 && !I->enew_ready) || !(L->t1 < target))
        return 0;
    for (i = 0; i < ne; i++) /* gw_events_check's test of a sign change */
        if (I->e[i] > 0.0 && !(I->enew[i] > 0.0)) return 0;
    L->run.steps++;
    I->n_accepted++;
    I->dense_t0 = I->t;
    I->dense_h = L->t1 - I->t;
    I->dense_ready = 0;
    if (ne > 0) {
        double *tmp = I->e;
        I->enew_ready = 0;
        I->n_evt++;
        I->e = I->enew;
        I->enew = tmp;
    }
    I->t = L->t1;
    I->fcur_valid = 0;
    L->soa = 2;
    L->steps = L->run.steps;
    return 1;
}

/* Lane L's next attempt from its step size hs (the passes' norms n1, n2; d1 = 0: its series
 * finite in orders 0 and 1) as gw_taylor_attempt_size and gw_next_attempt make it when it is
 * not the call's last, the budget is not spent, its projection is within the budget and the
 * step advances time.  0 if not that case (nothing changed: the solver code attempts it). */
static int gw_ens_fast_attempt(gw_lane *L, double target, double n1, double n2, double hs,
                               double d1) {
    gw_instance *I = L->I;
    double h, remaining;
    if (GW_ENSEMBLE_LANE_STEPS || d1 != 0.0 || !(n1 <= DBL_MAX) || !(n2 <= DBL_MAX)) return 0;
    h = hs < I->max_step ? hs : I->max_step; /* h_adapt, and the attempt's h */
    remaining = target - I->t;
    if (1.01 * h >= remaining || (double)I->n_call_steps >= I->max_internal_steps ||
        remaining > GW_PROJECTION_MARGIN * (I->max_internal_steps - (double)(I->n_call_steps + 1)) * h ||
        h < gw_h_min(I->t) || !(I->t + h > I->t))
        return 0;
    I->h_adapt = h;
    I->n_call_steps++;
    L->run.n_fast = 0;
    L->h = h;
    L->t1 = I->t + h;
    return 1;
}

/* Every active lane after the batch kernel: conclude (defects from the pass), then, where the
 * series is the lane's new one, its next attempt (norms and increments from the passes). */
static void gw_ens_batch_steps(gw_ensemble *E, int order) {
    enum { W = GW_ENS_LANES };
    const size_t SI = GW_ENS_SI, SO = GW_ENS_SO;
    const int nx = E->m->nx;
    double n1[W], n2[W], d1[W], hs[W], scale[W], err[W], h[W], acc[W];
    int go[W], last[W], l, i, any = 0;
    gw_ens_norms(E->w, SI, SO, E->fsn, nx, order, E->lc, n1, n2, d1, hs);
    for (l = 0; l < W; l++) scale[l] = E->lane[l].pending ? E->lane[l].h / (order + 1) : 0.0;
    gw_ens_defects(E->w, SI, SO, E->dp, E->x, E->anom, nx, E->job->rel_tol, scale, err);
    for (l = 0; l < W; l++) {
        gw_lane *L = &E->lane[l];
        gw_instance *I = L->I;
        const long traj = L->traj;
        int fresh = 1;
        go[l] = 0;
        h[l] = 0.0;
        if (traj < 0) continue;
        if (L->pending) {
            const double target = gw_ens_target(E, L);
            gw_int_result r;
#if defined(GW_TL_HAS_EVT) && GW_TL_HAS_EVT && GW_TAYLOR_KERNEL_EVT
            if (E->m->ne > 0 && gw_eval_pre(I) == 0) { /* the indicators at (t1, xnew) */
                gw_tlb_evt(E->w + l, L->t1, I->u, I->p, I->pre_c, I->enew);
                I->enew_ready = 1;
            }
#endif
            L->pending = 0;
            if (gw_ens_fast_accept(E, L, target, err[l], d1[l])) {
                go[l] = 1; /* the series at its new point, in this batch's block */
                L->ser = E->w + l;
                continue;
            }
            gw_ens_sync(E, l);
            if (GW_ENSEMBLE_LANE_STEPS || err[l] > 1.0) gw_ens_fetch(I, L); /* retries read it */
            r = GW_ENSEMBLE_LANE_STEPS
                    ? gw_taylor_conclude(I, target, &L->run, L->h, L->t1, E->w + SO + l, SI, &fresh)
                    : gw_taylor_conclude_err(I, target, &L->run, L->h, L->t1, err[l], 1, &fresh);
            I->enew_ready = 0;
            L->ser = NULL; /* the series of the point before: no longer the lane's */
            if (!gw_ens_after(E, L, r, target)) fresh = 0;
        }
        if (L->traj != traj || !fresh) continue; /* ended, or the state moved: a new series */
        go[l] = 1;
        L->ser = E->w + l;
    }
    for (l = 0; l < W; l++) {
        gw_lane *L = &E->lane[l];
        gw_instance *I = L->I;
        double target;
        if (!go[l]) continue;
        go[l] = 0;
        last[l] = 0;
        target = gw_ens_target(E, L);
        if (!gw_ens_fast_attempt(L, target, n1[l], n2[l], hs[l], d1[l])) {
            const double norms[4] = {n1[l], n2[l], hs[l], d1[l] == 0.0};
            gw_int_result r;
            gw_ens_sync(E, l);
            if (GW_ENSEMBLE_LANE_STEPS)
                gw_ens_fetch(I, L);
            else if (d1[l] != 0.0) /* a derivative not finite: gw_taylor_attempt_size names it */
                for (i = 0; i < nx; i++)
                    I->tl_w[(size_t)i * (size_t)(order + 1) + 1] = E->w[(size_t)i * SI + SO + l];
            r = gw_taylor_attempt_size(I, target, &L->run, GW_ENSEMBLE_LANE_STEPS ? NULL : norms,
                                       &L->h, &L->t1, &last[l]);
            if (r != GW_INT_OK) {
                gw_ens_after(E, L, r, target);
                continue;
            }
        }
        go[l] = 1;
        h[l] = L->h;
        any = 1;
    }
    if (!any) return;
    /* P'(h) of every lane into E->dp, where the next batch's defect pass reads it: E->dp's
     * columns were read by this batch's defects above (and the lanes' not going on are not
     * pending, so their columns are written again by gw_ens_point before they are read) */
    gw_ens_increments(E->w, SI, SO, nx, order, h, E->qx, E->dp);
    if (!GW_ENSEMBLE_LANE_STEPS) {
        for (l = 0; l < W; l++) { /* x, xc of each lane going on into the columns E->xa, xca */
            const gw_instance *I = E->lane[l].I;
            acc[l] = go[l] && E->lane[l].soa == 2; /* accepted here: in E->x, E->xcn */
            if (go[l] && !E->lane[l].soa)
                for (i = 0; i < nx; i++) {
                    E->xa[(size_t)i * W + l] = I->x[i];
                    E->xca[(size_t)i * W + l] = I->xc[i];
                }
        }
        /* xnew, xcnew of every lane (the lanes not going on: unused values) */
        gw_ens_sum_updates(E->qx, acc, nx, E->xa, E->xca, E->x, E->xcn);
    }
    for (l = 0; l < W; l++) {
        gw_lane *L = &E->lane[l];
        gw_instance *I = L->I;
        if (!go[l]) continue;
        if (GW_ENSEMBLE_LANE_STEPS) {
            gw_taylor_increment(I->tl_w, order, 1, 0, nx, L->h, I->dx, I->k[2]);
            gw_sum_update(I);
        }
        L->soa = !GW_ENSEMBLE_LANE_STEPS; /* its states in the columns */
        if (!last[l]) { /* its point and P'(h) in the batch's columns already (2) */
            L->pending = GW_ENSEMBLE_LANE_STEPS ? 1 : 2;
        } else { /* a step landing on the call's target: checked with the right-hand side */
            const double target = gw_ens_target(E, L);
            int fresh;
            gw_ens_sync(E, l);
            gw_ens_fetch(I, L); /* its retries and event location read the series */
            if (!GW_ENSEMBLE_LANE_STEPS) gw_ens_dp_copy(E, l); /* P'(h) for gw_taylor_defect */
            gw_ens_after(E, L, gw_taylor_conclude(I, target, &L->run, L->h, L->t1, NULL, 1, &fresh),
                         target);
        }
    }
}

#endif /* GW_ENSEMBLE_BATCH_H */
