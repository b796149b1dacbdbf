/*
 * gw_eval.c -- model evaluation: the generated CasADi functions (gw_model.h) called with
 * per-instance arg/res/iw/w buffers sized by their *_work functions, so that instances
 * evaluate independently (CasADi SX functions are reentrant then; mem is always 0).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <string.h>

#include "gw_instance.h"

GW_INTERNAL int gw_fun_alloc(gw_instance *I, gw_fun *f, const gw_function *g, gw_int n_in,
                             gw_int n_out) {
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

GW_INTERNAL void gw_fun_free(gw_instance *I, gw_fun *f) {
    gw_free(I, (void *)f->arg);
    gw_free(I, f->res);
    gw_free(I, f->iw);
    gw_free(I, f->w);
    memset(f, 0, sizeof(*f));
}

static void gw_fun_bind_up(gw_fun *f, const double *u, const double *p) {
    if (!f->eval) return;
    f->arg[2] = u;
    f->arg[3] = p;
}

GW_INTERNAL void gw_fun_bind(gw_instance *I) {
    gw_fun_bind_up(&I->f_ode, I->u, I->p);
    gw_fun_bind_up(&I->f_out, I->u, I->p);
    gw_fun_bind_up(&I->f_evt, I->u, I->p);
    gw_fun_bind_up(&I->f_jac, I->u, I->p);
    gw_fun_bind_up(&I->f_dir, I->u, I->p);
    gw_fun_bind_up(&I->f_upd, I->u, I->p);
    if (I->f_pre.eval && I->f_ode.eval) I->f_ode.arg[4] = I->pre_c;
    if (I->f_pre.eval && I->f_evt.eval) I->f_evt.arg[4] = I->pre_c;
}

static int gw_fun_call(gw_fun *f) { return f->eval(f->arg, f->res, f->iw, f->w, 0); }

/* pre_c = ode_pre(p), the parameter-only part of ode and evt, once per parameter change */
GW_INTERNAL int gw_eval_pre(gw_instance *I) {
    if (!I->f_pre.eval || I->pre_valid) return 0;
    I->f_pre.arg[0] = I->p;
    I->f_pre.res[0] = I->pre_c;
    if (gw_fun_call(&I->f_pre) != 0) return -1;
    I->pre_valid = 1;
    return 0;
}

/* f(t, x, u, p) -> out; the pointer to t never outlives the call */
static int gw_fun_call_txup(gw_fun *f, double t, const double *x, double *out) {
    double tt = t;
    int r;
    f->arg[0] = &tt;
    f->arg[1] = x;
    f->res[0] = out;
    r = gw_fun_call(f);
    f->arg[0] = NULL;
    return r;
}

GW_API int gw_eval_init(gw_instance *I, double *x_out) {
    if (!I->f_init.eval) return -1;
    I->f_init.arg[0] = I->s;
    I->f_init.arg[1] = I->p;
    I->f_init.res[0] = x_out;
    return gw_fun_call(&I->f_init);
}

GW_API int gw_eval_out(gw_instance *I, double t, const double *x, double *y_out) {
    if (!I->f_out.eval) return I->m->ny == 0 ? 0 : -1;
    return gw_fun_call_txup(&I->f_out, t, x, y_out);
}

GW_API int gw_eval_evt(gw_instance *I, double t, const double *x, double *e_out) {
    if (!I->f_evt.eval) return I->m->ne == 0 ? 0 : -1;
    I->n_evt++;
    if (gw_eval_pre(I) != 0) return -1;
    return gw_fun_call_txup(&I->f_evt, t, x, e_out);
}

GW_API int gw_eval_chk(gw_instance *I, double *c_out) {
    if (!I->f_chk.eval) return I->m->nc == 0 ? 0 : -1;
    I->f_chk.arg[0] = I->s;
    I->f_chk.arg[1] = I->p;
    I->f_chk.res[0] = c_out;
    return gw_fun_call(&I->f_chk);
}

GW_API int gw_eval_nom(gw_instance *I, double *nom_out) {
    int i;
    if (!I->f_nom.eval) {
        for (i = 0; i < I->m->nx; i++) nom_out[i] = 1.0;
        return 0;
    }
    I->f_nom.arg[0] = I->p;
    I->f_nom.res[0] = nom_out;
    return gw_fun_call(&I->f_nom);
}

GW_API int gw_eval_dir(gw_instance *I, double t, const double *x, double *D) {
    if (!I->f_dir.eval) return -1;
    return gw_fun_call_txup(&I->f_dir, t, x, D);
}

GW_API int gw_eval_dini(gw_instance *I, double t, double *D0) {
    double tt = t;
    int r;
    if (!I->f_dini.eval) return -1;
    I->f_dini.arg[0] = &tt;
    I->f_dini.arg[1] = I->s;
    I->f_dini.arg[2] = I->u;
    I->f_dini.arg[3] = I->p;
    I->f_dini.res[0] = D0;
    r = gw_fun_call(&I->f_dini);
    I->f_dini.arg[0] = NULL;
    return r;
}

GW_INTERNAL int gw_eval_jac(gw_instance *I, double t, const double *x, double *J) {
    if (!I->f_jac.eval) return -1;
    return gw_fun_call_txup(&I->f_jac, t, x, J);
}

GW_INTERNAL int gw_eval_upd(gw_instance *I, double t, const double *x, int k, double *x_out) {
    double kk = (double)k;
    int r;
    if (!I->f_upd.eval) return -1;
    I->f_upd.arg[4] = &kk;
    r = gw_fun_call_txup(&I->f_upd, t, x, x_out);
    I->f_upd.arg[4] = NULL;
    return r;
}

GW_API int gw_rhs(gw_instance *I, double t, const double *x, double *xdot) {
    I->n_rhs++;
    if (gw_eval_pre(I) != 0) return -1;
    return gw_fun_call_txup(&I->f_ode, t, x, xdot);
}

#endif /* GW_UNITY_BUILD */
