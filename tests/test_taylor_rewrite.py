"""The exact rewrites of the Taylor decomposition (taylor/rewrite.py).

- a system built to hit every rule (constant factors through products, sums, negations,
  divisions and reciprocals, squares x (c x), reciprocals used as factors, scaled operands of
  nonlinear ops, scaled outputs): its rewritten kernel's series against CasADi's own derivatives
  (Lie derivatives, no Taylor arithmetic of ours), also at a parameter 0 (no factor is divided by);
- the models of the project's scenes (the paper wheel, the Gyrover with flywheel and tilt, friction
  with its sqrt and divisions, the Euler disk, the lunar rover): the rewritten kernel's series equal
  the un-rewritten kernel's to rounding at random points;
- what the rewrite removes on the paper wheel: no mul by a constant, no twice, no reciprocal node,
  x (c x) as sq, fewer nodes and interior sums;
- random graphs of every supported kind of op, with parameters 0, negative and infinite: the
  rewritten kernel's series equal the un-rewritten one's, no finite coefficient made NaN or inf.
"""
from __future__ import annotations

import ctypes
import math
import random
import subprocess
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from conftest import SCENES
from gyrowheel.fmu_build import load_scene
from gyrowheel.fmu_build.builder import model_spec
from gyrowheel.fmu_build.codegen import hoisted, optimised, taylor_ode
from gyrowheel.fmu_build.compiler import compiler
from gyrowheel.taylor.kernel_c import taylor_source, work_series
from gyrowheel.taylor.kernel_plan import Plan
from gyrowheel.taylor.graph import Decomposition, decompose

ROOT = Path(__file__).resolve().parent.parent
ORDER = 9
D = ctypes.POINTER(ctypes.c_double)


class Jet:
    """A decomposition's kernel (one lane) compiled: series(t, x, u, p) -> (nx, ORDER + 1)."""

    def __init__(self, dec: Decomposition, tmp: Path, name: str):
        d = tmp / name
        d.mkdir(parents=True)
        (d / "gw_taylor_model.h").write_text(taylor_source(dec, name))
        (d / "jet.c").write_text(
            "#include <math.h>\n#include <stddef.h>\n#define GW_MAYBE_UNUSED __attribute__((unused))\n"
            "#define GW_TL_W 1\n#define GW_TL(name) rw_##name\n#include \"gw_taylor_model.h\"\n"
            "void jet(int order, const double *t, const double *x, const double *u, const double *p,"
            " double *w);\n"
            "void jet(int order, const double *t, const double *x, const double *u, const double *p,"
            " double *w) {\n    double c[GW_TL_NCST + 1];\n    rw_cst(u, p, c);\n"
            "    rw_jet(order, t, x, c, w);\n}\n")
        subprocess.run([compiler(), "-std=c99", "-O1", "-shared", "-fPIC", "-Wall", "-Wextra", "-Werror",
                        f"-I{ROOT / 'c_src'}", f"-I{d}", str(d / "jet.c"), "-o", str(d / "jet.so"), "-lm"],
                       check=True, capture_output=True)
        self.lib, self.nx, self.size = ctypes.CDLL(str(d / "jet.so")), dec.nx, work_series(dec)

    def series(self, t: float, x, u, p) -> np.ndarray:
        t, x, u, p = (np.ascontiguousarray(v, dtype=float).reshape(-1) for v in ([t], x, u, p))
        w = np.zeros(self.size * (ORDER + 1) + 8)
        self.lib.jet(ORDER, *(v.ctypes.data_as(D) for v in (t, x, u, p, w)))
        return w[: self.nx * (ORDER + 1)].reshape(self.nx, ORDER + 1).copy()


def _rules_system() -> ca.Function:
    """x' = f(t, x, p) using every rewrite rule (p = (p0, p1): factors that may be 0)"""
    x, t, p = ca.SX.sym("x", 4), ca.SX.sym("t"), ca.SX.sym("p", 2)
    a, b, c, d = x[0], x[1], x[2], x[3]
    k = p[0] * (2.0 - p[1])
    r = 3.0 / (2.0 * (k + 1.5) * (c + 2.0))  # a reciprocal of a scaled sum, used as a factor
    sa = a * (0.7 * a)  # x (c x)
    e = -(2.0 * (p[0] * b)) * (p[1] * a)  # factors through neg, twice and a product
    f = [
        r * (p[0] * sa) - (b * r) * 1.3 + e + ca.exp(-(a * b)),  # reciprocals -> divisions; lin
        ca.sin(0.5 * (a - p[1] * d)) * (c * r) / (0.25 * b * b + 1.0),  # scaled sincos argument
        (p[0] * a) / (p[1] * (c + 2.0)) + 1.0 / (r * (d * d + 1.0)) - 2.0 * ca.sqrt(3.0 * (c + 2.5)),
        ca.atan2(p[0] * a + 0.3, 2.0 * b - 4.0) + (0.5 * (d + 2.0)) ** 1.5 - t * (p[0] * c)
        + ca.exp(-(2.0 * a)) * (2.0 - b) / (1.0 / (c + 3.0) * p[1] + 1.0),
    ]
    return optimised(ca.Function("gw_ode", [t, x, ca.SX.sym("u", 0), p], [ca.vertcat(*f)],
                                 ["t", "x", "u", "p"], ["xdot"]))


def _lie(f: ca.Function) -> ca.Function:
    """x^(k)(t) / k!, k = 0 .. ORDER, of the solution through (t, x) (CasADi's derivatives)"""
    t, x, p = ca.SX.sym("t"), ca.SX.sym("x", f.nnz_in(1)), ca.SX.sym("p", f.nnz_in(3))
    rhs, g, ders = f(t, x, ca.SX(0, 1), p), x, [x]
    for k in range(1, ORDER + 1):
        g = ca.jtimes(g, x, rhs) + ca.jacobian(g, t)
        ders.append(g / math.factorial(k))
    return ca.Function("lie", [t, x, p], [ca.horzcat(*ders)])


def test_rules_system_against_casadi_derivatives(tmp_path):
    """Every rule applied (op counts), and the rewritten series equal CasADi's derivatives,
    also with a factor 0 (p0 = 0: a rewrite dividing by it would give NaN)."""
    f = _rules_system()
    dec, raw = decompose(f), decompose(f, rewrite=False)
    assert not {"twice", "neg"} & set(dec.op_counts)
    assert dec.op_counts["sq"] > raw.op_counts.get("sq", 0) and len(dec.nodes) < len(raw.nodes)
    assert any(s is not None for s in dec.output_scales)
    jet, lie = Jet(dec, tmp_path, "rules"), _lie(f)
    rng = np.random.default_rng(5)
    for i in range(6):
        x = rng.uniform(-0.8, 0.8, 4)
        p = np.array([0.0 if i == 0 else rng.uniform(0.5, 1.5), rng.uniform(0.5, 1.5)])
        t = rng.uniform(0, 2)
        got, ref = jet.series(t, x, [], p), np.array(lie(t, x, p))
        assert np.all(np.isfinite(got))
        np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-10 * np.max(np.abs(ref)))


def _scene_ode(name: str) -> tuple[ca.Function, np.ndarray, np.ndarray, np.ndarray]:
    """a scene's ode as the FMU's kernel gets it (hoisted, cse'd, put back together), its state
    at the start values, the inputs and parameters at their start values"""
    spec = model_spec(load_scene(SCENES / name))
    fns = {slot: optimised(fn) for slot, fn in hoisted(spec).items()}
    p = np.array([q.start for q in spec.parameters], dtype=float)
    x0 = np.array(spec.functions()["init"]([q.start for q in spec.starts], p)).ravel()
    u = np.array([q.start for q in spec.inputs], dtype=float) if spec.inputs else np.zeros(0)
    return taylor_ode(fns), x0, u, p


@pytest.mark.parametrize("scene", ["paper_earth.toml", "gyrover_mission_earth.toml",
                                   "paper_earth_friction.toml", "euler_disk.toml", "lunar_rover.toml"])
def test_scene_series_equal_the_unrewritten_kernel(scene, tmp_path):
    ode, x0, u, p = _scene_ode(scene)
    new, old = decompose(ode), decompose(ode, rewrite=False)
    assert len(new.nodes) < len(old.nodes)
    a, b = Jet(new, tmp_path, "new"), Jet(old, tmp_path, "old")
    rng = np.random.default_rng(3)
    for _ in range(4):
        x = x0 + rng.uniform(-0.05, 0.05, x0.size) * np.maximum(1.0, np.abs(x0))
        got, ref = a.series(0.3, x, u, p), b.series(0.3, x, u, p)
        assert np.all(np.isfinite(ref))
        scale = np.max(np.abs(ref), axis=1, keepdims=True)  # each state's series
        err = np.max(np.abs(got - ref) / np.where(scale > 0, scale, 1.0))
        assert err < 1e-11, f"{scene}: series differ by {err:.1e} of their largest coefficient"


def test_paper_wheel_rewrite_removes_the_waste():
    """The paper wheel's graph: c / (2 c' sin b) used as a factor of two products -> one
    shared quotient, no linear node carrying only a constant factor, x (c y + d) distributed and
    its products shared: 18 interior terms instead of 24."""
    ode, *_ = _scene_ode("paper_earth.toml")
    new, old = decompose(ode), decompose(ode, rewrite=False)
    assert old.op_counts["twice"] == 1 and "twice" not in new.op_counts
    recip = lambda d: [nd for nd in d.nodes.values() if nd.op == "div" and nd.args[0][0] == "c"]  # noqa: E731
    assert recip(old) and not recip(new)
    assert new.op_counts["div"] == 1 and new.op_counts["sincos"] == old.op_counts["sincos"]
    assert not [nd for nd in new.nodes.values() if nd.op == "mul" and "c" in (a[0] for a in nd.args)]
    assert len(new.nodes) <= len(old.nodes) - 15
    assert (len(Plan(old).terms), len(Plan(new).terms)) == (24, 18)
    assert sum(nd.op == "mul" for nd in new.nodes.values()) == 13  # heyoka's minimal form: 15


def test_products_shared_modulo_associativity(tmp_path):
    """a b c and a b d share a b; a x / d and b x / d share x / d (one division); a (0.5 b - 2)
    read once is distributed, 0.5 (a b) - 2 a, and merged into the sum reading it; the
    rewritten series equal CasADi's derivatives."""
    x, t, p = ca.SX.sym("x", 6), ca.SX.sym("t"), ca.SX.sym("p", 1)
    a, b, c, d, e = (x[i] for i in range(5))
    den = d * d + 1.0
    f = [(a * b) * c, d * (b * a), (a * e) / den, (c * e) / den + 1.0, p[0] * ((e * d) * (a * b)),
         a * (0.5 * b - 2.0) + c]
    ode = optimised(ca.Function("gw_ode", [t, x, ca.SX.sym("u", 0), p], [ca.vertcat(*f)],
                                ["t", "x", "u", "p"], ["xdot"]))
    dec = decompose(ode)
    kinds = [(nd.op, len(Plan(dec).terms)) for nd in dec.nodes.values()]
    assert dec.op_counts["div"] == 1, kinds  # e / den, shared
    assert dec.op_counts["mul"] <= 6, kinds  # a b; (a b) c, (a b) d; a (e/den), c (e/den); e d (a b)
    lins = [nd for nd in dec.nodes.values() if nd.op == "lin"]
    assert [len(nd.args) for nd in lins] == [3], kinds  # 0.5 (a b) - 2 a + c, a b shared
    jet, lie = Jet(dec, tmp_path, "shared"), _lie(ode)
    rng = np.random.default_rng(8)
    for _ in range(4):
        x0, p0 = rng.uniform(-0.8, 0.8, 6), rng.uniform(0.5, 1.5, 1)
        got, ref = jet.series(0.2, x0, [], p0), np.array(lie(0.2, x0, p0))
        np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-10 * np.max(np.abs(ref)))


def _random_expr(rng: random.Random, x: ca.SX, p: ca.SX, t: ca.SX, depth: int) -> ca.SX:
    """a random expression of the states, parameters and time: every rewrite rule's pattern
    (factors, reciprocals, x (c x), a (c b + d), shared products) among nonlinear ops"""
    if depth == 0 or rng.random() < 0.2:
        return rng.choice([x[0], x[1], x[2], p[0], p[1], p[2], t, ca.SX(rng.choice([0.0, -1.5, 2.0]))])
    a, b = _random_expr(rng, x, p, t, depth - 1), _random_expr(rng, x, p, t, depth - 1)
    c = rng.choice([p[0], p[1], p[2], 2.0, -0.5])
    return rng.choice([
        a + b, a - b, a * b, c * a, a / (b * b + 1.5), a / c, c / (2.0 * (a * a + 1.0)), -a, 2 * a,
        ca.sin(a), ca.cos(0.5 * a), ca.exp(0.3 * ca.sin(a)), ca.sqrt(a * a + 1.0), ca.atan2(a, b + 3.0),
        (a * a + 1.0) ** 1.5, (a * a + 1.0) ** (0.3 * ca.sin(b)), ca.tanh(a), ca.fabs(a),
        ca.fmin(a, b), ca.fmax(a, b), ca.if_else(a > 0.1, b, 2.0 * a), ca.atan(a), ca.log(a * a + 2.0),
        (a * b) * (c * a) + (b * a) / (a * a + 1.0), a * (c * a), a * (c * b - p[1]) + a])


@pytest.mark.parametrize("seed", range(40))
def test_random_graphs_rewritten_equal_unrewritten(seed, tmp_path):
    """The rewritten kernel's series equal the un-rewritten one's on random graphs, also with
    parameters 0, negative and infinite: no finite coefficient becomes NaN or inf (a factor
    divided by, a product reassociated through 0 inf)."""
    rng = random.Random(seed)
    x, t, p = ca.SX.sym("x", 3), ca.SX.sym("t"), ca.SX.sym("p", 3)
    f = [_random_expr(rng, x, p, t, 4) + 0.1 * x[i] for i in range(3)]
    ode = optimised(ca.Function("gw_ode", [t, x, ca.SX.sym("u", 0), p], [ca.vertcat(*f)],
                                ["t", "x", "u", "p"], ["xdot"]))
    new, old = Jet(decompose(ode), tmp_path, "new"), Jet(decompose(ode, rewrite=False), tmp_path, "old")
    points = np.random.default_rng(seed)
    for pv in ([0.7, 1.1, -0.4], [0.0, 0.0, 0.0], [-1.3, 0.0, 2.0], [math.inf, 1.0, 0.5], [1.0, -math.inf, 0.0]):
        xv = points.uniform(-0.9, 0.9, 3)
        got, ref = new.series(0.37, xv, [], pv), old.series(0.37, xv, [], pv)
        finite = np.isfinite(ref)
        assert np.all(np.isfinite(got[finite])), f"p = {pv}: finite coefficients became {got[finite & ~np.isfinite(got)]}"
        got, ref = np.where(finite, got, 0.0), np.where(finite, ref, 0.0)
        scale = np.max(np.abs(ref), axis=1, keepdims=True)
        err = np.max(np.abs(got - ref) / np.where(scale > 0, scale, 1.0))
        assert err < 1e-10, f"p = {pv}: series differ by {err:.1e} of their largest coefficient"
