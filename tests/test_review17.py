"""Fresh-eyes review of the event indicators read from the Taylor kernel's order-0 row
(fmu_build/taylor_events.py, GW_TL(evt); c_src/gw_solver_taylor.c and gw_ensemble.c)."""
from __future__ import annotations

import ctypes

import casadi as ca
import numpy as np

from fmu_build.codegen import optimised
from test_taylor_events import _library, _ptr


def _sign_model():
    t, x, u, p = ca.SX.sym("t"), ca.SX.sym("x", 2), ca.SX.sym("u", 0), ca.SX.sym("p", 1)
    names = ["t", "x", "u", "p"]
    ode = ca.Function("gw_ode", [t, x, u, p], [ca.vertcat(x[1], -ca.sin(x[0]))], names, ["xdot"])
    # sign of a NaN (sqrt of a negative) and of -0.0: casadi_sign returns its argument there
    e = ca.vertcat(ca.sin(x[0]) + ca.sign(ca.sqrt(x[1])), ca.sin(x[0]) + 1.0 / ca.sign(x[1]),
                   ca.sin(x[0]) * ca.sign(x[1]) - p[0])
    evt = ca.Function("gw_evt", [t, x, u, p], [e], names, ["e"])
    return {"ode": optimised(ode), "evt": optimised(evt)}


def test_kernel_indicators_take_casadis_sign_of_nan_and_negative_zero(tmp_path):
    """GW_TL(evt) wrote sign(v) as taylor_graph's order-0 C, (v > 0 ? 1 : (v < 0 ? -1 : 0)),
    while gw_evt (CasADi's C) calls casadi_sign, v < 0 ? -1 : v > 0 ? 1 : v: a NaN gave 0 (a
    finite indicator that does not fire where gw_evt's NaN counts as a crossing) and -0.0 gave
    +0.0 (1 / sign: +inf against -inf).  The kernel's indicators must be gw_evt's bit for bit
    where no sine is read from the kernel."""
    fns = _sign_model()
    lib = _library(fns, tmp_path)
    p, u, pc = np.array([0.25]), np.zeros(1), np.zeros(1)
    for x1 in (-1.0, -0.0, 0.0, 2.0):
        x = np.array([0.3, x1])
        ref = np.array(fns["evt"](0.0, x, np.zeros(0), p), dtype=float).ravel()
        e = np.full(3, 7.0)
        assert lib.evt(3, ctypes.c_double(0.0), _ptr(x), _ptr(u), _ptr(p), _ptr(pc), _ptr(e)) == 1
        assert np.array_equal(np.isnan(e), np.isnan(ref)), (x1, e, ref)
        ok = ~np.isnan(ref)
        np.testing.assert_allclose(e[ok], ref[ok], rtol=1e-15, atol=0)
        assert np.array_equal(np.signbit(e[ok]), np.signbit(ref[ok])), (x1, e, ref)
