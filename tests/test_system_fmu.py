"""Any small CasADi system becomes an FMU through the wheel's path (model/system.py)."""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from gyrowheel.fmu_build.builder import build_spec_fmu
from gyrowheel.model.system import System, SystemDescriptionError


def lag_system() -> System:
    s = System("lag", "first-order lag with a hidden integral")
    k = s.parameter("k", 2.0, "1/s", "rate", minimum=0.0)
    u = s.input("u", 0.0, "1", "target")
    x = s.state("x", 1.0, "1", "lagged value")
    z = s.state("z", 0.0, "1", "integral of x", output=False)
    s.der(x, k * (u - x))
    s.der(z, x)
    s.output("y2", 2 * x + u, "1", "2 x + u")
    s.event("low", x - 0.1, "warn", "is_low")
    return s


def test_general_system_fmu_runs_exactly(tmp_path):
    """x' = k (u - x): exp(-k t) from the FMU's own runtime; a warn event flags x <= 0.1."""
    fmu = build_spec_fmu(lag_system().spec(), tmp_path / "lag.fmu").fmu
    assert validate_fmu(str(fmu)) == []
    r = simulate_fmu(str(fmu), stop_time=2.0, output_interval=0.5)
    np.testing.assert_allclose(r["x"], np.exp(-2.0 * r["time"]), rtol=1e-7)
    np.testing.assert_allclose(r["y2"], 2 * np.exp(-2.0 * r["time"]), rtol=1e-7)
    assert list(r["is_low"]) == [False, False, False, True, True]  # x = 0.1 at t = 1.151


def test_controller_fmu_validates_with_fmpy_and_fmutool(controller_fmu):
    assert validate_fmu(str(controller_fmu)) == []
    fmutool = subprocess.run([str(Path(sys.executable).parent / "fmutool"), "-input",
                              str(controller_fmu), "-check"], capture_output=True, text=True)
    assert fmutool.returncode == 0, fmutool.stdout + fmutool.stderr
    out = fmutool.stdout + fmutool.stderr
    assert "seems to be compliant with FMI-2.0" in out and "No semantic error" in out, out


@pytest.mark.parametrize("build, message", [
    (lambda s: s.state("x", 0.0), "has no derivative"),
    (lambda s: s.output("y", __import__("casadi").SX.sym("q")), "not a declared"),
    (lambda s: s.parameter("2bad", 1.0), "not a valid identifier"),
    (lambda s: (s.input("a"), s.input("a")), "already used"),
    (lambda s: s.event("e", 1.0, "explode"), "action must be"),
    (lambda s: s.parameter("p", math.inf), "must be finite"),
])
def test_bad_system_descriptions_name_the_field(build, message):
    s = System("bad")
    with pytest.raises(SystemDescriptionError, match=message):
        build(s)
        s.spec()
