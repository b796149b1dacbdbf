"""model/polynomial.py: the exact normal form and the structured solve the equations go through.

Checked against plain evaluation of the input at random points (the rewrite must not change the
function), against numpy's solver, and on the wheel against the independent Newton-Euler
derivation (tests/reference/newton_euler.py) at random states, near flat included.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from gyrowheel.fmu_build.codegen import hoisted
from gyrowheel.model.build import build_model
from gyrowheel.model.polynomial import Normaliser, TooLarge, simplify, solve_linear
from reference import newton_euler as ne

a, b, c, d = (ca.SX.sym(n) for n in "abcd")


def values_equal(e1, e2, syms, n=20, seed=1):
    f = ca.Function("f", syms, [ca.densify(ca.vec(e1)), ca.densify(ca.vec(e2))])
    rng = np.random.default_rng(seed)
    for _ in range(n):
        v1, v2 = (np.array(v) for v in f(*rng.uniform(-2, 2, len(syms))))
        np.testing.assert_allclose(v1, v2, rtol=1e-12, atol=1e-12)


def n_ops(e, syms) -> int:
    return ca.Function("f", syms, [ca.cse(e)]).n_instructions()


def test_equal_terms_merge_and_opposites_cancel():
    e = ca.vertcat(0.5 * a * b + 0.5 * b * a, (a + b) * (a - b) - a * a + b * b, 3 * (a * c) - (c * a) * 3)
    s = simplify(e)
    assert str(s[0]) == "(a*b)"
    assert float(ca.DM(s[1])) == 0 and float(ca.DM(s[2])) == 0


def test_sin_squared_plus_cos_squared():
    e = ca.cos(c) ** 2 * a + ca.sin(c) ** 2 * a - a + ca.sin(c) * ca.cos(c)
    s = simplify(e)
    values_equal(e, s, [a, c])
    assert "cos(c)" in str(s) and "sq(cos" not in str(s)
    assert float(ca.DM(simplify(ca.cos(d) ** 2 + ca.sin(d) ** 2))) == 1.0


def test_atoms_keep_their_arguments_canonical():
    e = ca.sin(a * b) / (b * a + 1) + ca.sin(b * a) / (1 + a * b)
    s = simplify(e)
    values_equal(e, s, [a, b])
    assert str(s).count("sin") == 1


@pytest.mark.parametrize("expr", [
    ca.exp(a) * (a + b) ** 3 - ca.sqrt(c * c + 1) * ca.tanh(d),
    ca.fmax(a, b) * ca.if_else(c > 0, a, b) + ca.atan2(a, c) ** 2,
    (a + b) / (c - d) - ca.cos(a + b) * ca.sin(a),
])
def test_any_expression_keeps_its_values(expr):
    values_equal(expr, simplify(expr), [a, b, c, d])


def test_expansion_past_the_limit_returns_the_input():
    big = (a + b + c + d + 1) ** 8
    assert simplify(big, max_terms=50) is not None
    with pytest.raises(TooLarge):
        Normaliser(max_terms=50).polys(big)
    assert ca.is_equal(simplify(big, max_terms=50), big)


def test_structured_solve_matches_numpy():
    syms = [a, b, c, d]
    A = ca.SX.zeros(4, 4)
    A[0, 0], A[0, 2], A[2, 0], A[2, 2] = a + 2, b, b, c * c + 3
    A[1, 1] = ca.cos(d) + 2
    A[3, 3] = 5.0
    rhs = ca.vertcat(a * b, ca.sin(c), d - a, 2 * a)
    x = solve_linear(ca.sparsify(A), rhs)
    f = ca.Function("f", syms, [x, ca.densify(A), rhs])
    rng = np.random.default_rng(3)
    for _ in range(10):
        xv, Av, bv = (np.array(v) for v in f(*rng.uniform(-1, 1, 4)))
        np.testing.assert_allclose(xv.ravel(), np.linalg.solve(Av, bv.ravel()), rtol=1e-12)
    divisions = sum(1 for k in range(f.n_instructions()) if f.instruction_id(k) == ca.OP_DIV)
    assert divisions == 1  # one shared reciprocal for the whole system (the 1x1 constant block: none)


def test_wheel_rhs_is_smaller_and_agrees_with_newton_euler():
    """The FMU's ode (parameter-only part hoisted into ode_pre, gyrowheel.fmu_build.codegen.hoisted) has one
    division and the sines and cosines of alpha and beta only, and both forms equal the
    Newton-Euler right-hand side at random states, near flat and upright included."""
    spec = build_model()
    fns = hoisted(spec)
    ode, pre = fns["ode"], fns["ode_pre"]
    ode = ca.Function("ode", ode.sx_in(), ca.cse(ode.call(ode.sx_in())))
    ops = [ode.instruction_id(k) for k in range(ode.n_instructions())]
    assert ops.count(ca.OP_DIV) == 1  # a symbolic 3x3 solve would take 5
    assert ops.count(ca.OP_SIN) + ops.count(ca.OP_COS) == 4  # sin/cos of alpha and beta only
    assert ops.count(ca.OP_MUL) + ops.count(ca.OP_ADD) + ops.count(ca.OP_SUB) < 50  # 170 with a symbolic 3x3 solve
    full = spec.functions()["ode"]
    p = [2.0, 0.17, 0.25, 0.4, 0.02, 9.81]
    c = pre(p)
    rng = np.random.default_rng(7)
    for k in range(100):
        x = rng.uniform(-3, 3, 8)
        x[3] = rng.uniform(1e-3, np.pi - 1e-3) if k % 2 else rng.choice([1e-3, np.pi - 1e-3, np.pi / 2])
        ref = ne.rhs(x, (2.0, 0.17, 0.25, 0.4, 9.81))
        scale = max(1.0, np.max(np.abs(ref)))
        for got in (np.array(ode(0.0, x, [], p, c)).ravel(), np.array(full(0.0, x, [], p)).ravel()):
            np.testing.assert_allclose(got, ref, rtol=0, atol=1e-13 * scale)
