/*
 * gw_solver_rodas4.c -- the Rosenbrock method RODAS4 (Hairer & Wanner): linearisation (the
 * model's Jacobian or forward differences, and d f / d t), the LU factors of
 * W = I/(gamma h) - J, one step with its embedded error estimate, and the 3rd-order dense
 * output.  The adaptive loop (shared with DOP853) is in gw_solver.c.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <float.h>
#include <math.h>
#include <string.h>

#include "gw_solver.h"

/* ---- Rosenbrock RODAS4 coefficients -----------------------------------------------
 * E. Hairer, G. Wanner, Solving Ordinary Differential Equations II, 2nd ed., Springer
 * 1996, Sect. IV.7 (RODAS), coefficients as in Hairer's rodas.f, subroutine COEFST with
 * METH=1 ("method of Hairer & Wanner"): 6 stages, order 4, embedded order 3, stiffly
 * accurate, L-stable; dense output of order 3 (rodas.f, CONTRO).  Formulation with
 * W = I/(gamma h) - J and the stage increments k_i of rodas.f:
 *   W k_i = f(t + c_i h, x + sum_j a_ij k_j) + d_i h f_t + sum_j (c_ij / h) k_j
 * x_new = (x + sum_j a_5j k_j + k_5) + k_6 (stiffly accurate: the bracket is the
 * embedded 3rd-order solution), error estimate = k_6. */
static const double ros_gamma = 0.25;
static const double ros_c2 = 0.386, ros_c3 = 0.21, ros_c4 = 0.63;
static const double ros_d1 = 0.2500000000000000e+00, ros_d2 = -0.1043000000000000e+00,
                    ros_d3 = 0.1035000000000000e+00, ros_d4 = -0.3620000000000023e-01;
static const double ros_a21 = 0.1544000000000000e+01;
static const double ros_a31 = 0.9466785280815826e+00, ros_a32 = 0.2557011698983284e+00;
static const double ros_a41 = 0.3314825187068521e+01, ros_a42 = 0.2896124015972201e+01,
                    ros_a43 = 0.9986419139977817e+00;
static const double ros_a51 = 0.1221224509226641e+01, ros_a52 = 0.6019134481288629e+01,
                    ros_a53 = 0.1253708332932087e+02, ros_a54 = -0.6878860361058950e+00;
static const double ros_c21 = -0.5668800000000000e+01;
static const double ros_c31 = -0.2430093356833875e+01, ros_c32 = -0.2063599157091915e+00;
static const double ros_c41 = -0.1073529058151375e+00, ros_c42 = -0.9594562251023355e+01,
                    ros_c43 = -0.2047028614809616e+02;
static const double ros_c51 = 0.7496443313967647e+01, ros_c52 = -0.1024680431464352e+02,
                    ros_c53 = -0.3399990352819905e+02, ros_c54 = 0.1170890893206160e+02;
static const double ros_c61 = 0.8083246795921522e+01, ros_c62 = -0.7981132988064893e+01,
                    ros_c63 = -0.3152159432874371e+02, ros_c64 = 0.1631930543123136e+02,
                    ros_c65 = -0.6058818238834054e+01;
static const double ros_d21 = 0.1012623508344586e+02, ros_d22 = -0.7487995877610167e+01,
                    ros_d23 = -0.3480091861555747e+02, ros_d24 = -0.7992771707568823e+01,
                    ros_d25 = 0.1025137723295662e+01;
static const double ros_d31 = -0.6762803392801253e+00, ros_d32 = 0.6087714651680015e+01,
                    ros_d33 = 0.1643084320892478e+02, ros_d34 = 0.2476722511418386e+02,
                    ros_d35 = -0.6594389125716872e+01;

/* ---- Rosenbrock: Jacobian, time derivative, LU -------------------------------------- */

/* I->jac = d f / d x at (I->t, I->x) from the model's jac function, or by forward
 * differences (nx extra RHS evaluations) when the model has none; I->kx[2] = d f / d t
 * by a forward difference (one RHS evaluation).  Needs k[0] = f(t, x). */
GW_INTERNAL int gw_rodas4_linearise(gw_instance *I) {
    int i, j, nx = I->m->nx;
    const double t = I->t, *x = I->x, *f0 = I->k[0];
    double *J = I->jac, *ft = I->kx[2], *xt = I->xtmp, dt;
    if (nx == 0) return 0;
    if (I->f_jac.eval) {
        if (gw_eval_jac(I, t, x, J) != 0) {
            GW_LOG_ERR(I, "evaluation of the Jacobian failed at t=%.17g", t);
            return -1;
        }
    } else {
        memcpy(xt, x, (size_t)nx * sizeof(double));
        for (j = 0; j < nx; j++) {
            double xj = x[j], scale = fabs(xj) > I->nominal[j] ? fabs(xj) : I->nominal[j];
            double dx = sqrt(DBL_EPSILON) * scale;
            double *col = J + (size_t)j * (size_t)nx;
            xt[j] = xj + dx;
            dx = xt[j] - xj; /* the increment actually represented */
            if (gw_rhs_checked(I, t, xt, col)) return -1;
            xt[j] = xj;
            for (i = 0; i < nx; i++) col[i] = (col[i] - f0[i]) / dx;
        }
    }
    i = gw_first_nonfinite(J, nx * nx);
    if (i >= 0) {
        GW_LOG_ERR(I, "Jacobian entry d %s / d %s is not finite (%g) at t=%.17g", gw_x_name(I, i % nx),
                   gw_x_name(I, i / nx), J[i], t);
        return -1;
    }
    /* d f / d t (zero for autonomous models, up to rounding); a backward difference
     * if f is not finite just after t */
    dt = sqrt(DBL_EPSILON * (fabs(t) > 1e-5 ? fabs(t) : 1e-5));
    dt = (t + dt) - t;
    if (gw_rhs_checked(I, t + dt, x, ft)) return -1;
    if (gw_first_nonfinite(ft, nx) >= 0) {
        dt = t - (t - dt);
        if (gw_rhs_checked(I, t - dt, x, ft)) return -1;
        dt = -dt;
    }
    for (i = 0; i < nx; i++) ft[i] = (ft[i] - f0[i]) / dt;
    if (gw_first_nonfinite(ft, nx) >= 0) {
        GW_LOG_ERR(I, "time derivative of the right-hand side is not finite at t=%.17g", t);
        return -1;
    }
    return 0;
}

/* LU decomposition with partial pivoting of W = I/(gamma h) - J (column-major, in
 * I->lu, pivot rows in I->piv).  Returns 0, or 1 if W is singular to working precision. */
GW_INTERNAL int gw_rodas4_factor(gw_instance *I, double h) {
    int i, j, k, n = I->m->nx;
    const double fac = 1.0 / (ros_gamma * h);
    const size_t N = (size_t)n;
    double *A = I->lu;
    for (j = 0; j < n; j++)
        for (i = 0; i < n; i++) A[i + j * N] = -I->jac[i + j * N];
    for (i = 0; i < n; i++) A[i + i * N] += fac;
    for (k = 0; k < n; k++) {
        int p = k;
        double amax = fabs(A[k + k * N]), inv;
        for (i = k + 1; i < n; i++)
            if (fabs(A[i + k * N]) > amax) {
                amax = fabs(A[i + k * N]);
                p = i;
            }
        I->piv[k] = p;
        if (!(amax > 0.0) || !isfinite(amax)) return 1;
        if (p != k)
            for (j = 0; j < n; j++) {
                double tmp = A[k + j * N];
                A[k + j * N] = A[p + j * N];
                A[p + j * N] = tmp;
            }
        inv = 1.0 / A[k + k * N];
        for (i = k + 1; i < n; i++) A[i + k * N] *= inv;
        for (j = k + 1; j < n; j++) {
            const double akj = A[k + j * N];
            if (akj != 0.0)
                for (i = k + 1; i < n; i++) A[i + j * N] -= A[i + k * N] * akj;
        }
    }
    return 0;
}

/* b := W^-1 b with the factors of ros_factor */
static void gw_rodas4_solve(const gw_instance *I, double *b) {
    int i, k, n = I->m->nx;
    const size_t N = (size_t)n;
    const double *A = I->lu;
    for (k = 0; k < n; k++) {
        const int p = I->piv[k];
        if (p != k) {
            double tmp = b[k];
            b[k] = b[p];
            b[p] = tmp;
        }
    }
    for (k = 0; k < n; k++) {
        const double bk = b[k];
        if (bk != 0.0)
            for (i = k + 1; i < n; i++) b[i] -= A[i + k * N] * bk;
    }
    for (k = n - 1; k >= 0; k--) {
        double bk;
        b[k] /= A[k + k * N];
        bk = b[k];
        if (bk != 0.0)
            for (i = 0; i < k; i++) b[i] -= A[i + k * N] * bk;
    }
}

/* RODAS4 step with the factors of W for this h; *err = weighted RMS norm of k6.
 * Stage increments k1..k5 in I->k[1..5] (kept for the dense output), k6 in I->kx[0],
 * stage derivatives in I->kx[1], f_t in I->kx[2]. */
GW_INTERNAL int gw_rodas4_step(gw_instance *I, double h, double t1, double *err) {
    int i, nx = I->m->nx;
    const double t = I->t, *x = I->x, *f0 = I->k[0], *ft = I->kx[2];
    double *k1 = I->k[1], *k2 = I->k[2], *k3 = I->k[3], *k4 = I->k[4], *k5 = I->k[5],
           *k6 = I->kx[0], *dy = I->kx[1], *xt = I->xtmp, *xn = I->xnew;
    const double hd1 = h * ros_d1, hd2 = h * ros_d2, hd3 = h * ros_d3, hd4 = h * ros_d4;
    const double hc21 = ros_c21 / h, hc31 = ros_c31 / h, hc32 = ros_c32 / h,
                 hc41 = ros_c41 / h, hc42 = ros_c42 / h, hc43 = ros_c43 / h,
                 hc51 = ros_c51 / h, hc52 = ros_c52 / h, hc53 = ros_c53 / h,
                 hc54 = ros_c54 / h, hc61 = ros_c61 / h, hc62 = ros_c62 / h,
                 hc63 = ros_c63 / h, hc64 = ros_c64 / h, hc65 = ros_c65 / h;
    double sum = 0.0;
    I->k7_valid = 0;
    for (i = 0; i < nx; i++) k1[i] = f0[i] + hd1 * ft[i];
    gw_rodas4_solve(I, k1);
    for (i = 0; i < nx; i++) xt[i] = x[i] + ros_a21 * k1[i];
    if (gw_rhs_checked(I, t + ros_c2 * h, xt, dy)) return -1;
    for (i = 0; i < nx; i++) k2[i] = dy[i] + hd2 * ft[i] + hc21 * k1[i];
    gw_rodas4_solve(I, k2);
    for (i = 0; i < nx; i++) xt[i] = x[i] + ros_a31 * k1[i] + ros_a32 * k2[i];
    if (gw_rhs_checked(I, t + ros_c3 * h, xt, dy)) return -1;
    for (i = 0; i < nx; i++) k3[i] = dy[i] + hd3 * ft[i] + (hc31 * k1[i] + hc32 * k2[i]);
    gw_rodas4_solve(I, k3);
    for (i = 0; i < nx; i++) xt[i] = x[i] + ros_a41 * k1[i] + ros_a42 * k2[i] + ros_a43 * k3[i];
    if (gw_rhs_checked(I, t + ros_c4 * h, xt, dy)) return -1;
    for (i = 0; i < nx; i++)
        k4[i] = dy[i] + hd4 * ft[i] + (hc41 * k1[i] + hc42 * k2[i] + hc43 * k3[i]);
    gw_rodas4_solve(I, k4);
    for (i = 0; i < nx; i++)
        xt[i] = x[i] + ros_a51 * k1[i] + ros_a52 * k2[i] + ros_a53 * k3[i] + ros_a54 * k4[i];
    if (gw_rhs_checked(I, t1, xt, dy)) return -1;
    for (i = 0; i < nx; i++)
        k5[i] = dy[i] + (hc51 * k1[i] + hc52 * k2[i] + hc53 * k3[i] + hc54 * k4[i]);
    gw_rodas4_solve(I, k5);
    for (i = 0; i < nx; i++) xt[i] += k5[i]; /* embedded 3rd-order solution */
    if (gw_rhs_checked(I, t1, xt, dy)) return -1;
    for (i = 0; i < nx; i++)
        k6[i] = dy[i] + (hc61 * k1[i] + hc62 * k2[i] + hc63 * k3[i] + hc64 * k4[i] +
                         hc65 * k5[i]);
    gw_rodas4_solve(I, k6);
    for (i = 0; i < nx; i++) /* x_new - x, summed apart from x (compensated below) */
        I->dx[i] = (ros_a51 * k1[i] + ros_a52 * k2[i] + ros_a53 * k3[i] + ros_a54 * k4[i] + k5[i]) +
                   k6[i];
    gw_sum_update(I);
    for (i = 0; i < nx; i++) {
        double ax = fabs(x[i]), an, sk, r;
        an = fabs(xn[i]);
        sk = I->atol_eff * I->nominal[i] + I->rel_tol * (ax > an ? ax : an);
        r = k6[i] / sk;
        sum += r * r;
    }
    *err = nx > 0 ? sqrt(sum / nx) : 0.0;
    return 0;
}

/* ---- dense output ------------------------------------------------------------ */

/* RODAS4 continuous extension of order 3 (rodas.f, CONTRO):
 * x(t0 + th h) = x0 + th (x1 - x0) + th (1 - th) (r2 + th r3) */
GW_INTERNAL void gw_rodas4_dense(gw_instance *I) {
    int i, nx = I->m->nx;
    const double *x = I->x, *xn = I->xnew;
    const double *q1 = I->k[1], *q2 = I->k[2], *q3 = I->k[3], *q4 = I->k[4], *q5 = I->k[5];
    double *r0 = I->rcont, *r1 = r0 + nx, *r2 = r1 + nx, *r3 = r2 + nx, *r4 = r3 + nx;
    for (i = 0; i < nx; i++) {
        r0[i] = x[i];
        r1[i] = xn[i] - x[i];
        r2[i] = ros_d21 * q1[i] + ros_d22 * q2[i] + ros_d23 * q3[i] + ros_d24 * q4[i] +
                ros_d25 * q5[i];
        r3[i] = ros_d31 * q1[i] + ros_d32 * q2[i] + ros_d33 * q3[i] + ros_d34 * q4[i] +
                ros_d35 * q5[i];
        r4[i] = 0.0;
    }
}

#endif /* GW_UNITY_BUILD */
