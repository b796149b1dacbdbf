"""Sweep specs: grids, random samples, names and values checked before anything runs (no FMU)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gyrowheel.studies.batch import Settings
from gyrowheel.studies.execute import MAX_BATCH, auto_batch_size
from gyrowheel.studies.plan import Resolver
from gyrowheel.studies.spec import SweepSpecError, as_axis, parse_grid, parse_random, point_table
from gyrowheel.studies.target import Variable


def test_grid_forms():
    assert parse_grid("beta_deg=60:89:30").values == tuple(np.linspace(60, 89, 30))
    assert parse_grid("rel_tol=1e-10:1e-4:7:log").values == tuple(np.geomspace(1e-10, 1e-4, 7))
    assert parse_grid("g=earth,mars,3.0").values == ("earth", "mars", 3.0)
    assert parse_grid("gamma_dot=6").values == (6.0,)
    assert as_axis("M", [1, 2]).values == (1.0, 2.0)


@pytest.mark.parametrize("item, message", [
    ("beta_deg=60:89", "expected NAME=START:STOP:N"),
    ("beta_deg=60:89:x", "not an integer"),
    ("beta_deg=60:89:0", ">= 1"),
    ("beta_deg=a:89:3", "'a' is not a number"),
    ("rel_tol=0:1:3:log", "START > 0"),
    ("beta_deg", "expected NAME=SPEC"),
    ("=1,2", "expected NAME=SPEC"),
    ("M=1,,2", "empty value"),
])
def test_bad_grids_name_the_flag(item, message):
    with pytest.raises(SweepSpecError, match=message) as err:
        parse_grid(item)
    assert "--grid" in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("item, message", [
    ("M=gauss:2:0.1", "normal:MU:SIGMA or"), ("M=normal:2", "normal:MU:SIGMA"),
    ("M=normal:2:-1", "sigma must be >= 0"), ("M=uniform:2:1", "B > A"), ("M=normal:2:nan", "not finite"),
])
def test_bad_random_specs(item, message):
    with pytest.raises(SweepSpecError, match=message):
        parse_random(item)


def test_grid_product_order_and_common_random_numbers():
    grid = [parse_grid("a=1,2"), parse_grid("b=10,20,30")]
    table = point_table(grid, [parse_random("M=normal:2:0.1")], samples=4, seed=1)
    assert len(table) == 2 * 3 * 4 and list(table.columns) == ["a", "b", "M"]
    assert list(table["a"][:12]) == [1.0] * 12  # the first grid varies slowest
    assert list(table["b"][:8]) == [10.0] * 4 + [20.0] * 4
    draws = np.random.default_rng(1).normal(2, 0.1, 4)
    for start in range(0, len(table), 4):  # the same samples at every grid point
        assert list(table["M"][start:start + 4]) == list(draws)
    again = point_table(grid, [parse_random("M=normal:2:0.1")], samples=4, seed=1)
    assert table.equals(again)


def test_uniform_samples_in_range_and_seeded():
    t1 = point_table([], [parse_random("k=uniform:0.8:1.2")], samples=1000, seed=7)
    t2 = point_table([], [parse_random("k=uniform:0.8:1.2")], samples=1000, seed=8)
    assert t1["k"].between(0.8, 1.2).all() and not t1.equals(t2)


@pytest.mark.parametrize("kwargs, message", [
    (dict(grid=[parse_grid("a=1,2"), parse_grid("a=3")]), "given more than once"),
    (dict(random=[parse_random("M=normal:2:0.1")]), "needs --samples"),
    (dict(), "nothing to sweep"),
    (dict(grid=[parse_grid("a=1")], samples=0), "--samples must be >= 1"),
])
def test_bad_point_tables(kwargs, message):
    with pytest.raises(SweepSpecError, match=message):
        point_table(**kwargs)


def _variables():
    def v(name, type_="Real", causality="parameter", unit=None, initial="exact", items=None):
        return Variable(name, type_, causality, "fixed", initial, unit, 0.0, 0, items or {})
    return {"beta": v("beta", causality="output", unit="rad"), "g": v("g"), "M": v("M", unit="kg"),
            "solver": v("solver", "Enumeration", items={"euler": 1, "rk4": 2}),
            "z": v("z", causality="output", initial="calculated")}


def test_resolver_degrees_presets_enumerations():
    r = Resolver(_variables())
    assert r.resolve("beta_deg", 90.0, "x") == ("beta", math.pi / 2)
    assert r.resolve("g", "moon", "x") == ("g", 1.625)
    assert r.resolve("solver", "rk4", "x") == ("solver", 2)
    assert r.resolve("solver", 1.0, "x") == ("solver", 1)


@pytest.mark.parametrize("name, value, message", [
    ("foo", 1.0, "unknown variable 'foo'; settable: M, beta, g, solver"),
    ("M_deg", 1.0, "unknown variable 'M_deg'"),  # only angles have a _deg form
    ("z", 1.0, "calculated output and cannot be set"),
    ("g", "jupiter", "valid: earth, mars, moon or a number"),
    ("solver", "rk5", "valid: euler, rk4"),
    ("solver", 7.0, "not an item"),
    ("solver", 1.5, "not an integer"),
    # an fmi2Integer is 32 bits: refused here, not wrapped by ctypes to -1294967296 so that every
    # point fails with the FMU's "max_internal_steps = -1294967296 must be ..."
    ("solver", 3e9, r"value 3000000000.0 for 'solver' is out of range \[-2147483648, 2147483647\] \(Enumeration\)"),
])
def test_resolver_errors(name, value, message):
    with pytest.raises(SweepSpecError, match=message):
        Resolver(_variables()).resolve(name, value, "--grid")


@pytest.mark.parametrize("value", [1e10, 2**31, -3e9])
def test_an_integer_outside_its_32_bits_names_the_declared_range(earth_fmu, value):
    """max_internal_steps (an fmi2Integer, min 1, max 2147483647 in modelDescription.xml) beyond
    32 bits: out of range, naming the range the FMU declares, as gyrowheel simulate --set does."""
    from fmpy import read_model_description

    from gyrowheel.studies.target import _read_variables
    variables = _read_variables(read_model_description(str(earth_fmu)))
    assert (variables["max_internal_steps"].min, variables["max_internal_steps"].max) == ("1", "2147483647")
    with pytest.raises(SweepSpecError) as exc:
        Resolver(variables).resolve("max_internal_steps", value, "--grid")
    assert str(exc.value) == (f"--grid: value {float(value)!r} for 'max_internal_steps' is out of range "
                              "[1, 2147483647] (Integer)")
    assert Resolver(variables).resolve("max_internal_steps", 2**31 - 1, "--grid") == ("max_internal_steps", 2**31 - 1)


def test_communication_grid_lands_on_stop_time():
    assert Settings(stop_time=1.0, output_interval=0.3).grid() == (4, 0.3)
    assert Settings(stop_time=1.0, output_interval=0.25).grid() == (4, 0.25)
    assert Settings(stop_time=2.0, output_interval=0.1, start_time=1.0).grid() == (10, 0.1)


def test_auto_batch_size():
    assert auto_batch_size(10_000, 2) == MAX_BATCH
    assert auto_batch_size(100, 2) == 13
    assert auto_batch_size(3, 8) == 1


def test_huge_grids_refused_before_building_them():
    grid = [parse_grid("M=1:2:100000"), parse_grid("R=0.1:0.2:100000")]
    with pytest.raises(SweepSpecError, match="10000000000 points"):
        point_table(grid)
