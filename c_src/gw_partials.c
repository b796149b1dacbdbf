/*
 * gw_partials.c -- exact partial derivatives for the FMI layers' directional and adjoint
 * derivatives (fmi2GetDirectionalDerivative; fmi3GetDirectionalDerivative and
 * fmi3GetAdjointDerivative), from the model's generated Jacobians.  Interface-neutral: the
 * layer checks the state and passes its own wording for the messages (gw_pd_words).  The
 * knowns and unknowns depend on the mode (FMI 2.0.4 sections 2.1.9, 2.2.8; FMI 3.0.2
 * section 2.2.12 "Getting Partial Derivatives"):
 *
 *   Initialization Mode   unknowns: the Real InitialUnknowns (calculated outputs, states and
 *                         state derivatives); knowns: variables with initial = "exact"
 *                         (parameters, start values, settings) and inputs.
 *                         D0 = dini(t, s, u, p) = d v / d [s; p; u] at x = init(s, p).
 *   after it              unknowns: outputs, state derivatives (and states, the identity);
 *                         knowns: continuous states and inputs.
 *                         D = dir(t, x, u, p) = d [xdot; y] / d [x; u] (cached at the point).
 *
 * With J the matrix of the chosen unknowns and knowns, the directional derivative is J seed
 * (one seed value per known), the adjoint seed^T J (one seed value per unknown).  A known or
 * unknown outside its mode's set is refused with the reason.  Results are checked before any
 * is written: a product that overflows (a huge seed) is refused too, and the caller's array
 * never receives a non-finite value.  Event indicators are no unknowns (FMI 3.0.2 section
 * 2.2.12: their dependencies are for debugging only).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>

#include "gw_instance.h"

/* the words of the calling layer in messages (its standard's names and sections) */
typedef struct {
    const char *unknowns, *knowns; /* names of the arguments */
    const char *seed; /* the seed array in "<seed>[3] for x is not finite" */
    const char *not_unknown_init, *not_unknown_sim; /* "is not an unknown %s" */
    const char *not_known_init, *not_known_sim;     /* "is not %s" */
    int vr0_is_time; /* value reference 0 is time (FMI 3), whatever the table holds */
} gw_pd_words;

/* Where a variable sits in the matrix of the current mode: a row (unknown) or a column
 * (known), or the identity of a known with itself.  -1: not part of this mode's set. */
typedef struct {
    int row;   /* row of D or D0 */
    int ident; /* unknown that is itself a known: its column (dv/dv = 1) */
} gw_pd_unknown_at;

/* Unknown in Initialization Mode: a row of D0, or a start value / input (a known: identity) */
static int gw_pd_unknown_init(const gw_model *m, const gw_variable *v, gw_pd_unknown_at *at) {
    int k = (int)(v - m->vars);
    at->row = at->ident = -1;
    if (v->type != GW_REAL || v->kind == GW_VAR_INDICATOR) return 0;
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
static int gw_pd_known_init(const gw_model *m, const gw_variable *v, int *zero) {
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
static int gw_pd_unknown_sim(const gw_model *m, const gw_variable *v, gw_pd_unknown_at *at) {
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
static int gw_pd_known_sim(const gw_model *m, const gw_variable *v) {
    if (v->type != GW_REAL) return -1;
    if (v->kind == GW_VAR_INPUT) return m->nx + v->index;
    if (v->kind == GW_VAR_STATE) return v->state_index >= 0 ? v->state_index : v->index;
    if (v->kind == GW_VAR_START && v->state_index >= 0) return v->state_index;
    return -1;
}

static int gw_pd_unknown(const gw_model *m, int init_mode, const gw_variable *v,
                         gw_pd_unknown_at *at) {
    return init_mode ? gw_pd_unknown_init(m, v, at) : gw_pd_unknown_sim(m, v, at);
}

/* column of known v, -1 if it is none; *zero = 1: a known nothing depends on */
static int gw_pd_known(const gw_model *m, int init_mode, const gw_variable *v, int *zero) {
    *zero = 0;
    return init_mode ? gw_pd_known_init(m, v, zero) : gw_pd_known_sim(m, v);
}

/* d unknown / d known (both checked); *skip = 1 where the pair is no term of the sum */
static double gw_pd_entry(const gw_instance *I, int init_mode, const gw_pd_unknown_at *at,
                          const gw_variable *known, int *skip) {
    const gw_model *m = I->m;
    int zero, col = gw_pd_known(m, init_mode, known, &zero);
    *skip = zero;
    if (zero) return 0.0;
    if (at->ident >= 0) return col == at->ident ? 1.0 : 0.0;
    if (init_mode) return I->dini_D[(size_t)at->row + (size_t)col * (size_t)m->n_init_rows];
    return I->dir_D[(size_t)at->row + (size_t)col * (size_t)(m->nx + m->ny)];
}

/* the matrix of the current mode at the current point; 0 or reason logged.  Its entries are
 * checked where they are used (gw_pd_check): a non-finite partial of one pair (norm_2's
 * derivative at 0, in a multipliers model) must not refuse the others. */
static int gw_pd_matrix(gw_instance *I, const char *fn, int init_mode) {
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

/* a non-finite entry of the matrix that the sums of this unknown use: logged, -1; else 0 */
static int gw_pd_check(gw_instance *I, const char *fn, int init_mode, const gw_variable *u,
                       const gw_pd_unknown_at *at, const unsigned int knowns[], size_t nKnowns) {
    size_t j;
    if (at->ident >= 0) return 0;
    for (j = 0; j < nKnowns; j++) {
        const gw_variable *v = gw_variable_find(I->m, knowns[j]);
        int skip;
        double d = gw_pd_entry(I, init_mode, at, v, &skip);
        if (!skip && !isfinite(d)) {
            GW_LOG_ERR(I, "%s: the partial derivative of %s with respect to %s is not finite "
                       "(%g) at t=%.17g%s; nothing returned", fn, u->name, v->name, d, I->t,
                       init_mode ? " (check the parameters and start values)" : "");
            return -1;
        }
    }
    return 0;
}

/* Component k of the result: directional, unknown k: sum_j d unknown_k / d known_j seed[j];
 * adjoint, known k: sum_i seed[i] d unknown_i / d known_k */
static double gw_pd_sum(const gw_instance *I, int init_mode, int adjoint,
                        const unsigned int unknowns[], size_t nUnknowns,
                        const unsigned int knowns[], size_t nKnowns, const double seed[],
                        size_t k) {
    size_t l, n = adjoint ? nUnknowns : nKnowns;
    double sum = 0.0;
    for (l = 0; l < n; l++) {
        gw_pd_unknown_at at;
        int skip;
        double d;
        gw_pd_unknown(I->m, init_mode, gw_variable_find(I->m, unknowns[adjoint ? l : k]), &at);
        d = gw_pd_entry(I, init_mode, &at, gw_variable_find(I->m, knowns[adjoint ? k : l]), &skip);
        if (!skip) sum += d * seed[l];
    }
    return sum;
}

/* One list of references (unknown: the unknowns, else the knowns), each a variable of the
 * table (or time), an unknown / a known of the mode, its seed value finite if the seed goes
 * with this list (seed not NULL).  GW_OK or GW_ERROR with the reason logged. */
static gw_status gw_pd_check_refs(gw_instance *I, const char *fn, const gw_pd_words *w,
                                  int init_mode, int unknown, const unsigned int refs[], size_t n,
                                  const double seed[]) {
    const char *is_not = unknown ? (init_mode ? w->not_unknown_init : w->not_unknown_sim)
                                 : (init_mode ? w->not_known_init : w->not_known_sim);
    size_t k;
    for (k = 0; k < n; k++) {
        int is_time = refs[k] == 0 && w->vr0_is_time;
        const gw_variable *v = is_time ? NULL : gw_variable_find(I->m, refs[k]);
        const char *name = v ? v->name : "time";
        gw_pd_unknown_at at;
        int zero;
        if (!v && !is_time) {
            GW_LOG_ERR(I, "%s: unknown value reference %u (%s[%lu])", fn, refs[k],
                       unknown ? w->unknowns : w->knowns, (unsigned long)k);
            return GW_ERROR;
        }
        if (unknown && (!v || !gw_pd_unknown(I->m, init_mode, v, &at))) {
            GW_LOG_ERR(I, "%s: %s (vr=%u) is not an unknown %s", fn, name, refs[k], is_not);
            return GW_ERROR;
        }
        if (!unknown && (!v || gw_pd_known(I->m, init_mode, v, &zero) < 0)) {
            GW_LOG_ERR(I, "%s: known %s (vr=%u) is not %s", fn, name, refs[k], is_not);
            return GW_ERROR;
        }
        if (seed && !isfinite(seed[k])) {
            GW_LOG_ERR(I, "%s: %s[%lu] for %s is not finite", fn, w->seed, (unsigned long)k,
                       name);
            return GW_ERROR;
        }
    }
    return GW_OK;
}

/* Every argument checked (references, seeds) before anything is computed; GW_OK or GW_ERROR
 * with the reason logged */
static gw_status gw_pd_check_args(gw_instance *I, const char *fn, int init_mode, int adjoint,
                                  const gw_pd_words *w, const unsigned int unknowns[],
                                  size_t nUnknowns, const unsigned int knowns[], size_t nKnowns,
                                  const double seed[], const double sensitivity[]) {
    if (nUnknowns > 0 && (!unknowns || !(adjoint ? seed : sensitivity))) {
        GW_LOG_ERR(I, "%s: NULL array for %lu unknowns", fn, (unsigned long)nUnknowns);
        return GW_ERROR;
    }
    if (nKnowns > 0 && (!knowns || !(adjoint ? sensitivity : seed))) {
        GW_LOG_ERR(I, "%s: NULL array for %lu knowns", fn, (unsigned long)nKnowns);
        return GW_ERROR;
    }
    if (gw_pd_check_refs(I, fn, w, init_mode, 1, unknowns, nUnknowns, adjoint ? seed : NULL))
        return GW_ERROR;
    return gw_pd_check_refs(I, fn, w, init_mode, 0, knowns, nKnowns, adjoint ? NULL : seed);
}

/* The directional (adjoint = 0: sensitivity = J seed, nUnknowns values) or adjoint
 * (adjoint = 1: sensitivity = seed^T J, nKnowns values) derivative at the current point, in
 * Initialization Mode (init_mode: D0) or after it (D).  GW_OK, or GW_ERROR with the reason
 * logged and sensitivity untouched. */
GW_INTERNAL gw_status gw_partials(gw_instance *I, const char *fn, int init_mode, int adjoint,
                                  const gw_pd_words *w, const unsigned int unknowns[],
                                  size_t nUnknowns, const unsigned int knowns[], size_t nKnowns,
                                  const double seed[], double sensitivity[]) {
    const gw_model *m = I->m;
    size_t k, n_out = adjoint ? nKnowns : nUnknowns;
    if (gw_pd_check_args(I, fn, init_mode, adjoint, w, unknowns, nUnknowns, knowns, nKnowns,
                         seed, sensitivity) != GW_OK)
        return GW_ERROR;
    if (gw_pd_matrix(I, fn, init_mode) != 0) return GW_ERROR;
    /* every entry used and every result checked before any is written */
    for (k = 0; k < nUnknowns; k++) {
        const gw_variable *v = gw_variable_find(m, unknowns[k]);
        gw_pd_unknown_at at;
        gw_pd_unknown(m, init_mode, v, &at);
        if (gw_pd_check(I, fn, init_mode, v, &at, knowns, nKnowns) != 0) return GW_ERROR;
    }
    for (k = 0; k < n_out; k++) {
        double d = gw_pd_sum(I, init_mode, adjoint, unknowns, nUnknowns, knowns, nKnowns, seed, k);
        if (!isfinite(d)) {
            const gw_variable *v = gw_variable_find(m, adjoint ? knowns[k] : unknowns[k]);
            GW_LOG_ERR(I, "%s: the %s derivative %s %s is not finite (%g): the seed is too "
                       "large; nothing returned", fn, adjoint ? "adjoint" : "directional",
                       adjoint ? "with respect to" : "of", v->name, d);
            return GW_ERROR;
        }
    }
    for (k = 0; k < n_out; k++)
        sensitivity[k] =
            gw_pd_sum(I, init_mode, adjoint, unknowns, nUnknowns, knowns, nKnowns, seed, k);
    return GW_OK;
}

#endif /* GW_UNITY_BUILD */
