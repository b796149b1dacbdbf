"""The generated Taylor kernel (taylor/kernel_c.py, c_src/gw_taylor_ops.h) on its own.

- every recurrence to order 20 against an independent reference: each operation applied to
  operands with closed-form solutions (y = y0 e^{0.3 t}, z = 0.4 + (z0 - 0.4) e^{-0.25 t}),
  whose Taylor coefficients mpmath computes at 50 digits (no Taylor arithmetic of ours);
- the lane layouts (W = 1, 2 and 4 and 8 with GCC's vector extension, 3 as plain lanes) give
  the same numbers, bit for bit, lane by lane, at misaligned work arrays, and write nothing
  outside the work size GW_TL_NVAR (order + 1) W they announce;
- every lane count compiles under -std=c99 -Wall -Wextra -Wpedantic -Werror with gcc and clang;
- the recurrence of every elementary operation against CasADi's own derivatives (coefficient k =
  derivative / k!) at random points; an unsupported operation is refused by name; every example
  scene's operations are supported.
"""
from __future__ import annotations

import ctypes
import functools
import math
import shutil
import subprocess
from pathlib import Path

import casadi as ca
import mpmath as mp
import numpy as np
import pytest

from conftest import SCENES
from gyrowheel.fmu_build import load_scene
from gyrowheel.fmu_build.builder import model_spec
from gyrowheel.fmu_build.codegen import optimised
from gyrowheel.fmu_build.compiler import compiler
from gyrowheel.taylor.kernel_c import taylor_source, work_series
from gyrowheel.taylor.graph import TaylorUnsupportedError, decompose

ROOT = Path(__file__).resolve().parent.parent
ORDER = 20
STRICT = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]


def _ops(y, z, t, p, lib):
    """op name -> expression in y(t), z(t), t, p; lib: casadi or the mpmath stand-ins"""
    return {
        "mul": y * z, "div": y / z, "div_const_num": 2.0 / z, "sq": y ** 2, "sqrt": lib.sqrt(z),
        "sin": lib.sin(y), "cos": lib.cos(z), "tan": lib.tan(y), "exp": lib.exp(y),
        "log": lib.log(z), "pow_const": y ** 2.5, "pow_var": z ** y, "tanh": lib.tanh(y),
        "atan2": lib.atan2(y, z), "atan": lib.atan(y), "asin": lib.asin(y), "acos": lib.acos(z),
        "sinh": lib.sinh(y), "cosh": lib.cosh(z), "neg_twice": -(2 * y) + z - 1.0, "inv": 1.0 / y,
        "time": lib.sin(t) * y, "sub_const": 1.0 - y * p, "fabs": lib.fabs(y - 0.5),
        "fmin": lib.fmin(y, z), "fmax": lib.fmax(y, p * z), "if_else": lib.if_else(y > z, y * y, z),
        "sign": lib.sign(y - 0.5) * z, "floor": lib.floor(4.0 * y) * z,
        "chain": lib.exp(lib.sin(y * z) / (1.0 + y)) * lib.sqrt(z + y * y),
    }


class _Mp:
    """mpmath with CasADi's names (the branch of a piecewise op taken at the point)"""
    sqrt, sin, cos, tan, exp, log = mp.sqrt, mp.sin, mp.cos, mp.tan, mp.exp, mp.log
    tanh, atan2, atan, asin, acos = mp.tanh, mp.atan2, mp.atan, mp.asin, mp.acos
    sinh, cosh, fabs, sign, floor = mp.sinh, mp.cosh, abs, mp.sign, mp.floor
    fmin, fmax = staticmethod(min), staticmethod(max)

    @staticmethod
    def if_else(c, a, b):
        return a if c else b


def _system():
    y, z, t = ca.SX.sym("y"), ca.SX.sym("z"), ca.SX.sym("t")
    p = ca.SX.sym("p", 1)
    ops = _ops(y, z, t, p[0], ca)
    w = ca.SX.sym("w", len(ops))
    f = ca.Function("gw_ode", [t, ca.vertcat(y, z, w), ca.SX.sym("u", 0), p],
                    [ca.vertcat(0.3 * y, -0.25 * z + 0.1, *ops.values())], ["t", "x", "u", "p"], ["xdot"])
    return optimised(f), list(ops)


def _library(f: ca.Function, lanes: int, tmp: Path, cc: str = "cc", flags=STRICT) -> ctypes.CDLL:
    """jet(order, t, x, p, w) and nvar() of f's kernel with `lanes` lanes"""
    d = tmp / f"w{lanes}_{Path(cc).name}"
    d.mkdir(parents=True, exist_ok=True)
    (d / "gw_taylor_model.h").write_text(taylor_source(decompose(f), "ops"))
    (d / "jet.c").write_text(
        "#include <math.h>\n#include <stddef.h>\n#define GW_MAYBE_UNUSED __attribute__((unused))\n"
        f"#define GW_TL_W {lanes}\n#define GW_TL(name) gw_t_##name\n#include \"gw_taylor_model.h\"\n"
        "int nvar(void);\nint nvar(void) { return GW_TL_NVAR; }\n"
        "void jet(int order, const double *t, const double *x, const double *p, double *w);\n"
        "void jet(int order, const double *t, const double *x, const double *p, double *w) {\n"
        "    double c[(GW_TL_NCST + 1) * GW_TL_W];\n    gw_t_cst(NULL, p, c);\n"
        "    gw_t_jet(order, t, x, c, w);\n}\n")
    lib = d / "jet.so"
    r = subprocess.run([cc, *flags, "-shared", "-fPIC", f"-I{ROOT / 'c_src'}", f"-I{d}", str(d / "jet.c"),
                        "-o", str(lib), "-lm"], capture_output=True, text=True)
    assert r.returncode == 0, f"{cc} W={lanes}:\n{r.stderr}"
    return ctypes.CDLL(str(lib))


def _points(n: int, nx: int):
    rng = np.random.default_rng(20)
    pts = []
    for _ in range(n):
        y0, z0 = rng.uniform(0.3, 0.7, 2)
        if abs(y0 - z0) < 0.05 or abs(y0 - 0.5) < 0.05 or abs(4 * y0 - round(4 * y0)) < 0.1:
            y0 = 0.62 if y0 < 0.5 else 0.36  # away from the kinks of the piecewise ops
        pts.append((np.concatenate([[y0, z0], rng.uniform(-1, 1, nx - 2)]), rng.uniform(0, 2),
                    rng.uniform(0.5, 1.5)))
    return pts


def _run(lib, lanes: int, order: int, pts, offset: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """states' series (lanes, nx, order + 1) at the points (one per lane), and the whole work
    array (its canaries around the announced size)"""
    nx = pts[0][0].size
    D = ctypes.POINTER(ctypes.c_double)
    x = np.ascontiguousarray(np.array([q[0] for q in pts]).T)  # x[i W + l]
    t = np.array([q[1] for q in pts])
    p = np.array([q[2] for q in pts])
    size = lib.nvar() * (order + 1) * lanes
    buf = np.full(size + offset + 16, 7.25)
    w = buf[offset:]
    lib.jet(order, t.ctypes.data_as(D), x.ctypes.data_as(D), p.ctypes.data_as(D), w.ctypes.data_as(D))
    series = w[: nx * (order + 1) * lanes].reshape(nx, order + 1, lanes).transpose(2, 0, 1)
    return series, buf


@pytest.fixture(scope="module")
def system():
    return _system()


def test_every_recurrence_to_order_20_against_mpmath(system, tmp_path):
    """State w_op of w_op' = op(y(t), z(t)) has coefficients c_k / (k + 1) of op(y, z) at t0."""
    f, names = system
    lib = _library(f, 1, tmp_path)
    mp.mp.dps = 50
    for x, t0, p in _points(3, f.nnz_in(1)):
        series = _run(lib, 1, ORDER, [(x, t0, p)])[0][0]
        y0, z0 = mp.mpf(x[0]), mp.mpf(x[1])

        @functools.lru_cache(maxsize=None)
        def at(s, prec):  # every op at t0 + s (mpmath samples the same s for each op)
            y, z = y0 * mp.exp(0.3 * s), 0.4 + (z0 - 0.4) * mp.exp(-0.25 * s)
            return _ops(y, z, t0 + s, mp.mpf(p), _Mp)
        for i, name in enumerate(names):
            ref = mp.taylor(lambda s: at(s, mp.mp.prec)[name], 0, ORDER - 1)
            ref = np.array([0.0] + [float(c) / (k + 1) for k, c in enumerate(ref)])
            got = series[2 + i]
            # compare at the scale a step uses: r = the series' radius estimate
            r = 1.0 / max(abs(c) ** (1.0 / k) for k, c in enumerate(ref) if k > 0 and c != 0.0)
            scaled = np.abs(got[1:] - ref[1:]) * r ** np.arange(1, ORDER + 1)
            assert scaled.max() <= 1e-12 * max(1.0, np.abs(ref[1:] * r ** np.arange(1, ORDER + 1)).max()), (
                name, int(np.argmax(scaled)) + 1, got[1:6], ref[1:6])
        # the drivers too: y_k = y0 0.3^k / k!
        np.testing.assert_allclose(series[0], [x[0] * 0.3 ** k / math.factorial(k) for k in range(ORDER + 1)],
                                   rtol=1e-13, atol=0)


@pytest.mark.parametrize("lanes", [2, 3, 4, 8, 16])
def test_lanes_equal_one_lane_bit_for_bit(system, tmp_path, lanes):
    """Each lane of a W-lane kernel equals the one-lane kernel at its point, bit for bit
    (same operations per lane; no contraction in either build), at work arrays of every
    alignment, and nothing outside the announced work size is written."""
    f, _ = system
    one, many = _library(f, 1, tmp_path), _library(f, lanes, tmp_path)
    assert many.nvar() == one.nvar() == work_series(decompose(f))
    pts = _points(lanes, f.nnz_in(1))
    for order in (3, 13, ORDER):
        ref = np.array([_run(one, 1, order, [q])[0][0] for q in pts])
        for offset in range(4):
            got, buf = _run(many, lanes, order, pts, offset)
            np.testing.assert_array_equal(got, ref, err_msg=f"W={lanes} order {order} offset {offset}")
            size = many.nvar() * (order + 1) * lanes
            assert (buf[:offset] == 7.25).all() and (buf[offset + size:] == 7.25).all()
            assert np.isfinite(got).all()


@pytest.mark.parametrize("cc", ["gcc", "clang"])
def test_every_lane_count_warning_clean(system, tmp_path, cc):
    """The kernel template instantiated with 1, 2, 3, 4, 8, 16 lanes compiles under -std=c99 -Wall
    -Wextra -Wpedantic -Werror (the assertion in _library shows the compiler's output)."""
    if shutil.which(cc) is None:
        pytest.skip(f"{cc} is not installed (make test installs it: Debian package {cc})")
    f, _ = system
    for lanes in (1, 2, 3, 4, 8, 16):
        _library(f, lanes, tmp_path, cc)


# ---- against CasADi's derivatives; what the decomposition supports -------------------------

def _op_system():
    """x' = (drivers y, z; then one state per operation of y and z)."""
    y, z, t = ca.SX.sym("y"), ca.SX.sym("z"), ca.SX.sym("t")
    p = ca.SX.sym("p", 1)
    ops = {
        "mul": y * z, "div": y / z, "div_const_num": 2.0 / z, "sq": y ** 2, "sqrt": ca.sqrt(z),
        "sin": ca.sin(y), "cos": ca.cos(z), "tan": ca.tan(y), "exp": ca.exp(y), "log": ca.log(z),
        "pow_const": y ** 2.5, "pow_var": z ** y, "tanh": ca.tanh(y), "atan2": ca.atan2(y, z),
        "atan": ca.atan(y), "asin": ca.asin(y), "acos": ca.acos(z), "fabs": ca.fabs(y - 0.5),
        "fmin": ca.fmin(y, z), "fmax": ca.fmax(y, p[0] * z), "if_else": ca.if_else(y > z, y * y, z),
        "sinh": ca.sinh(y), "cosh": ca.cosh(z), "neg_twice": -(2 * y) + z - 1.0, "inv": 1.0 / y,
        "time": ca.sin(t) * y, "sub_const": 1.0 - y * p[0],
    }
    w = ca.SX.sym("w", len(ops))
    x = ca.vertcat(y, z, w)
    xdot = ca.vertcat(0.3 + 0.2 * z * p[0], -0.25 * y + 0.1, *ops.values())
    f = ca.Function("gw_ode", [t, x, ca.SX.sym("u", 0), p], [xdot], ["t", "x", "u", "p"], ["xdot"])
    return f, list(ops)


def _jet_library(f: ca.Function, tmp: Path) -> ctypes.CDLL:
    (tmp / "gw_taylor_model.h").write_text(taylor_source(decompose(optimised(f)), "ops"))
    (tmp / "jet.c").write_text(
        '#include <math.h>\n#include <stddef.h>\n#define GW_MAYBE_UNUSED __attribute__((unused))\n#define GW_TL_W 1\n'
        '#define GW_TL(name) gw_tl1_##name\n#include "gw_taylor_model.h"\n'
        "void jet(int order, const double *t, const double *x, const double *p, double *w);\n"
        "void jet(int order, const double *t, const double *x, const double *p, double *w) {\n"
        "    double c[GW_TL_NCST + 1];\n    gw_tl1_cst(NULL, p, c);\n    gw_tl1_jet(order, t, x, c, w);\n}\n")
    lib = tmp / "jet.so"
    subprocess.run([compiler(), "-std=c99", "-O1", "-shared", "-fPIC", "-Wall", "-Wextra", "-Werror",
                    f"-I{ROOT / 'c_src'}", f"-I{tmp}", str(tmp / "jet.c"), "-o", str(lib), "-lm"],
                   check=True, capture_output=True)
    return ctypes.CDLL(str(lib))


def _lie_derivatives(f: ca.Function, order: int) -> ca.Function:
    """x^(k)(t), k = 0..order, of the solution through (t, x): d/dt g = dg/dx f + dg/dt."""
    t, x, p = ca.SX.sym("t"), ca.SX.sym("x", f.nnz_in(1)), ca.SX.sym("p", 1)
    rhs = f(t, x, ca.SX(0, 1), p)
    ders, g = [x], x
    for _ in range(order):
        g = ca.jtimes(g, x, rhs) + ca.jacobian(g, t)
        ders.append(g)
    return ca.Function("lie", [t, x, p], [ca.horzcat(*ders)])


def test_recurrences_match_casadi_derivatives(tmp_path):
    """Coefficient k of every operation's series equals CasADi's k-th derivative / k!."""
    f, names = _op_system()
    order = 7
    lib = _jet_library(f, tmp_path)
    lie = _lie_derivatives(f, order)
    dec = decompose(optimised(f))
    nx = f.nnz_in(1)
    rng = np.random.default_rng(11)
    D = ctypes.POINTER(ctypes.c_double)
    for _ in range(5):
        y, z = rng.uniform(0.2, 0.8, 2)
        x = np.concatenate([[y, z], rng.uniform(-1, 1, nx - 2)])
        t, p = np.array([rng.uniform(0, 2)]), np.array([rng.uniform(0.5, 1.5)])
        w = np.zeros(work_series(dec) * (order + 1))
        lib.jet(order, t.ctypes.data_as(D), x.ctypes.data_as(D), p.ctypes.data_as(D), w.ctypes.data_as(D))
        jet = w[: nx * (order + 1)].reshape(nx, order + 1)
        ref = np.array(lie(t[0], x, p)) / np.array([math.factorial(k) for k in range(order + 1)])
        for i in range(nx):
            name = "driver" if i < 2 else names[i - 2]
            np.testing.assert_allclose(jet[i], ref[i], rtol=1e-9, atol=1e-11, err_msg=name)


def test_unsupported_operation_is_refused_by_name(tmp_path):
    x = ca.SX.sym("x", 1)
    f = ca.Function("gw_ode", [ca.SX.sym("t"), x, ca.SX.sym("u", 0), ca.SX.sym("p", 0)], [ca.erf(x)])
    with pytest.raises(TaylorUnsupportedError, match="'erf'"):
        decompose(f)


@pytest.mark.parametrize("path", sorted(SCENES.glob("*.toml")), ids=lambda p: p.stem)
def test_every_example_scene_supported(path):
    """Every effect's operations have recurrences (the decomposition of each example scene)."""
    spec = model_spec(load_scene(path))
    dec = decompose(optimised(spec.functions()["ode"]))
    assert dec.nx == spec.x.numel() and dec.n_var > dec.nx
