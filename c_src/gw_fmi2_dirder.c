/*
 * gw_fmi2_dirder.c -- fmi2GetDirectionalDerivative (Co-Simulation and Model Exchange): exact
 * partial derivatives of state derivatives and outputs with respect to continuous states and
 * Real inputs, from the model's generated `dir` function, D = d [xdot; y] / d [x; u]
 * (column-major, cached at the current point).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>

#include "gw_fmi2.h"

#define GW_MASK_GetDirectionalDerivative                                                        \
    (GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED | GW_ST_TERMINATED |             \
     GW_ST_ERROR | GW_ST_ME)

/* Row of D for an unknown: 0..nx-1 xdot, nx.. y; or *xrow >= 0 for the identity row of
 * a continuous state.  0 if v is no output, state or derivative. */
static int gw_dd_unknown(const gw_model *m, const gw_variable *v, int *row, int *xrow) {
    *row = -1;
    *xrow = -1;
    if (v->type != GW_REAL) return 0;
    switch (v->kind) {
    case GW_VAR_OUTPUT: *row = m->nx + v->index; return 1;
    case GW_VAR_DERIVATIVE: *row = v->index; return 1;
    case GW_VAR_STATE: *xrow = v->state_index >= 0 ? v->state_index : v->index; return 1;
    case GW_VAR_START:
        if (v->state_index >= 0) {
            *xrow = v->state_index;
            return 1;
        }
        if (v->out_index >= 0) {
            *row = m->nx + v->out_index;
            return 1;
        }
        return 0;
    default: return 0;
    }
}

/* Column of D for a known: 0..nx-1 x, nx.. u.  -1 if v is no state or input. */
static int gw_dd_known(const gw_model *m, const gw_variable *v) {
    if (v->type != GW_REAL) return -1;
    if (v->kind == GW_VAR_INPUT) return m->nx + v->index;
    if (v->kind == GW_VAR_STATE) return v->state_index >= 0 ? v->state_index : v->index;
    if (v->kind == GW_VAR_START && v->state_index >= 0) return v->state_index;
    return -1;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    static const char fn[] = "fmi2GetDirectionalDerivative";
    const gw_model *m;
    size_t i, j;
    int nrow;
    gw_fmu *F = (gw_fmu *)c;
    gw_instance *I;
    fmi2Status status = fmi2OK;
    /* a function the model does not provide fails alike in every state */
    if (F && !F->I->f_dir.eval && F->state != GW_ST_FATAL) {
        GW_LOG_ERR(F->I, "%s: not provided by this FMU (providesDirectionalDerivative=false)", fn);
        gw_fmi2_set_state(F, GW_ST_ERROR);
        return fmi2Error;
    }
    if (!gw_fmi2_begin(F, fn, GW_MASK_GetDirectionalDerivative)) return fmi2Error;
    I = F->I;
    m = I->m;
    nrow = m->nx + m->ny;
    if (nUnknown > 0 && (!vUnknown_ref || !dvUnknown))
        GW_FAIL("%s: NULL array for %lu unknowns", fn, (unsigned long)nUnknown);
    if (nKnown > 0 && (!vKnown_ref || !dvKnown))
        GW_FAIL("%s: NULL array for %lu knowns", fn, (unsigned long)nKnown);
    /* check every reference before computing anything */
    for (i = 0; i < nUnknown; i++) {
        const gw_variable *v = gw_variable_find(m, vUnknown_ref[i]);
        int row, xrow;
        if (!v) GW_FAIL("%s: unknown value reference %u (vUnknown_ref[%lu])", fn, vUnknown_ref[i],
                     (unsigned long)i);
        if (!gw_dd_unknown(m, v, &row, &xrow))
            GW_FAIL("%s: unknown %s (vr=%u) is not a Real output, continuous state or state "
                 "derivative", fn, v->name, v->vr);
    }
    for (j = 0; j < nKnown; j++) {
        const gw_variable *v = gw_variable_find(m, vKnown_ref[j]);
        if (!v) GW_FAIL("%s: unknown value reference %u (vKnown_ref[%lu])", fn, vKnown_ref[j],
                     (unsigned long)j);
        if (gw_dd_known(m, v) < 0)
            GW_FAIL("%s: known %s (vr=%u) is not a continuous state or a Real input", fn, v->name,
                 v->vr);
        if (!isfinite(dvKnown[j]))
            GW_FAIL("%s: seed dvKnown[%lu] for %s is not finite", fn, (unsigned long)j, v->name);
    }
    /* D at the current point (before initialisation ends: at x = init(s, p)) */
    if (I->in_setup || !I->dir_valid) {
        int k, n = nrow * (m->nx + m->nu);
        if (I->in_setup && gw_eval_init(I, I->x) != 0)
            GW_FAIL("%s: evaluation of the initial state failed", fn);
        I->dir_valid = 0;
        if (gw_eval_dir(I, I->t, I->x, I->dir_D) != 0)
            GW_FAIL("%s: evaluation of the Jacobian failed at t=%.17g", fn, I->t);
        for (k = 0; k < n; k++)
            if (!isfinite(I->dir_D[k])) {
                GW_LOG_NONFINITE(I, "%s: Jacobian entry (%d, %d) is not finite at t=%.17g", fn,
                              k % nrow, k / nrow, I->t);
                status = gw_fmi2_status(I->nonfinite_status);
                goto END;
            }
        I->dir_valid = !I->in_setup;
    }
    for (i = 0; i < nUnknown; i++) {
        const gw_variable *v = gw_variable_find(m, vUnknown_ref[i]);
        double sum = 0.0;
        int row, xrow;
        gw_dd_unknown(m, v, &row, &xrow);
        for (j = 0; j < nKnown; j++) {
            int col = gw_dd_known(m, gw_variable_find(m, vKnown_ref[j]));
            if (xrow >= 0)
                sum += (col == xrow) ? dvKnown[j] : 0.0;
            else
                sum += I->dir_D[(size_t)row + (size_t)col * (size_t)nrow] * dvKnown[j];
        }
        dvUnknown[i] = sum;
    }
    GW_END_FUNCTION();
}

#endif /* GW_UNITY_BUILD */
