/*
 * gw_solver.c -- internal integrators (explicit Euler, RK4, Dormand-Prince 5(4),
 * Dormand-Prince 8(5,3), Rosenbrock RODAS4), their dense output, and the loops that
 * integrate one communication step exactly to its end, handing every accepted step
 * to the event module.
 * No memory is allocated while integrating: all work vectors live in the instance
 * (gw_solver_alloc at instantiation).
 */
#include <float.h>
#include <math.h>
#include <string.h>

#include "gw_solver.h"

/* ---- Dormand-Prince 5(4) coefficients (Hairer, Norsett, Wanner) ---------- */
static const double c2 = 1.0 / 5.0, c3 = 3.0 / 10.0, c4 = 4.0 / 5.0, c5 = 8.0 / 9.0;
static const double a21 = 1.0 / 5.0;
static const double a31 = 3.0 / 40.0, a32 = 9.0 / 40.0;
static const double a41 = 44.0 / 45.0, a42 = -56.0 / 15.0, a43 = 32.0 / 9.0;
static const double a51 = 19372.0 / 6561.0, a52 = -25360.0 / 2187.0, a53 = 64448.0 / 6561.0,
                    a54 = -212.0 / 729.0;
static const double a61 = 9017.0 / 3168.0, a62 = -355.0 / 33.0, a63 = 46732.0 / 5247.0,
                    a64 = 49.0 / 176.0, a65 = -5103.0 / 18656.0;
static const double a71 = 35.0 / 384.0, a73 = 500.0 / 1113.0, a74 = 125.0 / 192.0,
                    a75 = -2187.0 / 6784.0, a76 = 11.0 / 84.0;
static const double e1 = 71.0 / 57600.0, e3 = -71.0 / 16695.0, e4 = 71.0 / 1920.0,
                    e5 = -17253.0 / 339200.0, e6 = 22.0 / 525.0, e7 = -1.0 / 40.0;
static const double d1 = -12715105075.0 / 11282082432.0, d3 = 87487479700.0 / 32700410799.0,
                    d4 = -10690763975.0 / 1880347072.0, d5 = 701980252875.0 / 199316789632.0,
                    d6 = -1453857185.0 / 822651844.0, d7 = 69997945.0 / 29380423.0;

/* ---- Dormand-Prince 8(5,3) coefficients -----------------------------------------
 * E. Hairer, S.P. Norsett, G. Wanner, Solving Ordinary Differential Equations I,
 * 2nd ed., Springer 1993, Sect. II.5 and II.6 (DOP853), decimal values as in Hairer's
 * dop853.f (also scipy.integrate's dop853_coefficients.py).  Row s of dop_a gives the
 * argument of stage s (0-based; stage 12 is f(t+h, x_new), FSAL); stages 13..15 are
 * the extra stages of the 7th-order dense output. */
static const double dop_c[16] = {
    0.0, 0.526001519587677318785587544488e-01, 0.789002279381515978178381316732e-01,
    0.118350341907227396726757197510, 0.281649658092772603273242802490,
    0.333333333333333333333333333333, 0.25, 0.307692307692307692307692307692,
    0.651282051282051282051282051282, 0.6, 0.857142857142857142857142857142, 1.0, 1.0, 0.1,
    0.2, 0.777777777777777777777777777778};
static const double dop_a[16][16] = {
    [1] = {[0] = 5.26001519587677318785587544488e-2},
    [2] = {[0] = 1.97250569845378994544595329183e-2, [1] = 5.91751709536136983633785987549e-2},
    [3] = {[0] = 2.95875854768068491816892993775e-2, [2] = 8.87627564304205475450678981324e-2},
    [4] = {[0] = 2.41365134159266685502369798665e-1, [2] = -8.84549479328286085344864962717e-1,
           [3] = 9.24834003261792003115737966543e-1},
    [5] = {[0] = 3.7037037037037037037037037037e-2, [3] = 1.70828608729473871279604482173e-1,
           [4] = 1.25467687566822425016691814123e-1},
    [6] = {[0] = 3.7109375e-2, [3] = 1.70252211019544039314978060272e-1,
           [4] = 6.02165389804559606850219397283e-2, [5] = -1.7578125e-2},
    [7] = {[0] = 3.70920001185047927108779319836e-2, [3] = 1.70383925712239993810214054705e-1,
           [4] = 1.07262030446373284651809199168e-1, [5] = -1.53194377486244017527936158236e-2,
           [6] = 8.27378916381402288758473766002e-3},
    [8] = {[0] = 6.24110958716075717114429577812e-1, [3] = -3.36089262944694129406857109825,
           [4] = -8.68219346841726006818189891453e-1, [5] = 2.75920996994467083049415600797e1,
           [6] = 2.01540675504778934086186788979e1, [7] = -4.34898841810699588477366255144e1},
    [9] = {[0] = 4.77662536438264365890433908527e-1, [3] = -2.48811461997166764192642586468,
           [4] = -5.90290826836842996371446475743e-1, [5] = 2.12300514481811942347288949897e1,
           [6] = 1.52792336328824235832596922938e1, [7] = -3.32882109689848629194453265587e1,
           [8] = -2.03312017085086261358222928593e-2},
    [10] = {[0] = -9.3714243008598732571704021658e-1, [3] = 5.18637242884406370830023853209,
            [4] = 1.09143734899672957818500254654, [5] = -8.14978701074692612513997267357,
            [6] = -1.85200656599969598641566180701e1, [7] = 2.27394870993505042818970056734e1,
            [8] = 2.49360555267965238987089396762, [9] = -3.0467644718982195003823669022},
    [11] = {[0] = 2.27331014751653820792359768449, [3] = -1.05344954667372501984066689879e1,
            [4] = -2.00087205822486249909675718444, [5] = -1.79589318631187989172765950534e1,
            [6] = 2.79488845294199600508499808837e1, [7] = -2.85899827713502369474065508674,
            [8] = -8.87285693353062954433549289258, [9] = 1.23605671757943030647266201528e1,
            [10] = 6.43392746015763530355970484046e-1},
    [13] = {[0] = 5.61675022830479523392909219681e-2, [6] = 2.53500210216624811088794765333e-1,
            [7] = -2.46239037470802489917441475441e-1, [8] = -1.24191423263816360469010140626e-1,
            [9] = 1.5329179827876569731206322685e-1, [10] = 8.20105229563468988491666602057e-3,
            [11] = 7.56789766054569976138603589584e-3, [12] = -8.298e-3},
    [14] = {[0] = 3.18346481635021405060768473261e-2, [5] = 2.83009096723667755288322961402e-2,
            [6] = 5.35419883074385676223797384372e-2, [7] = -5.49237485713909884646569340306e-2,
            [10] = -1.08347328697249322858509316994e-4, [11] = 3.82571090835658412954920192323e-4,
            [12] = -3.40465008687404560802977114492e-4, [13] = 1.41312443674632500278074618366e-1},
    [15] = {[0] = -4.28896301583791923408573538692e-1, [5] = -4.69762141536116384314449447206,
            [6] = 7.68342119606259904184240953878, [7] = 4.06898981839711007970213554331,
            [8] = 3.56727187455281109270669543021e-1, [12] = -1.39902416515901462129418009734e-3,
            [13] = 2.9475147891527723389556272149, [14] = -9.15095847217987001081870187138},
};
/* weights of the 8th-order solution */
static const double dop_b[12] = {
    [0] = 5.42937341165687622380535766363e-2, [5] = 4.45031289275240888144113950566,
    [6] = 1.89151789931450038304281599044,    [7] = -5.8012039600105847814672114227,
    [8] = 3.1116436695781989440891606237e-1,  [9] = -1.52160949662516078556178806805e-1,
    [10] = 2.01365400804030348374776537501e-1, [11] = 4.47106157277725905176885569043e-2};
/* 3rd-order error estimator: b - bhh on stages 0, 8, 11 */
static const double dop_bhh0 = 0.244094488188976377952755905512,
                    dop_bhh8 = 0.733846688281611857341361741547,
                    dop_bhh11 = 0.220588235294117647058823529412e-01;
/* 5th-order error estimator (ER1, ER6..ER12 of dop853.f) */
static const double dop_e5[12] = {
    [0] = 0.1312004499419488073250102996e-1, [5] = -0.1225156446376204440720569753e+1,
    [6] = -0.4957589496572501915214079952,   [7] = 0.1664377182454986536961530415e+1,
    [8] = -0.3503288487499736816886487290,   [9] = 0.3341791187130174790297318841,
    [10] = 0.8192320648511571246570742613e-1, [11] = -0.2235530786388629525884427845e-1};
/* dense output: the 4 highest coefficients (D4x..D7x of dop853.f) on stages 0..15 */
static const double dop_d[4][16] = {
    {[0] = -0.84289382761090128651353491142e+1, [5] = 0.56671495351937776962531783590,
     [6] = -0.30689499459498916912797304727e+1, [7] = 0.23846676565120698287728149680e+1,
     [8] = 0.21170345824450282767155149946e+1, [9] = -0.87139158377797299206789907490,
     [10] = 0.22404374302607882758541771650e+1, [11] = 0.63157877876946881815570249290,
     [12] = -0.88990336451333310820698117400e-1, [13] = 0.18148505520854727256656404962e+2,
     [14] = -0.91946323924783554000451984436e+1, [15] = -0.44360363875948939664310572000e+1},
    {[0] = 0.10427508642579134603413151009e+2, [5] = 0.24228349177525818288430175319e+3,
     [6] = 0.16520045171727028198505394887e+3, [7] = -0.37454675472269020279518312152e+3,
     [8] = -0.22113666853125306036270938578e+2, [9] = 0.77334326684722638389603898808e+1,
     [10] = -0.30674084731089398182061213626e+2, [11] = -0.93321305264302278729567221706e+1,
     [12] = 0.15697238121770843886131091075e+2, [13] = -0.31139403219565177677282850411e+2,
     [14] = -0.93529243588444783865713862664e+1, [15] = 0.35816841486394083752465898540e+2},
    {[0] = 0.19985053242002433820987653617e+2, [5] = -0.38703730874935176555105901742e+3,
     [6] = -0.18917813819516756882830838328e+3, [7] = 0.52780815920542364900561016686e+3,
     [8] = -0.11573902539959630126141871134e+2, [9] = 0.68812326946963000169666922661e+1,
     [10] = -0.10006050966910838403183860980e+1, [11] = 0.77771377980534432092869265740,
     [12] = -0.27782057523535084065932004339e+1, [13] = -0.60196695231264120758267380846e+2,
     [14] = 0.84320405506677161018159903784e+2, [15] = 0.11992291136182789328035130030e+2},
    {[0] = -0.25693933462703749003312586129e+2, [5] = -0.15418974869023643374053993627e+3,
     [6] = -0.23152937917604549567536039109e+3, [7] = 0.35763911791061412378285349910e+3,
     [8] = 0.93405324183624310003907691704e+2, [9] = -0.37458323136451633156875139351e+2,
     [10] = 0.10409964950896230045147246184e+3, [11] = 0.29840293426660503123344363579e+2,
     [12] = -0.43533456590011143754432175058e+2, [13] = 0.96324553959188282948394950600e+2,
     [14] = -0.39177261675615439165231486172e+2, [15] = -0.14972683625798562581422125276e+3},
};

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

/* Feasibility guard: a communication step whose remainder would need more than
 * GW_MAX_STEPS_AHEAD internal steps at the step size the controller has settled on is refused
 * at once with a reason instead of running for hours (absurd rates, wrong solver).
 * "Settled": GW_SETTLE consecutive attempts, each after an accepted step and not growing h by
 * more than 2x, all projecting too many steps.  A transient (Rosenbrock at 1e9 rad/s resolves
 * the nutation with h = 4e-9 s for a while, then damps it and takes 0.05 s steps) or a wall
 * approached by accepted / rejected steps (a right-hand side turning NaN ends in the step size
 * underflow error) breaks the run.  Steps the controller chose for accuracy (h < max_step) get
 * the tighter limit GW_MAX_STEPS_CONTROLLED: DOP853 settles at h = 4.6e-9 s for gamma_dot =
 * 1e9 rad/s (2e8 steps, minutes, for a 1 s step), DOPRI5 at 7.6e-10 s.  Steps held at max_step
 * are the user's explicit choice and keep the limit of the fixed-step solvers. */
#define GW_MAX_STEPS_AHEAD 1e9
#define GW_MAX_STEPS_CONTROLLED 1e8
#define GW_SETTLE 100

static int too_many_steps(gw_instance *I, double remaining, double h, double h_prev,
                          int rejected_last, unsigned long *n_fast) {
    const double limit = h < I->max_step ? GW_MAX_STEPS_CONTROLLED : GW_MAX_STEPS_AHEAD;
    if (rejected_last || h > 2.0 * h_prev || !(remaining > limit * h)) {
        *n_fast = 0;
        return 0;
    }
    if (++(*n_fast) <= GW_SETTLE) return 0;
    GW_ERROR(I, "at t=%.17g the remaining %g s of this communication step would need about %.3g "
             "internal steps of h=%g (limit %.0e): the dynamics are far too fast for the tolerance "
             "(huge rates?)%s", I->t, remaining, remaining / h, h, limit,
             I->solver == GW_SOLVER_ROSENBROCK ? "" : " or stiff (try solver rosenbrock)");
    return 1;
}

double gw_h_min(double t) {
    double at = fabs(t);
    return 16.0 * DBL_EPSILON * (at > 1.0 ? at : 1.0);
}

static const char *x_name(const gw_instance *I, int i) {
    return (I->m->x_names && I->m->x_names[i]) ? I->m->x_names[i] : "?";
}

static int first_nonfinite(const double *v, int n) {
    int i;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i])) return i;
    return -1;
}

/* Make k[0] = f(t, x) (reused across steps: FSAL / end-point derivative). */
static int ensure_f0(gw_instance *I) {
    int bad;
    if (I->fcur_valid) return 0;
    if (gw_rhs(I, I->t, I->x, I->k[0]) != 0) {
        GW_ERROR(I, "evaluation of the right-hand side failed at t=%.17g", I->t);
        return -1;
    }
    bad = first_nonfinite(I->k[0], I->m->nx);
    if (bad >= 0) {
        GW_ERROR(I, "derivative of state %s is not finite (%g) at t=%.17g", x_name(I, bad),
                 I->k[0][bad], I->t);
        return -1;
    }
    I->fcur_valid = 1;
    return 0;
}

static int rhs(gw_instance *I, double t, const double *x, double *xdot) {
    if (gw_rhs(I, t, x, xdot) != 0) {
        GW_ERROR(I, "evaluation of the right-hand side failed at t=%.17g", t);
        return -1;
    }
    return 0;
}

/* ---- single steps from (I->t, I->x) to t1 = I->t + h: result in I->xnew ---- */

static int step_euler(gw_instance *I, double h) {
    int i, nx = I->m->nx;
    const double *x = I->x, *k1 = I->k[0];
    for (i = 0; i < nx; i++) I->xnew[i] = x[i] + h * k1[i];
    I->k7_valid = 0;
    return 0;
}

/* max_i |a_i - b_i| / nominal_i */
static double scaled_diff(const gw_instance *I, const double *a, const double *b) {
    int i;
    double m = 0.0;
    for (i = 0; i < I->m->nx; i++) {
        double d = fabs(a[i] - b[i]) / I->nominal[i];
        if (d > m || d != d) m = d;
    }
    return m;
}

/* Explicit fixed steps far beyond their stability limit produce garbage that can cross event
 * indicators; refuse them. For f = lambda y the RK4 stages give |k3 - k2| / |k2 - k1| =
 * h |lambda| / 2, which is O(h) for a resolved motion: above GW_RK4_UNSTABLE (h |lambda| > 20,
 * RK4 is stable up to 2.8) the step means nothing. */
#define GW_RK4_UNSTABLE 10.0

static int rk4_unstable(gw_instance *I, double h) {
    const double d21 = scaled_diff(I, I->k[1], I->k[0]), d32 = scaled_diff(I, I->k[2], I->k[1]);
    double k1 = 0.0;
    int i;
    for (i = 0; i < I->m->nx; i++) {
        double a = fabs(I->k[0][i]) / I->nominal[i];
        if (a > k1) k1 = a;
    }
    if (!(d32 > GW_RK4_UNSTABLE * d21) || !(d32 > 1e-6 * k1)) return 0;
    GW_ERROR(I, "rk4 is unstable at t=%.17g with max_step=%g: h |lambda| ~ %.3g (stable up to 2.8); "
             "the dynamics are faster than the step: reduce max_step or use an adaptive solver",
             I->t, h, d21 > 0.0 ? 2.0 * d32 / d21 : HUGE_VAL);
    return 1;
}

static int step_rk4(gw_instance *I, double h, double t1) {
    int i, nx = I->m->nx;
    const double t = I->t, hh = 0.5 * h;
    const double *x = I->x;
    double *k1 = I->k[0], *k2 = I->k[1], *k3 = I->k[2], *k4 = I->k[3], *xt = I->xtmp;
    for (i = 0; i < nx; i++) xt[i] = x[i] + hh * k1[i];
    if (rhs(I, t + hh, xt, k2)) return -1;
    for (i = 0; i < nx; i++) xt[i] = x[i] + hh * k2[i];
    if (rhs(I, t + hh, xt, k3)) return -1;
    if (rk4_unstable(I, h)) return -1;
    for (i = 0; i < nx; i++) xt[i] = x[i] + h * k3[i];
    if (rhs(I, t1, xt, k4)) return -1;
    for (i = 0; i < nx; i++)
        I->xnew[i] = x[i] + (h / 6.0) * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
    I->k7_valid = 0;
    return 0;
}

/* DOPRI5 step; *err = weighted RMS error norm (NaN/inf when something overflowed). */
static int step_dopri5(gw_instance *I, double h, double t1, double *err) {
    int i, nx = I->m->nx;
    const double t = I->t, *x = I->x, *nom = I->nominal;
    const double rtol = I->rel_tol, atol = I->abs_tol;
    double *k1 = I->k[0], *k2 = I->k[1], *k3 = I->k[2], *k4 = I->k[3], *k5 = I->k[4],
           *k6 = I->k[5], *k7 = I->k[6], *xt = I->xtmp, *xn = I->xnew;
    double sum = 0.0;
    for (i = 0; i < nx; i++) xt[i] = x[i] + h * a21 * k1[i];
    if (rhs(I, t + c2 * h, xt, k2)) return -1;
    for (i = 0; i < nx; i++) xt[i] = x[i] + h * (a31 * k1[i] + a32 * k2[i]);
    if (rhs(I, t + c3 * h, xt, k3)) return -1;
    for (i = 0; i < nx; i++) xt[i] = x[i] + h * (a41 * k1[i] + a42 * k2[i] + a43 * k3[i]);
    if (rhs(I, t + c4 * h, xt, k4)) return -1;
    for (i = 0; i < nx; i++)
        xt[i] = x[i] + h * (a51 * k1[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i]);
    if (rhs(I, t + c5 * h, xt, k5)) return -1;
    for (i = 0; i < nx; i++)
        xt[i] = x[i] + h * (a61 * k1[i] + a62 * k2[i] + a63 * k3[i] + a64 * k4[i] + a65 * k5[i]);
    if (rhs(I, t1, xt, k6)) return -1;
    for (i = 0; i < nx; i++)
        xn[i] = x[i] + h * (a71 * k1[i] + a73 * k3[i] + a74 * k4[i] + a75 * k5[i] + a76 * k6[i]);
    if (rhs(I, t1, xn, k7)) return -1;
    I->k7_valid = 1;
    for (i = 0; i < nx; i++) {
        double ax = fabs(x[i]), an = fabs(xn[i]);
        double sk = atol * nom[i] + rtol * (ax > an ? ax : an);
        double ei = h * (e1 * k1[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i] + e6 * k6[i] +
                         e7 * k7[i]);
        double r = ei / sk;
        sum += r * r;
    }
    *err = nx > 0 ? sqrt(sum / nx) : 0.0;
    return 0;
}

/* DOP853 stage vectors: 0..5 in I->k[0..5], 6..11 in I->kx[0..5], 12 (f at the end
 * point, FSAL) in I->k[6] so that accept_step hands it on as the next k[0], 13..15
 * (dense output) in I->kx[6..8]. */
static void dop853_stages(const gw_instance *I, double *K[16]) {
    int s;
    for (s = 0; s < 6; s++) K[s] = I->k[s];
    for (s = 6; s < 12; s++) K[s] = I->kx[s - 6];
    K[12] = I->k[6];
    for (s = 13; s < 16; s++) K[s] = I->kx[s - 7];
}

/* xt = x + h * sum_{j<s} dop_a[s][j] K[j] */
static void dop853_arg(const gw_instance *I, double *const K[16], int s, double h, double *xt) {
    int i, j, nx = I->m->nx;
    const double *a = dop_a[s];
    for (i = 0; i < nx; i++) {
        double acc = 0.0;
        for (j = 0; j < s; j++)
            if (a[j] != 0.0) acc += a[j] * K[j][i];
        xt[i] = I->x[i] + h * acc;
    }
}

/* DOP853 step (12 stages); *err = Hairer's combined 5th/3rd-order error norm with the
 * DOPRI5 weights.  f(t1, xnew) is not evaluated here (only for accepted steps). */
static int step_dop853(gw_instance *I, double h, double t1, double *err) {
    int i, j, s, nx = I->m->nx;
    const double t = I->t, *x = I->x, *nom = I->nominal;
    const double rtol = I->rel_tol, atol = I->abs_tol;
    double *K[16], *xt = I->xtmp, *xn = I->xnew;
    double err5 = 0.0, err3 = 0.0, deno;
    dop853_stages(I, K);
    I->k7_valid = 0;
    for (s = 1; s < 12; s++) {
        dop853_arg(I, K, s, h, xt);
        if (rhs(I, s == 11 ? t1 : t + dop_c[s] * h, xt, K[s])) return -1;
    }
    for (i = 0; i < nx; i++) {
        double incr = 0.0, e5 = 0.0, e3, sk, ax, an;
        for (j = 0; j < 12; j++) {
            if (dop_b[j] != 0.0) incr += dop_b[j] * K[j][i];
            if (dop_e5[j] != 0.0) e5 += dop_e5[j] * K[j][i];
        }
        xn[i] = x[i] + h * incr;
        e3 = incr - dop_bhh0 * K[0][i] - dop_bhh8 * K[8][i] - dop_bhh11 * K[11][i];
        ax = fabs(x[i]);
        an = fabs(xn[i]);
        sk = atol * nom[i] + rtol * (ax > an ? ax : an);
        err5 += (e5 / sk) * (e5 / sk);
        err3 += (e3 / sk) * (e3 / sk);
    }
    deno = err5 + 0.01 * err3;
    if (deno <= 0.0) deno = 1.0;
    *err = nx > 0 ? fabs(h) * err5 * sqrt(1.0 / ((double)nx * deno)) : 0.0;
    return 0;
}

/* ---- Rosenbrock: Jacobian, time derivative, LU -------------------------------------- */

/* I->jac = d f / d x at (I->t, I->x) from the model's jac function, or by forward
 * differences (nx extra RHS evaluations) when the model has none; I->kx[2] = d f / d t
 * by a forward difference (one RHS evaluation).  Needs k[0] = f(t, x). */
static int ros_linearise(gw_instance *I) {
    int i, j, nx = I->m->nx;
    const double t = I->t, *x = I->x, *f0 = I->k[0];
    double *J = I->jac, *ft = I->kx[2], *xt = I->xtmp, dt;
    if (nx == 0) return 0;
    if (I->f_jac.eval) {
        gw_fun *f = &I->f_jac;
        double tt = t;
        int r;
        f->arg[0] = &tt;
        f->arg[1] = x;
        f->res[0] = J;
        r = f->eval(f->arg, f->res, f->iw, f->w, 0);
        f->arg[0] = NULL;
        if (r != 0) {
            GW_ERROR(I, "evaluation of the Jacobian failed at t=%.17g", t);
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
            if (rhs(I, t, xt, col)) return -1;
            xt[j] = xj;
            for (i = 0; i < nx; i++) col[i] = (col[i] - f0[i]) / dx;
        }
    }
    i = first_nonfinite(J, nx * nx);
    if (i >= 0) {
        GW_ERROR(I, "Jacobian entry d %s / d %s is not finite (%g) at t=%.17g", x_name(I, i % nx),
                 x_name(I, i / nx), J[i], t);
        return -1;
    }
    /* d f / d t (zero for autonomous models, up to rounding); a backward difference
     * if f is not finite just after t */
    dt = sqrt(DBL_EPSILON * (fabs(t) > 1e-5 ? fabs(t) : 1e-5));
    dt = (t + dt) - t;
    if (rhs(I, t + dt, x, ft)) return -1;
    if (first_nonfinite(ft, nx) >= 0) {
        dt = t - (t - dt);
        if (rhs(I, t - dt, x, ft)) return -1;
        dt = -dt;
    }
    for (i = 0; i < nx; i++) ft[i] = (ft[i] - f0[i]) / dt;
    if (first_nonfinite(ft, nx) >= 0) {
        GW_ERROR(I, "time derivative of the right-hand side is not finite at t=%.17g", t);
        return -1;
    }
    return 0;
}

/* LU decomposition with partial pivoting of W = I/(gamma h) - J (column-major, in
 * I->lu, pivot rows in I->piv).  Returns 0, or 1 if W is singular to working precision. */
static int ros_factor(gw_instance *I, double h) {
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
static void ros_solve(const gw_instance *I, double *b) {
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
static int step_rosenbrock(gw_instance *I, double h, double t1, double *err) {
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
    ros_solve(I, k1);
    for (i = 0; i < nx; i++) xt[i] = x[i] + ros_a21 * k1[i];
    if (rhs(I, t + ros_c2 * h, xt, dy)) return -1;
    for (i = 0; i < nx; i++) k2[i] = dy[i] + hd2 * ft[i] + hc21 * k1[i];
    ros_solve(I, k2);
    for (i = 0; i < nx; i++) xt[i] = x[i] + ros_a31 * k1[i] + ros_a32 * k2[i];
    if (rhs(I, t + ros_c3 * h, xt, dy)) return -1;
    for (i = 0; i < nx; i++) k3[i] = dy[i] + hd3 * ft[i] + (hc31 * k1[i] + hc32 * k2[i]);
    ros_solve(I, k3);
    for (i = 0; i < nx; i++) xt[i] = x[i] + ros_a41 * k1[i] + ros_a42 * k2[i] + ros_a43 * k3[i];
    if (rhs(I, t + ros_c4 * h, xt, dy)) return -1;
    for (i = 0; i < nx; i++)
        k4[i] = dy[i] + hd4 * ft[i] + (hc41 * k1[i] + hc42 * k2[i] + hc43 * k3[i]);
    ros_solve(I, k4);
    for (i = 0; i < nx; i++)
        xt[i] = x[i] + ros_a51 * k1[i] + ros_a52 * k2[i] + ros_a53 * k3[i] + ros_a54 * k4[i];
    if (rhs(I, t1, xt, dy)) return -1;
    for (i = 0; i < nx; i++)
        k5[i] = dy[i] + (hc51 * k1[i] + hc52 * k2[i] + hc53 * k3[i] + hc54 * k4[i]);
    ros_solve(I, k5);
    for (i = 0; i < nx; i++) xt[i] += k5[i]; /* embedded 3rd-order solution */
    if (rhs(I, t1, xt, dy)) return -1;
    for (i = 0; i < nx; i++)
        k6[i] = dy[i] + (hc61 * k1[i] + hc62 * k2[i] + hc63 * k3[i] + hc64 * k4[i] +
                         hc65 * k5[i]);
    ros_solve(I, k6);
    for (i = 0; i < nx; i++) {
        double ax = fabs(x[i]), an, sk, r;
        xn[i] = xt[i] + k6[i];
        an = fabs(xn[i]);
        sk = I->abs_tol * I->nominal[i] + I->rel_tol * (ax > an ? ax : an);
        r = k6[i] / sk;
        sum += r * r;
    }
    *err = nx > 0 ? sqrt(sum / nx) : 0.0;
    return 0;
}

/* ---- dense output ------------------------------------------------------------ */

/* DOP853's 7th-order continuous extension (dop853.f, CONTD8): three more stages,
 * then rcont[4] and rcx[0..2] = h * D K.  If a stage evaluation fails the higher terms
 * are dropped (cubic Hermite, still matching values and slopes at both ends). */
static void dense_dop853(gw_instance *I) {
    int i, j, r, s, nx = I->m->nx;
    const double h = I->dense_h, t0 = I->dense_t0;
    double *K[16], *out[4];
    dop853_stages(I, K);
    out[0] = I->rcont + 4 * nx;
    out[1] = I->rcx;
    out[2] = I->rcx + nx;
    out[3] = I->rcx + 2 * nx;
    for (s = 13; s < 16; s++) {
        dop853_arg(I, K, s, h, I->xtmp);
        if (gw_rhs(I, t0 + dop_c[s] * h, I->xtmp, K[s]) != 0 ||
            first_nonfinite(K[s], nx) >= 0) {
            for (r = 0; r < 4; r++)
                for (i = 0; i < nx; i++) out[r][i] = 0.0;
            return;
        }
    }
    for (r = 0; r < 4; r++)
        for (i = 0; i < nx; i++) {
            double acc = 0.0;
            for (j = 0; j < 16; j++)
                if (dop_d[r][j] != 0.0) acc += dop_d[r][j] * K[j][i];
            out[r][i] = h * acc;
        }
}

/* Fill rcont for the last accepted step (lazy: only when an event needs it). */
void gw_dense_prepare(gw_instance *I) {
    int i, nx = I->m->nx;
    const double h = I->dense_h;
    const double *x = I->x, *xn = I->xnew, *k1 = I->k[0], *k7 = I->k[6];
    double *r0 = I->rcont, *r1 = r0 + nx, *r2 = r1 + nx, *r3 = r2 + nx, *r4 = r3 + nx;
    if (I->dense_ready) return;
    if (I->solver == GW_SOLVER_ROSENBROCK) {
        /* RODAS4 continuous extension of order 3 (rodas.f, CONTRO):
         * x(t0 + th h) = x0 + th (x1 - x0) + th (1 - th) (r2 + th r3) */
        const double *q1 = I->k[1], *q2 = I->k[2], *q3 = I->k[3], *q4 = I->k[4],
                     *q5 = I->k[5];
        for (i = 0; i < nx; i++) {
            r0[i] = x[i];
            r1[i] = xn[i] - x[i];
            r2[i] = ros_d21 * q1[i] + ros_d22 * q2[i] + ros_d23 * q3[i] + ros_d24 * q4[i] +
                    ros_d25 * q5[i];
            r3[i] = ros_d31 * q1[i] + ros_d32 * q2[i] + ros_d33 * q3[i] + ros_d34 * q4[i] +
                    ros_d35 * q5[i];
            r4[i] = 0.0;
        }
        I->dense_ready = 1;
        return;
    }
    if (!I->k7_valid) {
        /* fixed-step solvers: end-point derivative for the cubic Hermite; it is
         * reused as k1 of the next step, so this costs nothing in the long run */
        if (gw_rhs(I, I->dense_t0 + h, xn, I->k[6]) != 0) {
            /* fall back to linear interpolation */
            for (i = 0; i < nx; i++) I->k[6][i] = (xn[i] - x[i]) / h;
        } else {
            I->k7_valid = 1;
        }
    }
    for (i = 0; i < nx; i++) {
        double ydiff = xn[i] - x[i];
        double bspl = h * k1[i] - ydiff;
        r0[i] = x[i];
        r1[i] = ydiff;
        r2[i] = bspl;
        r3[i] = ydiff - h * k7[i] - bspl;
        r4[i] = 0.0;
    }
    if (I->solver == GW_SOLVER_DOPRI5) {
        const double *k3 = I->k[2], *k4 = I->k[3], *k5 = I->k[4], *k6 = I->k[5];
        for (i = 0; i < nx; i++)
            r4[i] = h * (d1 * k1[i] + d3 * k3[i] + d4 * k4[i] + d5 * k5[i] + d6 * k6[i] +
                         d7 * k7[i]);
    }
    if (I->solver == GW_SOLVER_DOP853) dense_dop853(I);
    I->dense_ready = 1;
}

void gw_dense_eval(const gw_instance *I, double t, double *x_out) {
    int i, nx = I->m->nx;
    const double *r0 = I->rcont, *r1 = r0 + nx, *r2 = r1 + nx, *r3 = r2 + nx, *r4 = r3 + nx;
    double th, th1;
    if (t >= I->dense_t0 + I->dense_h) {
        memcpy(x_out, I->xnew, (size_t)nx * sizeof(double));
        return;
    }
    th = (t - I->dense_t0) / I->dense_h;
    if (th < 0.0) th = 0.0;
    th1 = 1.0 - th;
    if (I->solver == GW_SOLVER_DOP853) {
        const double *r5 = I->rcx, *r6 = r5 + nx, *r7 = r6 + nx;
        for (i = 0; i < nx; i++) {
            const double conv = r4[i] + th * (r5[i] + th1 * (r6[i] + th * r7[i]));
            x_out[i] = r0[i] + th * (r1[i] + th1 * (r2[i] + th * (r3[i] + th1 * conv)));
        }
        return;
    }
    for (i = 0; i < nx; i++)
        x_out[i] = r0[i] + th * (r1[i] + th1 * (r2[i] + th * (r3[i] + th1 * r4[i])));
}

/* ---- accepted steps ------------------------------------------------------------ */

static void swap_ptr(double **a, double **b) {
    double *tmp = *a;
    *a = *b;
    *b = tmp;
}

/* Accepted step (I->t, I->x) -> (t1, I->xnew): finiteness, events, commit.
 * *events counts events in this communication step (loop guard). */
static gw_int_result accept_step(gw_instance *I, double t1, int *events) {
    double te;
    gw_ev_result ev;
    int bad = first_nonfinite(I->xnew, I->m->nx);
    I->n_accepted++;
    if (bad >= 0) {
        GW_ERROR(I, "state %s is not finite (%g) at t=%.17g (solver %s)", x_name(I, bad),
                 I->xnew[bad], t1, gw_solver_name(I->solver));
        return GW_INT_ERROR;
    }
    I->dense_t0 = I->t;
    I->dense_h = t1 - I->t;
    I->dense_ready = 0;
    ev = (I->m->ne > 0) ? gw_events_check(I, I->t, t1, &te) : GW_EV_NONE;
    if (ev == GW_EV_ERROR) return GW_INT_ERROR;
    if (ev == GW_EV_NONE) {
        swap_ptr(&I->x, &I->xnew);
        if (I->m->ne > 0) swap_ptr(&I->e, &I->enew);
        I->t = t1;
        if (I->k7_valid) {
            swap_ptr(&I->k[0], &I->k[6]);
            I->fcur_valid = 1;
        } else {
            I->fcur_valid = 0;
        }
        return GW_INT_OK;
    }
    /* an event at te: the state there becomes the current state */
    swap_ptr(&I->x, &I->xev);
    swap_ptr(&I->e, &I->eev);
    I->t = te;
    I->fcur_valid = 0; /* restart the integration at the event */
    if (ev == GW_EV_TERMINATE) return GW_INT_TERMINATED;
    if (++(*events) > GW_MAX_EVENTS_PER_STEP) {
        GW_ERROR(I, "more than %d events in one communication step at t=%.17g",
                 GW_MAX_EVENTS_PER_STEP, te);
        return GW_INT_ERROR;
    }
    return GW_INT_OK;
}

/* ---- fixed-step solvers ------------------------------------------------------ */

static gw_int_result integrate_fixed(gw_instance *I, double t_end) {
    const double t0 = I->t, H = t_end - t0;
    double nd = ceil(H / I->max_step - 1e-12);
    unsigned long long n, i;
    int events = 0, growing;
    double d_prev;
    if (nd < 1.0) nd = 1.0;
    if (nd > GW_MAX_STEPS_AHEAD) {
        GW_ERROR(I, "communication step %g would need %.3g steps of max_step=%g (limit %.0e): "
                 "raise max_step or shorten the communication step", H, nd, I->max_step,
                 GW_MAX_STEPS_AHEAD);
        return GW_INT_ERROR;
    }
    n = (unsigned long long)nd;
    d_prev = 0.0;
    growing = 0;
    for (i = 1; i <= n; i++) {
        /* deterministic grid: t_i = t0 + i*H/n, the last one exactly t_end */
        const double ti = (i == n) ? t_end : t0 + (double)i * H / (double)n;
        while (I->t < ti) {
            const double h = ti - I->t;
            gw_int_result r;
            if (ensure_f0(I)) return GW_INT_ERROR;
            if (I->solver == GW_SOLVER_EULER) {
                /* Euler's instability: increments that more than double, step after step */
                double d;
                step_euler(I, h);
                d = scaled_diff(I, I->xnew, I->x);
                growing = (d > 2.0 * d_prev && d_prev > 1e-12) ? growing + 1 : 0;
                d_prev = d;
                if (growing >= 4) {
                    GW_ERROR(I, "euler is unstable at t=%.17g with max_step=%g: the increments grew "
                             "more than x2 per step for 4 steps; reduce max_step or use another solver",
                             I->t, h);
                    return GW_INT_ERROR;
                }
            } else if (step_rk4(I, h, ti)) {
                return GW_INT_ERROR;
            }
            r = accept_step(I, ti, &events);
            if (r != GW_INT_OK) return r;
        }
    }
    I->t = t_end;
    return GW_INT_OK;
}

/* ---- Dormand-Prince 5(4) ------------------------------------------------------- */

static double rms_weighted(const gw_instance *I, const double *v, const double *x) {
    int i, nx = I->m->nx;
    double sum = 0.0;
    for (i = 0; i < nx; i++) {
        double sk = I->abs_tol * I->nominal[i] + I->rel_tol * fabs(x[i]);
        double r = v[i] / sk;
        sum += r * r;
    }
    return nx > 0 ? sqrt(sum / nx) : 0.0;
}

/* Hairer's initial step size estimate (one extra RHS evaluation). */
static double initial_step(gw_instance *I, double hmax, double order) {
    int i, nx = I->m->nx;
    double dnf = rms_weighted(I, I->k[0], I->x), dny = rms_weighted(I, I->x, I->x);
    double h, der2, der12, h1;
    if (nx == 0) return hmax;
    h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : 0.01 * dny / dnf;
    if (h > hmax) h = hmax;
    for (i = 0; i < nx; i++) I->xtmp[i] = I->x[i] + h * I->k[0][i];
    if (gw_rhs(I, I->t + h, I->xtmp, I->k[1]) != 0) return h * 1e-3;
    for (i = 0; i < nx; i++) I->k[2][i] = I->k[1][i] - I->k[0][i];
    der2 = rms_weighted(I, I->k[2], I->x) / h;
    der12 = fabs(der2) > sqrt(dnf) ? fabs(der2) : sqrt(dnf);
    h1 = (der12 <= 1e-15 || !isfinite(der12)) ? (h * 1e-3 > 1e-6 ? h * 1e-3 : 1e-6)
                                              : pow(0.01 / der12, 1.0 / order);
    if (!isfinite(h1)) h1 = h * 1e-3;
    h = 100.0 * h < h1 ? 100.0 * h : h1;
    return h < hmax ? h : hmax;
}

/* The next attempt of an adaptive loop: the controller's h, bounded by max_step and shortened
 * to land exactly on t_end (*last), refused by the feasibility guard or when it no longer
 * advances time. Returns 0, or -1 with the reason logged. */
static int next_attempt(gw_instance *I, double t_end, int rejected_last, double *h_prev,
                        unsigned long *n_fast, double *h, double *t1, int *last) {
    const double remaining = t_end - I->t;
    *h = I->h_adapt < I->max_step ? I->h_adapt : I->max_step;
    *last = 1.01 * *h >= remaining;
    if (*last) *h = remaining;
    *t1 = *last ? t_end : I->t + *h;
    if (*last) {
        *h_prev = *h;
        return 0;
    }
    if (too_many_steps(I, remaining, *h, *h_prev, rejected_last, n_fast)) return -1;
    *h_prev = *h;
    if (*h < gw_h_min(I->t) || !(*t1 > I->t)) { /* steps that no longer advance time */
        GW_ERROR(I, "step size underflow at t=%.17g (h=%g, solver %s)", I->t, *h,
                 gw_solver_name(I->solver));
        return -1;
    }
    return 0;
}

static gw_int_result integrate_dopri5(gw_instance *I, double t_end) {
    int events = 0, rejected_last = 0;
    unsigned long n_fast = 0; /* attempts in a row projecting too many steps (guard) */
    double h_prev = 0.0; /* the previous attempt's step size (growth test of the guard) */
    const double hmax = I->max_step;
    if (ensure_f0(I)) return GW_INT_ERROR;
    if (!(I->h_adapt > 0.0)) I->h_adapt = initial_step(I, hmax, 5.0);
    if (I->h_adapt > hmax) I->h_adapt = hmax;
    while (I->t < t_end) {
        double h, err = 0.0, t1, fac;
        int last;
        if (ensure_f0(I)) return GW_INT_ERROR;
        if (next_attempt(I, t_end, rejected_last, &h_prev, &n_fast, &h, &t1, &last)) return GW_INT_ERROR;
        if (step_dopri5(I, h, t1, &err)) return GW_INT_ERROR;
        if (err <= 1.0) {
            gw_int_result r;
            fac = err > 0.0 ? GW_DOPRI5_SAFETY * pow(err, -0.2) : GW_DOPRI5_FAC_MAX;
            if (fac > GW_DOPRI5_FAC_MAX) fac = GW_DOPRI5_FAC_MAX;
            if (fac < GW_DOPRI5_FAC_MIN) fac = GW_DOPRI5_FAC_MIN;
            if (rejected_last && fac > 1.0) fac = 1.0;
            {
                double hnew = h * fac;
                /* a step shortened to land on t_end says little about the step size */
                if (last && h < I->h_adapt && hnew >= h) {
                    if (hnew < I->h_adapt) hnew = I->h_adapt;
                }
                I->h_adapt = hnew < hmax ? hnew : hmax;
            }
            rejected_last = 0;
            r = accept_step(I, t1, &events);
            if (r != GW_INT_OK) return r;
        } else {
            I->n_rejected++;
            fac = isfinite(err) ? GW_DOPRI5_SAFETY * pow(err, -0.2) : GW_DOPRI5_FAC_MIN;
            if (fac < GW_DOPRI5_FAC_MIN) fac = GW_DOPRI5_FAC_MIN;
            I->h_adapt = h * fac;
            rejected_last = 1;
            if (I->h_adapt < gw_h_min(I->t)) {
                GW_ERROR(I, "step size underflow at t=%.17g (h=%g, error norm %g)", I->t,
                         I->h_adapt, err);
                return GW_INT_ERROR;
            }
        }
    }
    I->t = t_end;
    return GW_INT_OK;
}

/* ---- DOP853 and Rosenbrock: adaptive loop ---------------------------------------------
 * Same landing on t_end, max_step bound, step size carry-over (I->h_adapt) and
 * underflow rule as DOPRI5.  Controllers (Hairer's codes, without memory of earlier
 * steps, so nothing beyond h_adapt has to survive fmi2Get/SetFMUstate):
 *   DOP853      h_new = h * clamp(0.9 err^(-1/8), 1/3, 6)
 *   Rosenbrock  h_new = h * clamp(0.9 err^(-1/4), 1/5, 6)
 * no increase right after a rejection.  Rosenbrock evaluates the Jacobian once per
 * accepted step (at its start point); a rejected step only refactors W with the new h.
 * A singular W is treated like a rejected step with h halved. */
static gw_int_result integrate_adaptive(gw_instance *I, double t_end) {
    const int ros = (I->solver == GW_SOLVER_ROSENBROCK);
    const double expo = ros ? 0.25 : 0.125, fac_min = ros ? 0.2 : 1.0 / 3.0, fac_max = 6.0;
    const double safety = 0.9, hmax = I->max_step;
    int events = 0, rejected_last = 0, jac_valid = 0;
    double lu_h = 0.0; /* step size of the factors in I->lu (0: none) */
    unsigned long n_jac = 0, n_lu = 0, rhs_jac = 0, n_fast = 0;
    double h_prev = 0.0; /* the previous attempt's step size (growth test of the guard) */
    const double t_begin = I->t;
    gw_int_result result = GW_INT_OK;
    if (ensure_f0(I)) return GW_INT_ERROR;
    if (!(I->h_adapt > 0.0)) I->h_adapt = initial_step(I, hmax, ros ? 4.0 : 8.0);
    if (I->h_adapt > hmax) I->h_adapt = hmax;
    while (I->t < t_end) {
        double h, err = 0.0, t1, fac;
        int last;
        if (ensure_f0(I)) return GW_INT_ERROR;
        if (next_attempt(I, t_end, rejected_last, &h_prev, &n_fast, &h, &t1, &last)) return GW_INT_ERROR;
        if (ros) {
            if (!jac_valid) {
                unsigned long long r0 = I->n_rhs;
                if (ros_linearise(I)) return GW_INT_ERROR;
                rhs_jac += (unsigned long)(I->n_rhs - r0);
                jac_valid = 1;
                n_jac++;
                lu_h = 0.0;
            }
            if (lu_h != h) {
                n_lu++;
                lu_h = h;
                if (ros_factor(I, h)) {
                    lu_h = 0.0;
                    I->n_rejected++;
                    I->h_adapt = 0.5 * h;
                    rejected_last = 1;
                    if (I->h_adapt < gw_h_min(I->t)) {
                        GW_ERROR(I, "step size underflow at t=%.17g (h=%g): the matrix "
                                 "I/(gamma h) - J stays singular", I->t, I->h_adapt);
                        return GW_INT_ERROR;
                    }
                    continue;
                }
            }
            if (step_rosenbrock(I, h, t1, &err)) return GW_INT_ERROR;
        } else {
            if (step_dop853(I, h, t1, &err)) return GW_INT_ERROR;
        }
        if (err <= 1.0) {
            gw_int_result r;
            double hnew;
            if (!ros) {
                /* FSAL: f at the new point, for the next step and the dense output */
                if (rhs(I, t1, I->xnew, I->k[6])) return GW_INT_ERROR;
                I->k7_valid = 1;
            }
            fac = err > 0.0 ? safety * pow(err, -expo) : fac_max;
            if (fac > fac_max) fac = fac_max;
            if (fac < fac_min) fac = fac_min;
            if (rejected_last && fac > 1.0) fac = 1.0;
            hnew = h * fac;
            /* a step shortened to land on t_end says little about the step size */
            if (last && h < I->h_adapt && hnew >= h && hnew < I->h_adapt) hnew = I->h_adapt;
            I->h_adapt = hnew < hmax ? hnew : hmax;
            rejected_last = 0;
            jac_valid = 0; /* a new point: new Jacobian */
            r = accept_step(I, t1, &events);
            if (r != GW_INT_OK) {
                result = r;
                break;
            }
        } else {
            I->n_rejected++;
            fac = isfinite(err) ? safety * pow(err, -expo) : fac_min;
            if (fac < fac_min) fac = fac_min;
            if (fac > 1.0) fac = 1.0;
            I->h_adapt = h * fac;
            rejected_last = 1;
            if (I->h_adapt < gw_h_min(I->t)) {
                GW_ERROR(I, "step size underflow at t=%.17g (h=%g, error norm %g, solver %s)",
                         I->t, I->h_adapt, err, gw_solver_name(I->solver));
                return GW_INT_ERROR;
            }
        }
    }
    if (result == GW_INT_OK) I->t = t_end;
    if (ros && gw_log_enabled(I, GW_LOG_SOLVER))
        gw_log(I, fmi2OK, GW_LOG_SOLVER,
               "rosenbrock t=%.17g -> t=%.17g jacobians=%lu (%s, rhs=%lu) lu=%lu", t_begin,
               I->t, n_jac, I->f_jac.eval ? "analytic" : "finite differences", rhs_jac, n_lu);
    return result;
}

gw_int_result gw_integrate(gw_instance *I, double t_end) {
    switch (I->solver) {
    case GW_SOLVER_EULER:
    case GW_SOLVER_RK4: return integrate_fixed(I, t_end);
    case GW_SOLVER_DOPRI5: return integrate_dopri5(I, t_end);
    case GW_SOLVER_DOP853:
    case GW_SOLVER_ROSENBROCK: return integrate_adaptive(I, t_end);
    default:
        GW_ERROR(I, "solver %s (%d) not available", gw_solver_name(I->solver), I->solver);
        return GW_INT_ERROR;
    }
}

/* ---- solver work memory ------------------------------------------------------------- */

int gw_solver_available(int solver) {
    return solver == GW_SOLVER_EULER || solver == GW_SOLVER_RK4 || solver == GW_SOLVER_DOPRI5 ||
           solver == GW_SOLVER_ROSENBROCK || solver == GW_SOLVER_DOP853;
}

int gw_solver_alloc(gw_instance *I) {
    const size_t nx = (size_t)I->m->nx;
    int i;
    for (i = 0; i < 9; i++) {
        I->kx[i] = (double *)gw_alloc(I, nx, sizeof(double));
        if (!I->kx[i]) return -1;
    }
    I->rcx = (double *)gw_alloc(I, 3 * nx, sizeof(double));
    I->jac = (double *)gw_alloc(I, nx * nx, sizeof(double));
    I->lu = (double *)gw_alloc(I, nx * nx, sizeof(double));
    I->piv = (int *)gw_alloc(I, nx, sizeof(int));
    return (I->rcx && I->jac && I->lu && I->piv) ? 0 : -1;
}

void gw_solver_free(gw_instance *I) {
    int i;
    for (i = 0; i < 9; i++) {
        gw_free(I, I->kx[i]);
        I->kx[i] = NULL;
    }
    gw_free(I, I->rcx);
    gw_free(I, I->jac);
    gw_free(I, I->lu);
    gw_free(I, I->piv);
    I->rcx = I->jac = I->lu = NULL;
    I->piv = NULL;
}
