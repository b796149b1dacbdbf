/*
 * gw_solver_taylor_increment.h -- solver taylor's increment dx = P(h) - x0 and P'(h) from the
 * step's series (a template: gw_solver_taylor.c includes it once per copy of the Taylor kernel,
 * gw_taylor.c, with GW_TLI(name) the copy's names and GW_TLI_ATTR its target; the same
 * operations in each).
 */
/* dx = P(h) - x0 = sum_{k>=1} X_k h^k and, if dp is not NULL, dp = P'(h), in one Horner pass:
 * with Q(s) = sum_{k>=1} X_k s^(k-1), dx = h Q(h) and P'(h) = Q(h) + h Q'(h).  The order loop
 * is outside the component loop (blocks of 8 components): the components' Horner chains are
 * independent and overlap, where one chain after the other waited on each multiply-add. */
#if GW_TL_INCREMENT8
/* a full block of 8 components as 4 pairs: the same multiplies and adds in the same order as
 * the scalar loop below, half the instructions (the scalar loop is bound by the issue of its 4
 * operations per component and order, not by the chains' latency); the ensemble's layout, with
 * the targets of its increments pass (gw_ens_increments, fused multiply-adds on x86-64-v3),
 * which equals this lane by lane bit for bit */
static GW_MAYBE_UNUSED GW_TLI_ATTR void GW_TLI(increment8)(const double *x0, size_t si, size_t so,
                                                            int order, double h, double *dx,
                                                            double *dp) {
    const gw_tl_v2 hv = {h, h};
    gw_tl_v2 q[4], dq[4];
    int c, k;
    for (c = 0; c < 4; c++) {
        const double *a = x0 + (size_t)(2 * c) * si + (size_t)order * so;
        q[c] = (gw_tl_v2){a[0], a[si]};
        dq[c] = (gw_tl_v2){0.0, 0.0};
    }
    for (k = order - 1; k >= 1; k--) {
        const double *xk = x0 + (size_t)k * so;
        for (c = 0; c < 4; c++) {
            const double *a = xk + (size_t)(2 * c) * si;
            dq[c] = dq[c] * hv + q[c];
            q[c] = q[c] * hv + (gw_tl_v2){a[0], a[si]};
        }
    }
    for (c = 0; c < 4; c++) {
        const gw_tl_v2 d = q[c] * hv;
        dx[2 * c] = d[0];
        dx[2 * c + 1] = d[1];
        if (dp) {
            const gw_tl_v2 e = q[c] + hv * dq[c];
            dp[2 * c] = e[0];
            dp[2 * c + 1] = e[1];
        }
    }
}

/* the one-lane path's series (gw_integrate_taylor: the kernel's order-major layout, si = 1),
 * a block of 8 components: the same multiplies and adds per component as above, its 4 pairs
 * held in registers (each order's 8 coefficients are contiguous: a pair is one load) */
static GW_MAYBE_UNUSED GW_TLI_ATTR void GW_TLI(increment8_om)(const double *x0, size_t so,
                                                               int order, double h, double *dx,
                                                               double *dp) {
    const gw_tl_v2 hv = {h, h};
    const double *a = x0 + (size_t)order * so;
    gw_tl_v2 q0 = GW_TL_LD2(a), q1 = GW_TL_LD2(a + 2), q2 = GW_TL_LD2(a + 4),
             q3 = GW_TL_LD2(a + 6);
    gw_tl_v2 d0 = {0.0, 0.0}, d1 = d0, d2 = d0, d3 = d0;
    int k;
    for (k = order - 1; k >= 1; k--) {
        a = x0 + (size_t)k * so;
        d0 = d0 * hv + q0;
        d1 = d1 * hv + q1;
        d2 = d2 * hv + q2;
        d3 = d3 * hv + q3;
        q0 = q0 * hv + GW_TL_LD2(a);
        q1 = q1 * hv + GW_TL_LD2(a + 2);
        q2 = q2 * hv + GW_TL_LD2(a + 4);
        q3 = q3 * hv + GW_TL_LD2(a + 6);
    }
    *(gw_tl_v2u *)(void *)dx = q0 * hv;
    *(gw_tl_v2u *)(void *)(dx + 2) = q1 * hv;
    *(gw_tl_v2u *)(void *)(dx + 4) = q2 * hv;
    *(gw_tl_v2u *)(void *)(dx + 6) = q3 * hv;
    if (dp) {
        *(gw_tl_v2u *)(void *)dp = q0 + hv * d0;
        *(gw_tl_v2u *)(void *)(dp + 2) = q1 + hv * d1;
        *(gw_tl_v2u *)(void *)(dp + 4) = q2 + hv * d2;
        *(gw_tl_v2u *)(void *)(dp + 6) = q3 + hv * d3;
    }
}
#endif /* GW_TL_INCREMENT8 */

/* gw_taylor_increment on the series X with state i's coefficient k at X[i si + k so]; the same
 * targets as the blocks of 8 and the ensemble's increments pass (gw_ens_increments fuses the last
 * nx mod 8 components' multiply-adds too: unfused here, those components of a single run would
 * be 1 ulp off the ensemble's lane, tests/test_taylor_near_pole.py::
 * test_ensemble_rejected_steps_retry_on_the_lane_series, lunar_rover's 9th state) */
static GW_MAYBE_UNUSED GW_TLI_ATTR void GW_TLI(increment_strided)(const double *X, size_t si,
                                                                   size_t so, int order, int nx,
                                                                   double h, double *dx,
                                                                   double *dp) {
    enum { B = 8 };
    int i0, b, k;
    for (i0 = 0; i0 < nx; i0 += B) {
        const int nb = nx - i0 < B ? nx - i0 : B;
        const double *x0 = X + (size_t)i0 * si;
        double q[B], dq[B];
#if GW_TL_INCREMENT8
        if (nb == B) {
            if (si == 1)
                GW_TLI(increment8_om)(x0, so, order, h, dx + i0, dp ? dp + i0 : NULL);
            else
                GW_TLI(increment8)(x0, si, so, order, h, dx + i0, dp ? dp + i0 : NULL);
            continue;
        }
#endif
        for (b = 0; b < nb; b++) {
            q[b] = x0[(size_t)b * si + (size_t)order * so];
            dq[b] = 0.0;
        }
        for (k = order - 1; k >= 1; k--) {
            const double *xk = x0 + (size_t)k * so;
            for (b = 0; b < nb; b++) {
                dq[b] = dq[b] * h + q[b];
                q[b] = q[b] * h + xk[(size_t)b * si];
            }
        }
        for (b = 0; b < nb; b++) dx[i0 + b] = q[b] * h;
        if (dp)
            for (b = 0; b < nb; b++) dp[i0 + b] = q[b] + h * dq[b];
    }
}
