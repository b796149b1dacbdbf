/*
 * gw_instance.c -- one instance: allocation (all through the front end's allocate/free
 * callbacks), default values, release.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <string.h>

#include "gw_instance.h"

GW_INTERNAL void *gw_alloc(const gw_instance *I, size_t n, size_t size) {
    void *ptr;
    if (n == 0) n = 1; /* never hand out NULL for empty vectors */
    ptr = I->alloc.allocate ? I->alloc.allocate(I->alloc.ctx, n, size) : I->cb.allocate(n, size);
    if (ptr) memset(ptr, 0, n * size); /* calloc-like, whatever the front end does */
    return ptr;
}

GW_INTERNAL void gw_free(const gw_instance *I, void *ptr) {
    if (!ptr) return;
    if (I->alloc.free)
        I->alloc.free(I->alloc.ctx, ptr);
    else
        I->cb.free(ptr);
}

static char *gw_str_dup(const gw_instance *I, const char *s) {
    size_t n = strlen(s) + 1;
    char *d = (char *)gw_alloc(I, n, 1);
    if (d) memcpy(d, s, n);
    return d;
}

#define GW_ALLOC_VEC(ptr, type, n)                                                            \
    do {                                                                                      \
        (ptr) = (type *)gw_alloc(I, (size_t)(n), sizeof(type));                               \
        if (!(ptr)) goto fail;                                                                \
    } while (0)

GW_API gw_instance *gw_instance_new_with(const gw_model *m, const char *name,
                                         const gw_callbacks *cb, const gw_allocator *alloc,
                                         int logging_on) {
    gw_instance *I;
    int i, nx = m->nx, ne = m->ne;
    I = (gw_instance *)(alloc ? alloc->allocate(alloc->ctx, 1, sizeof(gw_instance))
                              : cb->allocate(1, sizeof(gw_instance)));
    if (!I) return NULL;
    memset(I, 0, sizeof(*I));
    I->m = m;
    I->cb = *cb;
    if (alloc) I->alloc = *alloc;
    I->logging_on = logging_on ? 1 : 0;
    I->log_mask = logging_on ? ((1u << GW_LOG_N) - 1u) : 0u;
    I->nonfinite_status = GW_ERROR;
    I->name = gw_str_dup(I, name);
    if (!I->name) goto fail;

    GW_ALLOC_VEC(I->x, double, nx);
    GW_ALLOC_VEC(I->s, double, m->ns);
    GW_ALLOC_VEC(I->u, double, m->nu);
    GW_ALLOC_VEC(I->p, double, m->np);
    GW_ALLOC_VEC(I->y, double, m->ny);
    GW_ALLOC_VEC(I->e, double, ne);
    GW_ALLOC_VEC(I->c, double, m->nc);
    GW_ALLOC_VEC(I->nominal, double, nx);
    GW_ALLOC_VEC(I->flags, int, ne);
    GW_ALLOC_VEC(I->t_events, double, ne);
    for (i = 0; i < 7; i++) GW_ALLOC_VEC(I->k[i], double, nx);
    GW_ALLOC_VEC(I->xnew, double, nx);
    GW_ALLOC_VEC(I->xtmp, double, nx);
    GW_ALLOC_VEC(I->xev, double, nx);
    GW_ALLOC_VEC(I->rcont, double, 5 * nx);
    GW_ALLOC_VEC(I->enew, double, ne);
    GW_ALLOC_VEC(I->eev, double, ne);
    GW_ALLOC_VEC(I->x_bak, double, nx);
    GW_ALLOC_VEC(I->xc_bak, double, nx);
    GW_ALLOC_VEC(I->xc, double, nx);
    GW_ALLOC_VEC(I->xcnew, double, nx);
    GW_ALLOC_VEC(I->xc_x, double, nx);
    GW_ALLOC_VEC(I->dx, double, nx);
    GW_ALLOC_VEC(I->e_bak, double, ne);
    GW_ALLOC_VEC(I->flags_bak, int, ne);
    GW_ALLOC_VEC(I->t_events_bak, double, ne);
    if (gw_solver_alloc(I)) goto fail;

    GW_ALLOC_VEC(I->pre_c, double, m->n_pre);
    if (gw_fun_alloc(I, &I->f_pre, &m->ode_pre, 1, 1)) goto fail;
    if (gw_fun_alloc(I, &I->f_init, &m->init, 2, 1) ||
        gw_fun_alloc(I, &I->f_ode, &m->ode, m->ode_pre.eval ? 5 : 4, 1) ||
        gw_fun_alloc(I, &I->f_out, &m->out, 4, 1) ||
        gw_fun_alloc(I, &I->f_evt, &m->evt, m->ode_pre.eval ? 5 : 4, 1) ||
        gw_fun_alloc(I, &I->f_chk, &m->chk, 2, 1) || gw_fun_alloc(I, &I->f_nom, &m->nom, 1, 1) ||
        gw_fun_alloc(I, &I->f_jac, &m->jac, 4, 1))
        goto fail;

    /* state derivatives, event indicators for the front end, directional derivatives */
    GW_ALLOC_VEC(I->xdot, double, nx);
    GW_ALLOC_VEC(I->e_me, double, ne);
    if (m->dir.eval) {
        if (gw_fun_alloc(I, &I->f_dir, &m->dir, 4, 1)) goto fail;
        GW_ALLOC_VEC(I->dir_D, double, (size_t)(m->nx + m->ny) * (size_t)(m->nx + m->nu));
    }
    if (m->dini.eval && m->init_rows && m->n_init_rows > 0) {
        if (gw_fun_alloc(I, &I->f_dini, &m->dini, 4, 1)) goto fail;
        GW_ALLOC_VEC(I->dini_D, double,
                     (size_t)m->n_init_rows * (size_t)(m->ns + m->np + m->nu));
    }
    /* event instants with state updates */
    if (gw_fun_alloc(I, &I->f_upd, &m->upd, 5, 1)) goto fail;
    GW_ALLOC_VEC(I->x_upd, double, nx);
    GW_ALLOC_VEC(I->e_upd, double, ne);
    GW_ALLOC_VEC(I->edot, double, ne);
    GW_ALLOC_VEC(I->edot_new, double, ne);
    GW_ALLOC_VEC(I->ev_fired, int, ne);
    gw_fun_bind(I);
    gw_instance_reset(I);
    return I;
fail:
    gw_instance_free(I);
    return NULL;
}

GW_API gw_instance *gw_instance_new(const gw_model *m, const char *name, const gw_callbacks *cb,
                                    int logging_on) {
    return gw_instance_new_with(m, name, cb, NULL, logging_on);
}

GW_API void gw_instance_free(gw_instance *I) {
    int i;
    gw_free_fn free_fn;
    if (!I) return;
    gw_fun_free(I, &I->f_init);
    gw_fun_free(I, &I->f_ode);
    gw_fun_free(I, &I->f_out);
    gw_fun_free(I, &I->f_evt);
    gw_fun_free(I, &I->f_chk);
    gw_fun_free(I, &I->f_nom);
    gw_fun_free(I, &I->f_jac);
    gw_fun_free(I, &I->f_dir);
    gw_fun_free(I, &I->f_dini);
    gw_free(I, I->dini_D);
    gw_fun_free(I, &I->f_upd);
    gw_free(I, I->x_upd);
    gw_free(I, I->e_upd);
    gw_free(I, I->edot);
    gw_free(I, I->edot_new);
    gw_free(I, I->ev_fired);
    gw_fun_free(I, &I->f_pre);
    gw_free(I, I->pre_c);
    gw_solver_free(I);
    gw_free(I, I->xdot);
    gw_free(I, I->e_me);
    gw_free(I, I->dir_D);
    gw_free(I, I->x);
    gw_free(I, I->s);
    gw_free(I, I->u);
    gw_free(I, I->p);
    gw_free(I, I->y);
    gw_free(I, I->e);
    gw_free(I, I->c);
    gw_free(I, I->nominal);
    gw_free(I, I->flags);
    gw_free(I, I->t_events);
    for (i = 0; i < 7; i++) gw_free(I, I->k[i]);
    gw_free(I, I->xnew);
    gw_free(I, I->xtmp);
    gw_free(I, I->xev);
    gw_free(I, I->rcont);
    gw_free(I, I->enew);
    gw_free(I, I->eev);
    gw_free(I, I->x_bak);
    gw_free(I, I->xc_bak);
    gw_free(I, I->xc);
    gw_free(I, I->xcnew);
    gw_free(I, I->xc_x);
    gw_free(I, I->dx);
    gw_free(I, I->e_bak);
    gw_free(I, I->flags_bak);
    gw_free(I, I->t_events_bak);
    gw_free(I, I->name);
    if (I->alloc.free) {
        gw_allocator alloc = I->alloc;
        alloc.free(alloc.ctx, I);
        return;
    }
    free_fn = I->cb.free;
    free_fn(I);
}

/* Everything an instance holds after gw_instance_new. */
GW_API void gw_instance_reset(gw_instance *I) {
    const gw_model *m = I->m;
    int i;
    I->in_setup = 1;
    I->solver = m->default_solver;
    I->rel_tol = m->default_rel_tol;
    I->abs_tol = m->default_abs_tol;
    I->max_step = m->default_max_step;
    I->rel_tol_set = 0;
    I->abs_tol_set = 0;
    I->max_internal_steps = m->default_max_internal_steps > 0.0 ? m->default_max_internal_steps
                                                                : GW_DEFAULT_MAX_INTERNAL_STEPS;
    gw_update_atol_eff(I);
    gw_solver_select(I);
    I->err_old = 0.0;
    I->t_start = 0.0;
    I->t_stop = 0.0;
    I->stop_defined = 0;
    I->tol_defined = 0;
    I->tolerance = 0.0;
    I->t = 0.0;
    I->update_pending = 0;
    I->stopped_at_update = 0;
    for (i = 0; i < m->ns; i++) I->s[i] = m->s_start ? m->s_start[i] : 0.0;
    for (i = 0; i < m->nu; i++) I->u[i] = m->u_start ? m->u_start[i] : 0.0;
    for (i = 0; i < m->np; i++) I->p[i] = m->p_start ? m->p_start[i] : 0.0;
    for (i = 0; i < m->nx; i++) {
        I->x[i] = 0.0;
        I->xc[i] = 0.0;
        I->xc_x[i] = 0.0;
        I->nominal[i] = 1.0;
    }
    for (i = 0; i < m->ny; i++) I->y[i] = 0.0;
    for (i = 0; i < m->ne; i++) {
        I->e[i] = 0.0;
        I->flags[i] = 0;
        I->t_events[i] = 0.0;
    }
    I->terminated = 0;
    I->x_jumped = 0;
    I->last_successful_time = 0.0;
    I->y_valid = 0;
    I->pre_valid = 0;
    I->enew_ready = 0;
    I->edot_new_ready = 0;
    I->edot_valid = 0;
    I->fcur_valid = 0;
    I->xdot_valid = 0;
    I->dir_valid = 0;
    I->h_adapt = 0.0;
    I->n_rhs = I->n_accepted = I->n_rejected = I->n_evt = I->n_events = 0;
}

#endif /* GW_UNITY_BUILD */
