/*
 * gw_taylor_ops.h -- Taylor-coefficient recurrences of the elementary operations, for W
 * trajectories at once (a template: included once per lane count).
 *
 * A series is stored order-major with the lanes innermost: coefficient k of lane l at
 * a[k*W + l] (W = GW_TL_W; W = 1 is the single trajectory of solver `taylor`, W > 1 the
 * ensemble path, gw_ensemble.c, where the lane loops vectorise).  Coefficients are the
 * normalised derivatives a_k = a^(k)(t0) / k!.  Every function computes coefficient k >= 1 of
 * its result from coefficients < k of the result and <= k of the arguments (order 0 is the
 * plain operation, written by the generated code).  Formulas (Jorba & Zou 2005, sect. 3.2;
 * Griewank & Walther 2008, table 13.2), with v the result:
 *   mul   v = a b        v_k = sum_{j=0..k} a_j b_{k-j}
 *   sq    v = a^2        the same sum, symmetric half
 *   div   v = a / b      v_k = (a_k - sum_{j=1..k} b_j v_{k-j}) / b_0
 *   sqrt  v^2 = a        v_k = (a_k - sum_{j=1..k-1} v_j v_{k-j}) / (2 v_0)
 *   sincos s' = a' c, c' = -a' s: k s_k = sum_{j=1..k} j a_j c_{k-j}, k c_k = -sum j a_j s_{k-j}
 *   sinhcosh s' = a' c, c' = a' s
 *   exp   v' = a' v      k v_k = sum_{j=1..k} j a_j v_{k-j}
 *   log   a v' = a'      v_k = (a_k - (1/k) sum_{j=1..k-1} j v_j a_{k-j}) / a_0
 *   pow   a v' = e a' v  v_k = sum_{j=0..k-1} (e (k-j) - j) a_{k-j} v_j / (k a_0)
 *   tan   v' = a' q, q = 1 + v^2;  tanh  v' = a' q, q = 1 - v^2 (q written too)
 *   dq    r v' = n'      v_k = (k n_k - sum_{j=1..k-1} j v_j r_{k-j}) / (k r_0)
 *                        (atan: r = 1 + a^2, n = a; asin: r = sqrt(1 - a^2), n = a; acos n = -a)
 *   atan2 r v' = b a' - a b', r = a^2 + b^2:
 *         v_k = (sum_{j=1..k} j (a_j b_{k-j} - b_j a_{k-j}) - sum_{j=1..k-1} j v_j r_{k-j}) / (k r_0)
 * The accumulators are per lane (no reassociation across lanes is needed to vectorise).
 *
 * Before including: GW_TL_W (lanes) and GW_TL(name) (the name prefix of this instance).
 * Checked against CasADi's own derivatives: tests/test_taylor.py.
 */
/* GW_TL_INNER: how the helpers below are declared (a model may need only some of them);
 * GW_TL_STATIC: the model's cst and jet (gw_taylor_model.h) */
#ifndef GW_TL_INNER
#define GW_TL_INNER static GW_MAYBE_UNUSED
#endif
#ifndef GW_TL_STATIC
#define GW_TL_STATIC static GW_MAYBE_UNUSED
#endif
#define GW_TLK(v, j) ((v) + (size_t)(j) * GW_TL_W) /* coefficient j of a series */

/* acc = sum_{j=lo..hi} a_j b_{m-j} per lane; one lane: four interleaved partial sums, since
 * the chain of dependent additions bounds the loop (as heyoka's pairwise sums avoid) */
GW_TL_INNER void GW_TL(conv)(double *acc, const double *a, const double *b, int lo, int hi,
                             int m) {
    int j, l;
#if GW_TL_W == 1
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    for (j = lo; j + 3 <= hi; j += 4) {
        s0 += a[j] * b[m - j];
        s1 += a[j + 1] * b[m - j - 1];
        s2 += a[j + 2] * b[m - j - 2];
        s3 += a[j + 3] * b[m - j - 3];
    }
    for (; j <= hi; j++) s0 += a[j] * b[m - j];
    acc[0] = (s0 + s1) + (s2 + s3);
    (void)l;
#else /* the lanes are the independent sums, kept in a local array: acc may point into the
       * series themselves (the result's coefficient k), so sums kept in acc would be stored
       * and reloaded at every j (measured: the 8-lane kernel 1.8x slower) */
    double s[GW_TL_W];
    for (l = 0; l < GW_TL_W; l++) s[l] = 0.0;
    for (j = lo; j <= hi; j++) {
        const double *aj = GW_TLK(a, j), *bj = GW_TLK(b, m - j);
        for (l = 0; l < GW_TL_W; l++) s[l] += aj[l] * bj[l];
    }
    for (l = 0; l < GW_TL_W; l++) acc[l] = s[l];
#endif
}

GW_TL_INNER void GW_TL(mul)(double *out, const double *a, const double *b, int k) {
    GW_TL(conv)(out, a, b, 0, k, k);
}

/* sum_{j=lo..k-lo} a_j a_{k-j}: twice the sum below the middle, plus the middle term */
GW_TL_INNER void GW_TL(sym)(double *acc, const double *a, int k, int lo) {
    int l;
    const int hi = (k - 1) / 2;
    if (hi >= lo)
        GW_TL(conv)(acc, a, a, lo, hi, k);
    else
        for (l = 0; l < GW_TL_W; l++) acc[l] = 0.0;
    for (l = 0; l < GW_TL_W; l++) acc[l] *= 2.0;
    if (k % 2 == 0) {
        const double *am = GW_TLK(a, k / 2);
        for (l = 0; l < GW_TL_W; l++) acc[l] += am[l] * am[l];
    }
}

GW_TL_INNER void GW_TL(sq)(double *out, const double *a, int k) {
    GW_TL(sym)(out, a, k, 0);
}

/* v = a / b; a_k given (a constant numerator: 0 for k >= 1) */
GW_TL_INNER void GW_TL(div)(double *v, const double *ak, const double *b, int k) {
    double acc[GW_TL_W];
    int l;
    GW_TL(conv)(acc, b, v, 1, k, k);
    for (l = 0; l < GW_TL_W; l++) GW_TLK(v, k)[l] = ((ak ? ak[l] : 0.0) - acc[l]) / b[l];
}

GW_TL_INNER void GW_TL(sqrt)(double *v, const double *ak, int k) {
    double acc[GW_TL_W];
    int l;
    GW_TL(sym)(acc, v, k, 1);
    for (l = 0; l < GW_TL_W; l++) GW_TLK(v, k)[l] = (ak[l] - acc[l]) / (2.0 * v[l]);
}

/* sign = -1: sin/cos; +1: sinh/cosh */
GW_TL_INNER void GW_TL(pair)(double *s, double *c, const double *a, int k, double sign) {
    double as[GW_TL_W], ac[GW_TL_W];
    const double rk = 1.0 / k;
    int j, l;
    for (l = 0; l < GW_TL_W; l++) as[l] = ac[l] = 0.0;
    for (j = 1; j <= k; j++) {
        const double *aj = GW_TLK(a, j), *cj = GW_TLK(c, k - j), *sj = GW_TLK(s, k - j);
        for (l = 0; l < GW_TL_W; l++) {
            const double ja = j * aj[l];
            as[l] += ja * cj[l];
            ac[l] += ja * sj[l];
        }
    }
    for (l = 0; l < GW_TL_W; l++) {
        GW_TLK(s, k)[l] = rk * as[l];
        GW_TLK(c, k)[l] = sign * rk * ac[l];
    }
}

/* k v_k = sum_{j=1..k} j a_j q_{k-j} (exp: q = v; tan, tanh: q their aux series) */
GW_TL_INNER void GW_TL(dexp)(double *v, const double *a, const double *q, int k) {
    double acc[GW_TL_W];
    const double rk = 1.0 / k;
    int j, l;
    for (l = 0; l < GW_TL_W; l++) acc[l] = 0.0;
    for (j = 1; j <= k; j++) {
        const double *aj = GW_TLK(a, j), *qj = GW_TLK(q, k - j);
        for (l = 0; l < GW_TL_W; l++) acc[l] += j * aj[l] * qj[l];
    }
    for (l = 0; l < GW_TL_W; l++) GW_TLK(v, k)[l] = rk * acc[l];
}

/* tan (sign +1) and tanh (sign -1): v then q = 1 + sign v^2 */
GW_TL_INNER void GW_TL(tan)(double *v, double *q, const double *a, int k, double sign) {
    double acc[GW_TL_W];
    int l;
    GW_TL(dexp)(v, a, q, k);
    GW_TL(sym)(acc, v, k, 0);
    for (l = 0; l < GW_TL_W; l++) GW_TLK(q, k)[l] = sign * acc[l];
}

/* k r_0 v_k = k n_k - sum_{j=1..k-1} j v_j r_{k-j} (+ extra_k: atan2's numerator) */
GW_TL_INNER void GW_TL(dq)(double *v, const double *nk, const double *r, const double *extra, int k) {
    double acc[GW_TL_W];
    int j, l;
    for (l = 0; l < GW_TL_W; l++) acc[l] = extra ? extra[l] : k * nk[l];
    for (j = 1; j < k; j++) {
        const double *vj = GW_TLK(v, j), *rj = GW_TLK(r, k - j);
        for (l = 0; l < GW_TL_W; l++) acc[l] -= j * vj[l] * rj[l];
    }
    for (l = 0; l < GW_TL_W; l++) GW_TLK(v, k)[l] = acc[l] / (k * r[l]);
}

GW_TL_INNER void GW_TL(log)(double *v, const double *a, int k) {
    GW_TL(dq)(v, GW_TLK(a, k), a, NULL, k);
}

GW_TL_INNER void GW_TL(atan2)(double *v, const double *a, const double *b, const double *r, int k) {
    double num[GW_TL_W];
    int j, l;
    for (l = 0; l < GW_TL_W; l++) num[l] = 0.0;
    for (j = 1; j <= k; j++) {
        const double *aj = GW_TLK(a, j), *bj = GW_TLK(b, j);
        const double *ak = GW_TLK(a, k - j), *bk = GW_TLK(b, k - j);
        for (l = 0; l < GW_TL_W; l++) num[l] += j * (aj[l] * bk[l] - bj[l] * ak[l]);
    }
    GW_TL(dq)(v, NULL, r, num, k);
}

/* v = a^e, e constant per lane */
GW_TL_INNER void GW_TL(pow)(double *v, const double *a, const double *e, int k) {
    double acc[GW_TL_W];
    int j, l;
    for (l = 0; l < GW_TL_W; l++) acc[l] = 0.0;
    for (j = 0; j < k; j++) {
        const double *vj = GW_TLK(v, j), *aj = GW_TLK(a, k - j);
        for (l = 0; l < GW_TL_W; l++) acc[l] += (e[l] * (k - j) - j) * aj[l] * vj[l];
    }
    for (l = 0; l < GW_TL_W; l++) GW_TLK(v, k)[l] = acc[l] / (k * a[l]);
}

#undef GW_TLK
