/*
 * gw_fmi2_dirder.c -- fmi2GetDirectionalDerivative (Co-Simulation and Model Exchange): exact
 * partial derivatives from the model's generated functions, in every state where FMI 2.0.4
 * allows the call (tables of sections 3.2.3 and 4.2.4).  The knowns and unknowns depend on
 * the mode (section 2.1.9 and the `dependencies` of section 2.2.8):
 *
 *   Initialization Mode   unknowns: the Real InitialUnknowns (calculated outputs, states and
 *                         state derivatives); knowns: variables with initial = "exact"
 *                         (parameters, start values, settings) and inputs.
 *                         D0 = dini(t, s, u, p) = d v / d [s; p; u] at x = init(s, p).
 *   after it              unknowns: outputs, state derivatives (and states, the identity);
 *                         knowns: continuous states and inputs.
 *                         D = dir(t, x, u, p) = d [xdot; y] / d [x; u] (cached at the point).
 *
 * A known or unknown outside its mode's set is refused with fmi2Error and the reason.  The
 * result is checked before it is written: a product that overflows (a huge seed) is refused
 * too, and the caller's array never receives a non-finite value.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>

#include "gw_fmi2.h"

/* the frame of fmi2GetDirectionalDerivative (GW_FRAME_OPEN, gw_fmi2.h): interface, legal states */
#define GW_IFACE_GetDirectionalDerivative GW_IFACE_BOTH
#define GW_MASK_GetDirectionalDerivative                                                        \
    (GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED | GW_ST_TERMINATED |             \
     GW_ST_ERROR | GW_ST_ME)

/* Where a variable sits in the matrix of the current mode: a row (unknown) or a column
 * (known), or the identity of a known with itself.  -1: not part of this mode's set. */
typedef struct {
    int row;   /* row of D or D0 */
    int ident; /* unknown that is itself a known: its column (dv/dv = 1) */
} gw_dd_unknown_at;

/* Unknown in Initialization Mode: a row of D0, or a start value / input (a known: identity) */
static int gw_dd_unknown_init(const gw_model *m, const gw_variable *v, gw_dd_unknown_at *at) {
    int k = (int)(v - m->vars);
    at->row = at->ident = -1;
    if (v->type != GW_REAL) return 0;
    if (m->init_rows[k] >= 0) {
        at->row = m->init_rows[k];
        return 1;
    }
    if (v->kind == GW_VAR_START) at->ident = v->index;
    else if (v->kind == GW_VAR_PARAM) at->ident = m->ns + v->index;
    else if (v->kind == GW_VAR_INPUT) at->ident = m->ns + m->np + v->index;
    return at->ident >= 0;
}

/* Known in Initialization Mode: a column of D0; settings are knowns nothing depends on
 * (*zero = 1). */
static int gw_dd_known_init(const gw_model *m, const gw_variable *v, int *zero) {
    *zero = 0;
    if (v->type != GW_REAL) return -1;
    switch (v->kind) {
    case GW_VAR_START: return v->index;
    case GW_VAR_PARAM: return m->ns + v->index;
    case GW_VAR_INPUT: return m->ns + m->np + v->index;
    case GW_VAR_SETTING: *zero = 1; return 0;
    default: return -1;
    }
}

/* Unknown after initialisation: a row of D (0..nx-1 xdot, nx.. y), or a state (identity) */
static int gw_dd_unknown_sim(const gw_model *m, const gw_variable *v, gw_dd_unknown_at *at) {
    at->row = at->ident = -1;
    if (v->type != GW_REAL) return 0;
    switch (v->kind) {
    case GW_VAR_OUTPUT: at->row = m->nx + v->index; return 1;
    case GW_VAR_DERIVATIVE: at->row = v->index; return 1;
    case GW_VAR_STATE: at->ident = v->state_index >= 0 ? v->state_index : v->index; return 1;
    case GW_VAR_START:
        if (v->state_index >= 0) at->ident = v->state_index;
        else if (v->out_index >= 0) at->row = m->nx + v->out_index;
        return at->row >= 0 || at->ident >= 0;
    default: return 0;
    }
}

/* Known after initialisation: a column of D (0..nx-1 x, nx.. u), or -1 */
static int gw_dd_known_sim(const gw_model *m, const gw_variable *v) {
    if (v->type != GW_REAL) return -1;
    if (v->kind == GW_VAR_INPUT) return m->nx + v->index;
    if (v->kind == GW_VAR_STATE) return v->state_index >= 0 ? v->state_index : v->index;
    if (v->kind == GW_VAR_START && v->state_index >= 0) return v->state_index;
    return -1;
}

/* dvUnknown[i] = sum_j dv_i/dknown_j dvKnown[j] for one unknown (0 if not finite-able) */
static double gw_dd_sum(const gw_instance *I, int init_mode, const gw_dd_unknown_at *at,
                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                        const fmi2Real dvKnown[]) {
    const gw_model *m = I->m;
    size_t j;
    double sum = 0.0;
    for (j = 0; j < nKnown; j++) {
        const gw_variable *v = gw_variable_find(m, vKnown_ref[j]);
        int zero = 0, col;
        col = init_mode ? gw_dd_known_init(m, v, &zero) : gw_dd_known_sim(m, v);
        if (zero) continue;
        if (at->ident >= 0)
            sum += (col == at->ident) ? dvKnown[j] : 0.0;
        else if (init_mode)
            sum += I->dini_D[(size_t)at->row + (size_t)col * (size_t)m->n_init_rows] * dvKnown[j];
        else
            sum += I->dir_D[(size_t)at->row + (size_t)col * (size_t)(m->nx + m->ny)] * dvKnown[j];
    }
    return sum;
}

/* the matrix of the current mode at the current point; 0 or reason logged.  Its entries are
 * checked where they are used (gw_dd_check): a non-finite partial of one pair (norm_2's
 * derivative at 0, in a multipliers model) must not refuse the others. */
static int gw_dd_matrix(gw_instance *I, const char *fn, int init_mode) {
    if (init_mode) {
        if (gw_eval_dini(I, I->t, I->dini_D) != 0) {
            GW_LOG_ERR(I, "%s: evaluation of the initial partial derivatives failed", fn);
            return -1;
        }
        return 0;
    }
    if (I->dir_valid) return 0;
    if (I->in_setup && gw_eval_init(I, I->x) != 0) {
        GW_LOG_ERR(I, "%s: evaluation of the initial state failed", fn);
        return -1;
    }
    if (gw_eval_dir(I, I->t, I->x, I->dir_D) != 0) {
        GW_LOG_ERR(I, "%s: evaluation of the Jacobian failed at t=%.17g", fn, I->t);
        return -1;
    }
    I->dir_valid = !I->in_setup;
    return 0;
}

/* a non-finite entry of the matrix that the sum for this unknown uses: logged, -1; else 0 */
static int gw_dd_check(gw_instance *I, const char *fn, int init_mode, const gw_variable *u,
                       const gw_dd_unknown_at *at, const fmi2ValueReference vKnown_ref[],
                       size_t nKnown) {
    const gw_model *m = I->m;
    size_t j;
    if (at->ident >= 0) return 0;
    for (j = 0; j < nKnown; j++) {
        const gw_variable *v = gw_variable_find(m, vKnown_ref[j]);
        int zero = 0, col = init_mode ? gw_dd_known_init(m, v, &zero) : gw_dd_known_sim(m, v);
        double d;
        if (zero) continue;
        d = init_mode ? I->dini_D[(size_t)at->row + (size_t)col * (size_t)m->n_init_rows]
                      : I->dir_D[(size_t)at->row + (size_t)col * (size_t)(m->nx + m->ny)];
        if (!isfinite(d)) {
            GW_LOG_ERR(I, "%s: the partial derivative of %s with respect to %s is not finite "
                       "(%g) at t=%.17g%s; nothing returned", fn, u->name, v->name, d, I->t,
                       init_mode ? " (check the parameters and start values)" : "");
            return -1;
        }
    }
    return 0;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    const gw_model *m;
    size_t i, j;
    int init_mode;
    GW_FRAME_OPEN(GetDirectionalDerivative);
    /* a function the model does not provide fails alike in every state */
    if (!I->f_dir.eval && F->state != GW_ST_FATAL) {
        GW_LOG_ERR(I, "%s: not provided by this FMU (providesDirectionalDerivative=false)", fn);
        gw_fmi2_set_state(F, GW_ST_ERROR);
        return fmi2Error;
    }
    GW_FRAME_CHECK_STATE();
    m = I->m;
    /* Initialization Mode has its own knowns (FMI 2.0.4 section 2.2.8) when the model
     * generated their derivatives; a model without `dini` keeps the states as knowns there */
    init_mode = F->state == GW_ST_INIT_MODE && I->f_dini.eval != NULL;
    if (nUnknown > 0 && (!vUnknown_ref || !dvUnknown))
        GW_FAIL("%s: NULL array for %lu unknowns", fn, (unsigned long)nUnknown);
    if (nKnown > 0 && (!vKnown_ref || !dvKnown))
        GW_FAIL("%s: NULL array for %lu knowns", fn, (unsigned long)nKnown);
    /* check every reference before computing anything */
    for (i = 0; i < nUnknown; i++) {
        const gw_variable *v = gw_variable_find(m, vUnknown_ref[i]);
        gw_dd_unknown_at at;
        if (!v) GW_FAIL("%s: unknown value reference %u (vUnknown_ref[%lu])", fn, vUnknown_ref[i],
                        (unsigned long)i);
        if (init_mode ? !gw_dd_unknown_init(m, v, &at) : !gw_dd_unknown_sim(m, v, &at))
            GW_FAIL("%s: %s (vr=%u) is not an unknown %s", fn, v->name, v->vr,
                    init_mode ? "of Initialization Mode (a Real InitialUnknown, FMI 2.0.4 "
                                "section 2.2.8)"
                              : "(a Real output, continuous state or state derivative)");
    }
    for (j = 0; j < nKnown; j++) {
        const gw_variable *v = gw_variable_find(m, vKnown_ref[j]);
        int zero;
        if (!v) GW_FAIL("%s: unknown value reference %u (vKnown_ref[%lu])", fn, vKnown_ref[j],
                        (unsigned long)j);
        if ((init_mode ? gw_dd_known_init(m, v, &zero) : gw_dd_known_sim(m, v)) < 0)
            GW_FAIL("%s: known %s (vr=%u) is not %s", fn, v->name, v->vr,
                    init_mode ? "a known of Initialization Mode (a Real parameter, start value "
                                "or input)"
                              : "a continuous state or a Real input (parameters are knowns "
                                "only in Initialization Mode, FMI 2.0.4 section 2.2.8)");
        if (!isfinite(dvKnown[j]))
            GW_FAIL("%s: seed dvKnown[%lu] for %s is not finite", fn, (unsigned long)j, v->name);
    }
    if (gw_dd_matrix(I, fn, init_mode) != 0) {
        status = fmi2Error;
        goto END;
    }
    /* every result checked before any is written (a huge seed may overflow) */
    for (i = 0; i < nUnknown; i++) {
        gw_dd_unknown_at at;
        const gw_variable *v = gw_variable_find(m, vUnknown_ref[i]);
        double d;
        if (init_mode) gw_dd_unknown_init(m, v, &at);
        else gw_dd_unknown_sim(m, v, &at);
        if (gw_dd_check(I, fn, init_mode, v, &at, vKnown_ref, nKnown) != 0) {
            status = fmi2Error;
            goto END;
        }
        d = gw_dd_sum(I, init_mode, &at, vKnown_ref, nKnown, dvKnown);
        if (!isfinite(d))
            GW_FAIL("%s: the directional derivative of %s is not finite (%g): the seed is too "
                    "large; nothing returned", fn, v->name, d);
    }
    for (i = 0; i < nUnknown; i++) {
        gw_dd_unknown_at at;
        const gw_variable *v = gw_variable_find(m, vUnknown_ref[i]);
        if (init_mode) gw_dd_unknown_init(m, v, &at);
        else gw_dd_unknown_sim(m, v, &at);
        dvUnknown[i] = gw_dd_sum(I, init_mode, &at, vKnown_ref, nKnown, dvKnown);
    }
    GW_FRAME_END();
}

#endif /* GW_UNITY_BUILD */
