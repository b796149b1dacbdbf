"""Fresh-eyes review of the event indicators read from the Taylor kernel's order-0 row
(taylor/events.py, GW_TL(evt); c_src/gw_solver_taylor.c and gw_ensemble.c)."""
from __future__ import annotations

import ctypes

import casadi as ca
import numpy as np

from gyrowheel.fmu_build.codegen import optimised
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


def _events_and_state(fmu, unzipdir, h: float, stop: float, tol: float):
    """Communication steps of h (the last step of each fmi2DoStep checks with gw_evt, the others
    read the kernel's indicators) until the run ends: ([(event message shape, t)], t reached,
    the states)."""
    import re

    from fmi_helpers import Slave
    from fmpy.fmi2 import fmi2LastSuccessfulTime
    s = Slave(fmu, unzipdir=unzipdir)
    try:
        s.fmu2.setDebugLogging(True, [])
        s.init(solver=6, rel_tol=tol, abs_tol=tol * 1e-2, max_step=stop)
        t = 0.0
        while t < stop - 1e-12:
            try:
                s.slave.doStep(t, min(h, stop - t))
            except Exception:
                t = s.slave.getRealStatus(fmi2LastSuccessfulTime)
                break
            t += min(h, stop - t)
        events = [(re.sub(r"t=\S+", "t=", m), float(re.search(r"t=([-+0-9.e]+)", m)[1]))
                  for _, _, m in s.messages if "event " in m and "t=" in m]
        return events, t, np.array(s.get("x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot",
                                         "gamma_dot", "rolling_mode"))
    finally:
        s.free()


def test_single_run_update_warning_and_terminal_events_as_with_gw_evt(tmp_path):
    """Solver taylor's single run reads the indicators from the kernel at every step's end but
    the last of each fmi2DoStep (c_src/gw_solver_taylor.c); test_taylor_events.py compares only
    the ensemble against gw_evt, on falls.  slope_hold has all three kinds: the stiction update
    (rolling_mode -1 -> 0, a jump of the state, the run goes on), the slip warning, the lift-off
    that ends the run.  Built with the kernel's indicators and rebuilt with gw_evt at every step
    (GW_TAYLOR_KERNEL_EVT 0), many communication steps and one: the same events in the same
    order at the same times, the same end, the same states (to the rounding by which the
    kernel's sine may differ from gw_sin's)."""
    import subprocess
    import zipfile

    from conftest import SCENES
    from gyrowheel.fmu_build import build_fmu, load_scene
    from gyrowheel.fmu_build.compiler import compiler
    built = build_fmu(load_scene(SCENES / "slope_hold.toml"), tmp_path / "s.fmu", build_dir=tmp_path / "b",
                      taylor=True)
    assert "#define GW_TL_HAS_EVT 1" in (built.sources / "gw_taylor_model.h").read_text()
    dirs = {}
    for flag in (1, 0):
        unz = dirs[flag] = tmp_path / f"k{flag}"
        with zipfile.ZipFile(built.fmu) as z:
            z.extractall(unz)
        lib = next((unz / "binaries" / "linux64").glob("*.so"))
        lib.unlink()
        subprocess.run([compiler(), "-std=c99", "-O2", f"-DGW_TAYLOR_KERNEL_EVT={flag}", "-shared", "-fPIC",
                        f"-I{built.sources}", str(built.sources / "gw_fmu.c"), "-o", str(lib), "-lm"],
                       check=True, capture_output=True)
    for h, tol in ((0.0137, 1e-9), (10.0, 1e-7)):
        (ek, tk, xk), (e0, t0, x0) = (_events_and_state(built.fmu, dirs[f], h, 10.0, tol) for f in (1, 0))
        kinds = [k for k, _ in ek]
        assert any("state updated" in k for k in kinds) and any("warning" in k for k in kinds)
        assert any("terminated" in k for k in kinds) and tk < 10.0
        assert kinds == [k for k, _ in e0]
        np.testing.assert_allclose([t for _, t in ek], [t for _, t in e0], rtol=0, atol=1e-11)
        assert abs(tk - t0) < 1e-11
        np.testing.assert_allclose(xk, x0, rtol=1e-9, atol=1e-10)
