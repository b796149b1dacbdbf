"""The event indicators read from the Taylor kernel's order-0 row (taylor/events.py).

Solver taylor and the ensemble evaluate the indicators at each accepted step's end from the
series the kernel has just computed there (GW_TL(evt)) instead of calling gw_evt: the values
must be gw_evt's (to a rounding of the kernel's own sine), the events at the same times, and a
model whose indicators use an operation the generator does not write keeps gw_evt.  sign() of a
NaN and of -0.0 as CasADi's; a single run's update, warning and terminal events (slope_hold) as
with gw_evt at every step.
"""
from __future__ import annotations

import ctypes
import subprocess
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from conftest import SCENES
from gyrowheel.fmu_build import build_fmu, load_scene, parse_scene
from gyrowheel.fmu_build.builder import model_spec
from gyrowheel.fmu_build.codegen import hoisted, optimised, taylor_ode
from gyrowheel.fmu_build.compiler import compiler
from gyrowheel.taylor.ensemble import Ensemble
from gyrowheel.taylor.kernel_c import taylor_source
from gyrowheel.taylor.events import event_source, kernel_nodes
from gyrowheel.taylor.graph import decompose

ROOT = Path(__file__).resolve().parent.parent
_HARNESS = """#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#define GW_MAYBE_UNUSED __attribute__((unused))
#define GW_TL_W 1
#define GW_TL(name) gw_tl1_##name
#include "gw_taylor_model.h"
/* the kernel's series at (t, x) in *w (free it), 32-byte aligned: the returned pointer; NULL */
static double *series_at(int order, double t, const double *x, const double *u, const double *p,
                         double **w) {
    double c[GW_TL_NCST + 1], *wi;
    *w = (double *)malloc(sizeof(double) * ((size_t)GW_TL_NVAR * (size_t)(order + 1) + 8));
    if (!*w) return NULL;
    wi = (double *)(void *)(((uintptr_t)*w + 31u) & ~(uintptr_t)31u);
    gw_tl1_cst(u, p, c);
    gw_tl1_series(order, &t, x, c, wi);
    return wi;
}
int evt(int order, double t, const double *x, const double *u, const double *p, const double *pc,
        double *e);
/* the indicators from the order-0 row of the series at (t, x) */
int evt(int order, double t, const double *x, const double *u, const double *p, const double *pc,
        double *e) {
    double *w, *wi = series_at(order, t, x, u, p, &w);
    if (!wi) return -1;
#if GW_TL_HAS_EVT
    gw_tl1_evt(wi, t, u, p, pc, e);
#else
    (void)pc, (void)e;
#endif
    free(w);
    return GW_TL_HAS_EVT;
}
int evt_slope(int order, double t, const double *x, const double *u, const double *p,
              const double *pc, double *e, double *d);
/* the same with the indicators' time derivatives from the rows of order 0 and 1; 0 without */
int evt_slope(int order, double t, const double *x, const double *u, const double *p,
              const double *pc, double *e, double *d) {
#if defined(GW_TL_HAS_EVT_SLOPE) && GW_TL_HAS_EVT_SLOPE
    double *w, *wi = series_at(order, t, x, u, p, &w);
    if (!wi) return -1;
    gw_tl1_evt_slope(wi, wi + GW_TL_NODES, t, u, p, pc, e, d);
    free(w);
    return 1;
#else
    (void)order, (void)t, (void)x, (void)u, (void)p, (void)pc, (void)e, (void)d, (void)series_at;
    return 0;
#endif
}
"""


def _functions(spec) -> dict[str, ca.Function]:
    """The functions as the FMU's build generates them (codegen.generate_functions)."""
    return {slot: optimised(f) for slot, f in hoisted(spec).items()}


def _library(fns: dict[str, ca.Function], tmp: Path) -> ctypes.CDLL:
    dec = decompose(taylor_ode(fns))
    (tmp / "gw_taylor_model.h").write_text(taylor_source(dec, "m", fns.get("evt")))
    (tmp / "evt.c").write_text(_HARNESS)
    lib = tmp / "evt.so"
    # -O1: the values are compared, not timed (GCC's -O2 took most of gyrover_ice's case)
    subprocess.run([compiler(), "-std=c99", "-O1", "-shared", "-fPIC", "-Wall", "-Wextra", "-Werror",
                    f"-I{ROOT / 'c_src'}", f"-I{tmp}", str(tmp / "evt.c"), "-o", str(lib), "-lm"],
                   check=True, capture_output=True)
    return ctypes.CDLL(str(lib))


def _ptr(a: np.ndarray):
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


SCENE_FILES = sorted(SCENES.glob("*.toml"))


@pytest.mark.parametrize("path", SCENE_FILES, ids=lambda p: p.stem)
def test_kernel_indicators_and_slopes_equal_the_event_function(path, tmp_path):
    """At random states (the scene's parameters), every indicator from the kernel's row equals
    gw_evt's function (CasADi evaluating it) to a rounding of a sine; every scene's fall event
    reads sin(beta) from the kernel, so each scene with events has the function.  (The C of
    gw_evt's own operations is checked bit for bit by the ensemble tests below and in
    test_taylor_solver.py, which compare whole runs.)  The indicators' time derivatives from the
    rows of order 0 and 1 (what the crossing search inside a step uses at each step's end) equal
    CasADi's forward derivative of gw_evt along gw_ode, their values GW_TL(evt)'s bit for bit."""
    spec = model_spec(load_scene(path))
    fns = _functions(spec)
    if "evt" not in fns:
        pytest.skip("no events")
    evt, nx = fns["evt"], spec.x.numel()
    lib = _library(fns, tmp_path)
    rng = np.random.default_rng(7)
    p = np.array([q.start for q in spec.parameters], dtype=float)
    u = np.array([q.start or 0.0 for q in spec.inputs] or [0.0], dtype=float)
    pc = np.array(fns["ode_pre"](p), dtype=float).ravel() if "ode_pre" in fns else np.zeros(1)
    ne, exact, n, slopes = evt.nnz_out(0), 0, 0, 0
    slope_fn = _slope_function(evt, fns["ode"])
    for _ in range(50):
        x, t = rng.uniform(-2.0, 2.0, nx), float(rng.uniform(0.0, 10.0))
        args = [t, x, u[: spec.u.numel()], p] + ([pc] if evt.n_in() == 5 else [])
        ref = np.array(evt(*args), dtype=float).ravel()
        e = np.full(ne, np.nan)
        has = lib.evt(3, ctypes.c_double(t), _ptr(x), _ptr(u), _ptr(p), _ptr(pc), _ptr(e))
        assert has == 1, "the fall event's sin(beta) is a kernel node: the function exists"
        ok = np.isfinite(ref)
        assert np.array_equal(np.isfinite(e), ok)
        # (several roundings where an indicator's terms cancel: slope_descent's 1.09 to 5e-15)
        np.testing.assert_allclose(e[ok], ref[ok], rtol=0, atol=1e-13 * (1.0 + np.abs(ref[ok]).max()))
        exact += int(np.sum(e[ok] == ref[ok]))
        n += int(ok.sum())
        slope = np.array(slope_fn(*args), dtype=float).ravel()
        es, d = np.full(ne, np.nan), np.full(ne, np.nan)
        assert lib.evt_slope(3, ctypes.c_double(t), _ptr(x), _ptr(u), _ptr(p), _ptr(pc), _ptr(es), _ptr(d)) == 1
        np.testing.assert_array_equal(es, e)
        fine = np.isfinite(slope) & (np.abs(slope) < 1e8)  # a rate near a pole of f says nothing
        # (the kernel's rates x' differ from gw_ode's by roundings, which an indicator's
        # cancelling terms raise: gyrover_ice's normal force to 2.4e-11; a wrong rule is O(1) off)
        np.testing.assert_allclose(d[fine], slope[fine], rtol=1e-9,
                                   atol=1e-10 * (1.0 + np.abs(slope[fine]).max()))
        slopes += int(fine.sum())
    assert exact > 0  # libm's sin here, gw_sin's in gw_evt: mostly the same bits
    assert slopes >= 40


def test_an_operation_without_c_here_keeps_gw_evt():
    """An indicator using an operation the generator does not write (erf) gives no function
    (GW_TL_HAS_EVT 0): the runtime evaluates gw_evt; so do indicators that read nothing from
    the kernel (no gain)."""
    t, x, u, p = ca.SX.sym("t"), ca.SX.sym("x", 2), ca.SX.sym("u", 0), ca.SX.sym("p", 1)
    names = ["t", "x", "u", "p"]
    ode = ca.Function("gw_ode", [t, x, u, p], [ca.vertcat(x[1], -ca.sin(x[0]))], names, ["xdot"])
    dec = decompose(optimised(ode))
    assert ("sin", 0) in kernel_nodes(dec)

    def source(e):
        return event_source(optimised(ca.Function("gw_evt", [t, x, u, p], [e], names, ["e"])), dec)
    assert "GW_TL_HAS_EVT 1" in source(ca.sin(x[0]) - p[0])
    assert "GW_TL_HAS_EVT 0" in source(ca.erf(x[1]) + ca.sin(x[0]))
    assert "GW_TL_HAS_EVT 0" in source(x[1] - p[0])  # nothing from the kernel


def _slope_function(evt: ca.Function, ode: ca.Function) -> ca.Function:
    """(evt's inputs) -> de/dt = de/dx f(t, x) + de/dt|_x: CasADi's forward derivative of the
    indicators along the right-hand side (not the generator's instruction-by-instruction rules)."""
    t, x = ca.MX.sym("t"), ca.MX.sym("x", evt.size1_in(1))
    rest = [ca.MX.sym(f"a{k}", evt.sparsity_in(k)) for k in range(2, evt.n_in())]
    e = evt(t, x, *rest)
    f = ode(t, x, rest[0], rest[1], *(rest[2:] if ode.n_in() == 5 else []))
    return ca.Function("d", [t, x, *rest], [ca.jtimes(e, x, f) + ca.jacobian(e, t)])


def test_slope_rules_of_each_operation():
    """Each operation the slope generator has a rule for, differentiated along x' = (x1, -sin x0,
    1): the C rules (compiled) against CasADi's derivative, with constant operands (one-sided
    rules) and state operands; an operation without a rule (pow with a varying exponent) leaves
    GW_TL_HAS_EVT_SLOPE 0 while GW_TL(evt) stays."""
    t, x, u, p = ca.SX.sym("t"), ca.SX.sym("x", 3), ca.SX.sym("u", 0), ca.SX.sym("p", 1)
    names = ["t", "x", "u", "p"]
    ode = ca.Function("gw_ode", [t, x, u, p], [ca.vertcat(x[1], -ca.sin(x[0]), 1.0 + 0.0 * x[2])], names, ["xdot"])
    s0 = ca.sin(x[0])
    exprs = [s0 * x[1] - p[0], s0 / (2.0 + x[1] ** 2), ca.sqrt(2.0 + s0), ca.atan2(s0, 1.5 + x[2]),
             ca.atan2(s0, p[0]), ca.fabs(s0 - 0.1), ca.fmin(s0, x[1]), ca.fmax(s0, p[0] * x[1]),
             ca.if_else(x[2] > 0.3, s0 * t, x[1]), ca.tanh(s0) + ca.exp(0.1 * x[1]) + ca.log(2.0 + s0),
             ca.atan(s0) + ca.asin(0.5 * s0) + ca.acos(0.4 * s0), ca.cos(x[1]) * ca.sin(x[2]) + s0,
             ca.sinh(0.3 * x[1]) + ca.cosh(0.2 * x[2]) + s0, s0 ** 3 + 1.0 / (3.0 + s0), ca.tan(0.3 * s0),
             p[0] * s0 - t, ca.cos(x[0]) + 2.0 * s0]
    fns = {"ode": optimised(ode), "evt": optimised(ca.Function("gw_evt", [t, x, u, p], [ca.vertcat(*exprs)],
                                                                 names, ["e"]))}
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        lib = _library(fns, Path(tmp))
        rng = np.random.default_rng(3)
        slope_fn = _slope_function(fns["evt"], fns["ode"])
        for _ in range(20):
            xv, tv, pv = rng.uniform(-1.0, 1.0, 3), float(rng.uniform(0.0, 2.0)), np.array([0.7])
            ref = np.array(slope_fn(tv, xv, np.zeros(0), pv), dtype=float).ravel()
            e, d = np.full(len(exprs), np.nan), np.full(len(exprs), np.nan)
            uv = np.zeros(1)
            assert lib.evt_slope(3, ctypes.c_double(tv), _ptr(xv), _ptr(uv), _ptr(pv), _ptr(uv), _ptr(e), _ptr(d)) == 1
            np.testing.assert_allclose(d, ref, rtol=1e-12, atol=1e-13)
    dec = decompose(fns["ode"])
    varying = event_source(optimised(ca.Function("gw_evt", [t, x, u, p], [s0 ** x[1]], names, ["e"])), dec)
    assert "GW_TL_HAS_EVT 1" in varying and "GW_TL_HAS_EVT_SLOPE 0" in varying


FALLS = """[model]
name = "falls"
[effects.gravity]
g = 9.81
[initial]
beta_deg = 80.0
gamma_dot = 1.0
"""


def test_fall_times_as_with_the_event_function(tmp_path):
    """Trajectories that fall at different times (the ensemble, 9 on 4 lanes, refills and the
    one-lane tail): the same steps and fall times as the same library evaluating gw_evt at every
    step (GW_TAYLOR_KERNEL_EVT 0), to the event location's tolerance (1e-12 s relative; the
    kernel's sin(beta) may differ from gw_sin's by a rounding), and the same states to 1e-9."""
    built = build_fmu(parse_scene(FALLS, "scene.toml"), tmp_path / "f.fmu", build_dir=tmp_path / "b",
                      taylor=True)
    assert "GW_TL_HAS_EVT 1" in (tmp_path / "b" / "fmu" / "sources" / "gw_taylor_model.h").read_text()
    kw = dict(parameters={"g": [9.81, 3.721, 9.81, 9.81, 0.0, 9.81, 5.0, 1.625, 9.81], "beta_min": 0.1},
              starts={"gamma_dot": [6.0, 6.0, 1.0, 0.5, 3.0, 8.0, 0.2, 4.0, 6.1]}, rel_tol=1e-8)
    kernel = Ensemble(built.fmu, lanes=4, cache=tmp_path).run(20.0, **kw)
    evt = Ensemble(built.fmu, lanes=4, cache=tmp_path, defines={"GW_TAYLOR_KERNEL_EVT": 0}).run(20.0, **kw)
    assert kernel.terminated.sum() >= 3 and list(kernel.status) == list(evt.status)
    assert list(kernel.steps) == list(evt.steps)
    np.testing.assert_allclose(kernel.t_final, evt.t_final, rtol=0, atol=2e-12 * 20.0)
    np.testing.assert_allclose(kernel.x_final, evt.x_final, rtol=1e-9, atol=1e-9)


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
    """GW_TL(evt) writes sign(v) as CasADi's casadi_sign, v < 0 ? -1 : v > 0 ? 1 : v, which gw_evt
    calls (taylor/graph.py's SIGN_C), not as (v > 0 ? 1 : (v < 0 ? -1 : 0)): that would give 0
    for a NaN (a finite indicator that does not fire where gw_evt's NaN counts as a crossing) and
    +0.0 for -0.0 (1 / sign: +inf against -inf).  The kernel's indicators are gw_evt's bit for
    bit where no sine is read from the kernel."""
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


def test_single_run_update_warning_and_terminal_events_as_with_gw_evt(example_build, tmp_path):
    """Solver taylor's single run reads the indicators from the kernel at every step's end but
    the last of each fmi2DoStep (c_src/gw_solver_taylor.c); test_taylor_events.py compares only
    the ensemble against gw_evt, on falls.  slope_hold has all three kinds: the stiction update
    (rolling_mode -1 -> 0, a jump of the state, the run goes on), the slip warning, the lift-off
    that ends the run.  Built with the kernel's indicators and rebuilt with gw_evt at every step
    (GW_TAYLOR_KERNEL_EVT 0), many communication steps and one: the same events in the same
    order at the same times, the same end, the same states (to the rounding by which the
    kernel's sine may differ from gw_sin's)."""
    import zipfile

    from gyrowheel.fmu_build.compiler import compile_shared
    built = example_build("slope_hold", taylor=True)  # the run's one build (read only: unpacked below)
    assert "#define GW_TL_HAS_EVT 1" in (built.sources / "gw_taylor_model.h").read_text()
    dirs = {}
    for flag in (1, 0):
        unz = dirs[flag] = tmp_path / f"k{flag}"
        with zipfile.ZipFile(built.fmu) as z:
            z.extractall(unz)
    # GW_TAYLOR_KERNEL_EVT 1 (c_src/gw_solver.h's default): the FMU's own binary; 0: the same
    # source and flags (compile_shared's) with gw_evt at every step
    lib = next((dirs[0] / "binaries" / "linux64").glob("*.so"))
    lib.unlink()
    compile_shared(built.sources / "gw_fmu.c", [built.sources], lib, extra_flags=["-DGW_TAYLOR_KERNEL_EVT=0"])
    for h, tol in ((0.0137, 1e-9), (10.0, 1e-7)):
        (ek, tk, xk), (e0, t0, x0) = (_events_and_state(built.fmu, dirs[f], h, 10.0, tol) for f in (1, 0))
        kinds = [k for k, _ in ek]
        assert any("state updated" in k for k in kinds) and any("warning" in k for k in kinds)
        assert any("terminated" in k for k in kinds) and tk < 10.0
        assert kinds == [k for k, _ in e0]
        np.testing.assert_allclose([t for _, t in ek], [t for _, t in e0], rtol=0, atol=1e-11)
        assert abs(tk - t0) < 1e-11
        np.testing.assert_allclose(xk, x0, rtol=1e-9, atol=1e-10)
