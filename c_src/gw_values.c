/*
 * gw_values.c -- variable values: the model's variable table (GW_MODEL.vars, sorted by
 * value reference) mapped onto the instance's vectors p, s, u, y, x, xdot, the event flags
 * and the runtime settings.  Which variable may be set when is the front end's rule.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>
#include <string.h>

#include "gw_instance.h"

GW_API const gw_variable *gw_variable_find(const gw_model *m, unsigned int vr) {
    int lo = 0, hi = m->n_vars - 1;
    while (lo <= hi) {
        int mid = lo + (hi - lo) / 2;
        unsigned int v = m->vars[mid].vr;
        if (v == vr) return &m->vars[mid];
        if (v < vr)
            lo = mid + 1;
        else
            hi = mid - 1;
    }
    return NULL;
}

GW_API const char *gw_variable_name(const gw_model *m, int kind, int index) {
    int i;
    for (i = 0; i < m->n_vars; i++)
        if ((int)m->vars[i].kind == kind && m->vars[i].index == index) return m->vars[i].name;
    return NULL;
}

GW_API void gw_point_changed(gw_instance *I) {
    I->y_valid = 0;
    I->xdot_valid = 0;
    I->dir_valid = 0;
}

static double gw_setting_value(const gw_instance *I, int index) {
    switch (index) {
    case GW_SET_SOLVER: return (double)I->solver;
    case GW_SET_REL_TOL: return I->rel_tol;
    case GW_SET_ABS_TOL: return I->abs_tol;
    case GW_SET_MAX_STEP: return I->max_step;
    case GW_SET_MAX_INTERNAL_STEPS: return I->max_internal_steps;
    default: return 0.0;
    }
}

GW_API double gw_value_get(const gw_instance *I, const gw_variable *v) {
    switch (v->kind) {
    case GW_VAR_PARAM: return I->p[v->index];
    case GW_VAR_START:
        return (I->in_setup || v->out_index < 0) ? I->s[v->index] : I->y[v->out_index];
    case GW_VAR_INPUT: return I->u[v->index];
    case GW_VAR_OUTPUT: return I->y[v->index];
    case GW_VAR_SETTING: return gw_setting_value(I, v->index);
    case GW_VAR_EVENT: return I->flags[v->index] ? 1.0 : 0.0;
    case GW_VAR_STATE: return I->x[v->index];
    case GW_VAR_DERIVATIVE: return I->xdot[v->index];
    case GW_VAR_INDICATOR: return I->e_me[v->index]; /* as the front end last read them */
    default: return 0.0;
    }
}

/* the valid range of a setting (gw_core.h); 1 if value lies in it, else logs why */
static int gw_setting_in_range(gw_instance *I, const char *fn, const gw_variable *v,
                               double value) {
    switch (v->index) {
    case GW_SET_SOLVER:
        if (value == GW_SOLVER_TAYLOR && !I->m->taylor.jet) {
            GW_LOG_ERR(I, "%s: %s = 6 (taylor) is not available in this model: %s (build it "
                       "from a scene with solver = \"taylor\", or with the Taylor kernel)", fn,
                       v->name, I->m->taylor.why_absent ? I->m->taylor.why_absent
                                                        : "built without a Taylor kernel");
            return 0;
        }
        if (value == floor(value) && fabs(value) < 1e9 && gw_solver_available((int)value))
            return 1;
        GW_LOG_ERR(I, "%s: %s = %.17g is not a solver: valid are 1 (euler), 2 (rk4), 3 (dopri5), "
                   "4 (rosenbrock), 5 (dop853), 6 (taylor), 7 (auto)", fn, v->name, value);
        return 0;
    case GW_SET_REL_TOL:
        if (value >= GW_REL_TOL_MIN && value <= GW_REL_TOL_MAX) return 1;
        GW_LOG_ERR(I, "%s: %s = %g is outside its valid range [%.17g, %g] (a relative error "
                   "tolerance: at most 1, at least 10 machine epsilons)", fn, v->name, value,
                   GW_REL_TOL_MIN, GW_REL_TOL_MAX);
        return 0;
    case GW_SET_ABS_TOL:
        if (value == 0.0 || (value >= GW_ABS_TOL_MIN && value <= GW_ABS_TOL_MAX)) return 1;
        GW_LOG_ERR(I, "%s: %s = %g is outside its valid range [%g, %g] or 0 (an absolute error "
                   "tolerance in units of each state's nominal value; 0: follow rel_tol, as "
                   "rel_tol / 100)", fn, v->name, value, GW_ABS_TOL_MIN, GW_ABS_TOL_MAX);
        return 0;
    case GW_SET_MAX_STEP:
        if (value > 0.0) return 1;
        GW_LOG_ERR(I, "%s: %s = %g must be > 0 (s)", fn, v->name, value);
        return 0;
    case GW_SET_MAX_INTERNAL_STEPS:
        if (value == floor(value) && value >= GW_MAX_INTERNAL_STEPS_MIN &&
            value <= GW_MAX_INTERNAL_STEPS_MAX)
            return 1;
        GW_LOG_ERR(I, "%s: %s = %.17g must be a whole number from %.0f to %.0f (a budget of "
                   "internal steps per call)", fn, v->name, value, GW_MAX_INTERNAL_STEPS_MIN,
                   GW_MAX_INTERNAL_STEPS_MAX);
        return 0;
    default: return 1;
    }
}

GW_API gw_status gw_value_check(gw_instance *I, const char *fn, const gw_variable *v,
                                double value) {
    if (!isfinite(value)) {
        GW_LOG_ERR(I, "%s: value %g for variable %s (vr=%u) is not finite", fn, value, v->name,
                   v->vr);
        return GW_ERROR;
    }
    if (v->kind == GW_VAR_SETTING && !gw_setting_in_range(I, fn, v, value)) return GW_ERROR;
    if (v->type == GW_BOOLEAN && value != 0.0 && value != 1.0) {
        GW_LOG_ERR(I, "%s: value %g for Boolean variable %s (vr=%u) is neither 0 nor 1", fn,
                   value, v->name, v->vr);
        return GW_ERROR;
    }
    return GW_OK;
}

GW_INTERNAL gw_status gw_settings_check(gw_instance *I, const char *fn, const double *value) {
    static const char *const names[GW_N_SETTINGS] = {"solver", "rel_tol", "abs_tol", "max_step",
                                                     "max_internal_steps"};
    static const gw_type types[GW_N_SETTINGS] = {GW_ENUM, GW_REAL, GW_REAL, GW_REAL, GW_INTEGER};
    int k, i;
    for (k = 0; k < GW_N_SETTINGS; k++) {
        gw_variable v;
        memset(&v, 0, sizeof(v));
        v.kind = GW_VAR_SETTING;
        v.index = k;
        v.type = types[k];
        v.name = names[k];
        for (i = 0; i < I->m->n_vars; i++) /* the model's own variable, if it exposes one */
            if (I->m->vars[i].kind == GW_VAR_SETTING && I->m->vars[i].index == k) {
                v = I->m->vars[i];
                break;
            }
        if (gw_value_check(I, fn, &v, value ? value[k] : gw_setting_value(I, k)) != GW_OK)
            return GW_ERROR;
    }
    return GW_OK;
}

GW_API void gw_value_set(gw_instance *I, const gw_variable *v, double value) {
    switch (v->kind) {
    case GW_VAR_PARAM:
        I->p[v->index] = value;
        I->pre_valid = 0;
        if (!I->in_setup) { /* tunable parameter during the simulation */
            gw_point_changed(I);
            I->fcur_valid = 0;
            gw_eval_nom(I, I->nominal);
        }
        break;
    case GW_VAR_START: I->s[v->index] = value; break;
    case GW_VAR_INPUT:
        I->u[v->index] = value;
        gw_point_changed(I);
        I->fcur_valid = 0;
        break;
    case GW_VAR_SETTING:
        switch (v->index) {
        case GW_SET_SOLVER:
            I->solver = (int)value;
            gw_solver_select(I);
            break;
        case GW_SET_REL_TOL:
            I->rel_tol = value;
            I->rel_tol_set = 1; /* explicit: wins over a set-up tolerance */
            break;
        case GW_SET_ABS_TOL:
            I->abs_tol = value;
            I->abs_tol_set = 1;
            break;
        case GW_SET_MAX_STEP: I->max_step = value; break;
        case GW_SET_MAX_INTERNAL_STEPS: I->max_internal_steps = value; break;
        default: break;
        }
        break;
    default: break;
    }
}

#endif /* GW_UNITY_BUILD */
