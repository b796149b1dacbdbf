/*
 * gw_instance.c -- allocation of one instance (all through the importer's
 * allocateMemory/freeMemory), default values, and the evaluation helpers that
 * call the generated CasADi functions with per-instance work buffers.
 */
#include <math.h>
#include <string.h>

#include "gw_instance.h"

void *gw_alloc(const gw_instance *I, size_t n, size_t size) {
    void *ptr;
    if (n == 0) n = 1; /* never hand out NULL for empty vectors */
    ptr = I->cb.allocateMemory(n, size);
    if (ptr) memset(ptr, 0, n * size); /* calloc-like, whatever the importer does */
    return ptr;
}

void gw_free(const gw_instance *I, void *ptr) {
    if (ptr) I->cb.freeMemory(ptr);
}

int gw_all_finite(const double *v, int n) {
    int i;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

const char *gw_solver_name(int solver) {
    switch (solver) {
    case GW_SOLVER_EULER: return "euler";
    case GW_SOLVER_RK4: return "rk4";
    case GW_SOLVER_DOPRI5: return "dopri5";
    case GW_SOLVER_ROSENBROCK: return "rosenbrock";
    case GW_SOLVER_DOP853: return "dop853";
    default: return "unknown";
    }
}

/* ---- CasADi work buffers ------------------------------------------------- */

static int fun_alloc(gw_instance *I, gw_fun *f, const gw_function *g, gw_int n_in, gw_int n_out) {
    gw_int sz_arg = n_in, sz_res = n_out, sz_iw = 0, sz_w = 0;
    f->eval = g->eval;
    if (!g->eval) return 0;
    if (g->work && g->work(&sz_arg, &sz_res, &sz_iw, &sz_w) != 0) return -1;
    if (sz_arg < n_in) sz_arg = n_in;
    if (sz_res < n_out) sz_res = n_out;
    if (sz_iw < 0 || sz_w < 0) return -1;
    f->n_arg = sz_arg;
    f->n_res = sz_res;
    f->arg = (const double **)gw_alloc(I, (size_t)sz_arg, sizeof(const double *));
    f->res = (double **)gw_alloc(I, (size_t)sz_res, sizeof(double *));
    f->iw = (gw_int *)gw_alloc(I, (size_t)sz_iw, sizeof(gw_int));
    f->w = (double *)gw_alloc(I, (size_t)sz_w, sizeof(double));
    if (!f->arg || !f->res || !f->iw || !f->w) return -1;
    return 0;
}

static void fun_free(gw_instance *I, gw_fun *f) {
    gw_free(I, (void *)f->arg);
    gw_free(I, f->res);
    gw_free(I, f->iw);
    gw_free(I, f->w);
    memset(f, 0, sizeof(*f));
}

static char *str_dup(const gw_instance *I, const char *s) {
    size_t n = strlen(s) + 1;
    char *d = (char *)gw_alloc(I, n, 1);
    if (d) memcpy(d, s, n);
    return d;
}

#define ALLOC_VEC(ptr, type, n)                                   \
    do {                                                          \
        (ptr) = (type *)gw_alloc(I, (size_t)(n), sizeof(type));   \
        if (!(ptr)) goto fail;                                    \
    } while (0)

gw_instance *gw_instance_new(const gw_model *m, const char *name, const fmi2CallbackFunctions *cb,
                             int logging_on) {
    gw_instance *I;
    int i, nx = m->nx, ne = m->ne;
    I = (gw_instance *)cb->allocateMemory(1, sizeof(gw_instance));
    if (!I) return NULL;
    memset(I, 0, sizeof(*I));
    I->m = m;
    I->cb.logger = cb->logger;
    I->cb.allocateMemory = cb->allocateMemory;
    I->cb.freeMemory = cb->freeMemory;
    I->cb.componentEnvironment = cb->componentEnvironment;
    I->logging_on = logging_on ? 1 : 0;
    I->log_mask = logging_on ? ((1u << GW_LOG_N) - 1u) : 0u;
    I->name = str_dup(I, name);
    if (!I->name) goto fail;

    ALLOC_VEC(I->x, double, nx);
    ALLOC_VEC(I->s, double, m->ns);
    ALLOC_VEC(I->u, double, m->nu);
    ALLOC_VEC(I->p, double, m->np);
    ALLOC_VEC(I->y, double, m->ny);
    ALLOC_VEC(I->e, double, ne);
    ALLOC_VEC(I->c, double, m->nc);
    ALLOC_VEC(I->nominal, double, nx);
    ALLOC_VEC(I->flags, int, ne);
    for (i = 0; i < 7; i++) ALLOC_VEC(I->k[i], double, nx);
    ALLOC_VEC(I->xnew, double, nx);
    ALLOC_VEC(I->xtmp, double, nx);
    ALLOC_VEC(I->xev, double, nx);
    ALLOC_VEC(I->rcont, double, 5 * nx);
    ALLOC_VEC(I->enew, double, ne);
    ALLOC_VEC(I->eev, double, ne);
    ALLOC_VEC(I->x_bak, double, nx);
    ALLOC_VEC(I->e_bak, double, ne);
    ALLOC_VEC(I->flags_bak, int, ne);
    if (gw_solver_alloc(I)) goto fail;

    if (fun_alloc(I, &I->f_init, &m->init, 2, 1) || fun_alloc(I, &I->f_ode, &m->ode, 4, 1) ||
        fun_alloc(I, &I->f_out, &m->out, 4, 1) || fun_alloc(I, &I->f_evt, &m->evt, 4, 1) ||
        fun_alloc(I, &I->f_chk, &m->chk, 2, 1) || fun_alloc(I, &I->f_nom, &m->nom, 1, 1) ||
        fun_alloc(I, &I->f_jac, &m->jac, 4, 1))
        goto fail;

    /* preset argument pointers that never change (t, u, p live in the instance) */
    if (I->f_ode.eval) {
        I->f_ode.arg[2] = I->u;
        I->f_ode.arg[3] = I->p;
    }
    if (I->f_out.eval) {
        I->f_out.arg[2] = I->u;
        I->f_out.arg[3] = I->p;
    }
    if (I->f_evt.eval) {
        I->f_evt.arg[2] = I->u;
        I->f_evt.arg[3] = I->p;
    }
    if (I->f_jac.eval) {
        I->f_jac.arg[2] = I->u;
        I->f_jac.arg[3] = I->p;
    }
    gw_instance_defaults(I);
    return I;
fail:
    gw_instance_free(I);
    return NULL;
}

void gw_instance_free(gw_instance *I) {
    int i;
    void (*free_fn)(void *);
    if (!I) return;
    fun_free(I, &I->f_init);
    fun_free(I, &I->f_ode);
    fun_free(I, &I->f_out);
    fun_free(I, &I->f_evt);
    fun_free(I, &I->f_chk);
    fun_free(I, &I->f_nom);
    fun_free(I, &I->f_jac);
    gw_solver_free(I);
    gw_instance_me_free(I);
    gw_free(I, I->x);
    gw_free(I, I->s);
    gw_free(I, I->u);
    gw_free(I, I->p);
    gw_free(I, I->y);
    gw_free(I, I->e);
    gw_free(I, I->c);
    gw_free(I, I->nominal);
    gw_free(I, I->flags);
    for (i = 0; i < 7; i++) gw_free(I, I->k[i]);
    gw_free(I, I->xnew);
    gw_free(I, I->xtmp);
    gw_free(I, I->xev);
    gw_free(I, I->rcont);
    gw_free(I, I->enew);
    gw_free(I, I->eev);
    gw_free(I, I->x_bak);
    gw_free(I, I->e_bak);
    gw_free(I, I->flags_bak);
    gw_free(I, I->name);
    free_fn = I->cb.freeMemory;
    free_fn(I);
}

/* Everything an instance holds after fmi2Instantiate / fmi2Reset. */
void gw_instance_defaults(gw_instance *I) {
    const gw_model *m = I->m;
    int i;
    I->state = GW_ST_INSTANTIATED;
    I->solver = m->default_solver;
    I->rel_tol = m->default_rel_tol;
    I->abs_tol = m->default_abs_tol;
    I->max_step = m->default_max_step;
    I->t_start = 0.0;
    I->t_stop = 0.0;
    I->stop_defined = 0;
    I->tol_defined = 0;
    I->tolerance = 0.0;
    I->t = 0.0;
    for (i = 0; i < m->ns; i++) I->s[i] = m->s_start ? m->s_start[i] : 0.0;
    for (i = 0; i < m->nu; i++) I->u[i] = m->u_start ? m->u_start[i] : 0.0;
    for (i = 0; i < m->np; i++) I->p[i] = m->p_start ? m->p_start[i] : 0.0;
    for (i = 0; i < m->nx; i++) {
        I->x[i] = 0.0;
        I->nominal[i] = 1.0;
    }
    for (i = 0; i < m->ny; i++) I->y[i] = 0.0;
    for (i = 0; i < m->ne; i++) {
        I->e[i] = 0.0;
        I->flags[i] = 0;
    }
    I->terminated = 0;
    I->last_successful_time = 0.0;
    I->last_dostep_status = fmi2OK;
    I->y_valid = 0;
    I->fcur_valid = 0;
    I->h_adapt = 0.0;
    I->n_rhs = I->n_accepted = I->n_rejected = I->n_evt = I->n_events = 0;
}

/* ---- evaluation helpers ---------------------------------------------------- */

static int call(gw_fun *f) { return f->eval(f->arg, f->res, f->iw, f->w, 0); }

int gw_eval_init(gw_instance *I, double *x_out) {
    if (!I->f_init.eval) return -1;
    I->f_init.arg[0] = I->s;
    I->f_init.arg[1] = I->p;
    I->f_init.res[0] = x_out;
    return call(&I->f_init);
}

int gw_eval_out(gw_instance *I, double t, const double *x, double *y_out) {
    double tt = t;
    int r;
    if (!I->f_out.eval) return I->m->ny == 0 ? 0 : -1;
    I->f_out.arg[0] = &tt;
    I->f_out.arg[1] = x;
    I->f_out.res[0] = y_out;
    r = call(&I->f_out);
    I->f_out.arg[0] = NULL;
    return r;
}

int gw_eval_evt(gw_instance *I, double t, const double *x, double *e_out) {
    double tt = t;
    int r;
    if (!I->f_evt.eval) return I->m->ne == 0 ? 0 : -1;
    I->f_evt.arg[0] = &tt;
    I->f_evt.arg[1] = x;
    I->f_evt.res[0] = e_out;
    I->n_evt++;
    r = call(&I->f_evt);
    I->f_evt.arg[0] = NULL;
    return r;
}

int gw_eval_chk(gw_instance *I, double *c_out) {
    if (!I->f_chk.eval) return I->m->nc == 0 ? 0 : -1;
    I->f_chk.arg[0] = I->s;
    I->f_chk.arg[1] = I->p;
    I->f_chk.res[0] = c_out;
    return call(&I->f_chk);
}

int gw_eval_nom(gw_instance *I, double *nom_out) {
    int i;
    if (!I->f_nom.eval) {
        for (i = 0; i < I->m->nx; i++) nom_out[i] = 1.0;
        return 0;
    }
    I->f_nom.arg[0] = I->p;
    I->f_nom.res[0] = nom_out;
    return call(&I->f_nom);
}

int gw_rhs(gw_instance *I, double t, const double *x, double *xdot) {
    gw_fun *f = &I->f_ode;
    double tt = t;
    int r;
    f->arg[0] = &tt;
    f->arg[1] = x;
    f->res[0] = xdot;
    I->n_rhs++;
    r = f->eval(f->arg, f->res, f->iw, f->w, 0);
    f->arg[0] = NULL; /* never leave a dangling pointer to the stack */
    return r;
}

/* ---- Model Exchange and directional derivatives ------------------------------ */

int gw_instance_me_alloc(gw_instance *I) {
    const gw_model *m = I->m;
    I->xdot = (double *)gw_alloc(I, (size_t)m->nx, sizeof(double));
    I->e_me = (double *)gw_alloc(I, (size_t)m->ne, sizeof(double));
    if (!I->xdot || !I->e_me) return -1;
    if (m->dir.eval) {
        if (fun_alloc(I, &I->f_dir, &m->dir, 4, 1)) return -1;
        I->dir_D = (double *)gw_alloc(I, (size_t)(m->nx + m->ny) * (size_t)(m->nx + m->nu),
                                      sizeof(double));
        if (!I->dir_D) return -1;
        I->f_dir.arg[2] = I->u;
        I->f_dir.arg[3] = I->p;
    }
    I->xdot_valid = 0;
    I->dir_valid = 0;
    return 0;
}

void gw_instance_me_free(gw_instance *I) {
    fun_free(I, &I->f_dir);
    gw_free(I, I->xdot);
    gw_free(I, I->e_me);
    gw_free(I, I->dir_D);
    I->xdot = I->e_me = I->dir_D = NULL;
}

int gw_eval_dir(gw_instance *I, double t, const double *x, double *D) {
    double tt = t;
    int r;
    if (!I->f_dir.eval) return -1;
    I->f_dir.arg[0] = &tt;
    I->f_dir.arg[1] = x;
    I->f_dir.res[0] = D;
    r = call(&I->f_dir);
    I->f_dir.arg[0] = NULL;
    return r;
}
