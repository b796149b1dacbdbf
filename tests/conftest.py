"""Shared fixtures: the paper model, built FMUs (once per session) and integration helpers."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import model
from fmu_build import build_fmu, load_scene

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "examples" / "scenes"
PAPER = dict(M=2.0, R=0.17, k_diam=0.25, k_axial=0.4, g=9.81)
STATES = ["x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot", "gamma_dot"]  # INTERFACE.md order


class CasadiWheel:
    """The project's CasADi model as numpy callables (parameters by name)."""

    def __init__(self, formulation: str = "reduced", **values):
        wheel = {k: v for k, v in values.items() if k in ("M", "R", "k_diam", "k_axial", "beta_min")}
        g = values.get("g", 9.81)
        self.spec = model.build_model(wheel=wheel, effects={"gravity": {"g": g}}, formulation=formulation)
        self.fns = self.spec.functions()
        self.p = np.array([q.start for q in self.spec.parameters], dtype=float)
        self.out_names = [q.name for q, _ in self.spec.outputs]

    def x0(self, **start) -> np.ndarray:
        s = np.array([start.get(q.name, q.start) for q in self.spec.starts], dtype=float)
        return np.array(self.fns["init"](s, self.p)).ravel()

    def rhs(self, t, x):
        return np.array(self.fns["ode"](t, x, [], self.p)).ravel()

    def out(self, x) -> dict[str, float]:
        y = np.array(self.fns["out"](0.0, x, [], self.p)).ravel()
        return dict(zip(self.out_names, y))

    def integrate(self, x0, t_end, rtol=1e-11, atol=1e-12, t_eval=None, beta_min=None):
        """scipy DOP853 on the CasADi model; with beta_min, the fall is a terminal event."""
        from scipy.integrate import solve_ivp
        events = None
        if beta_min is not None:
            def fall(t, x):
                return math.sin(x[3]) - math.sin(beta_min)
            fall.terminal, fall.direction = True, -1
            events = fall
        sol = solve_ivp(self.rhs, (0.0, t_end), x0, method="DOP853", rtol=rtol, atol=atol,
                        t_eval=t_eval, dense_output=False, events=events)
        assert sol.success, sol.message
        return sol

    def fall_time(self, beta_min, rtol, atol, t_end=20.0, **start) -> float:
        """Reference time of the fall from the start values, located by scipy's event finder."""
        return float(self.integrate(self.x0(**start), t_end, rtol, atol, beta_min=beta_min).t_events[0][0])


def steady_precession(beta: float, rho: float, M: float, R: float, k_diam: float, k_axial: float,
                      g: float, sign: float = -1.0) -> dict[str, float]:
    """Initial rates of steady precession (eq. 52 generalised, eq. 49 corrected)."""
    I_d, I_a = k_diam * M * R**2, k_axial * M * R**2
    alpha_dot = sign * math.sqrt(M * g * R**2 / math.tan(beta) / ((I_a + M * R**2) * rho + I_d * R * math.cos(beta)))
    gamma_dot = -(rho / R + math.cos(beta)) * alpha_dot
    return dict(beta=beta, alpha_dot=alpha_dot, gamma_dot=gamma_dot, beta_dot=0.0)


def critical_spin(M, R, k_diam, k_axial, g) -> float:
    """Spin rate above which straight upright rolling is stable."""
    I_d, I_a = k_diam * M * R**2, k_axial * M * R**2
    return math.sqrt(M * g * R * I_d / (I_a * (I_a + M * R**2)))


@pytest.fixture(autouse=True)
def _fmpy_logger_alive():
    """After every test, fmpy's process-global logger proxy points at a living callback: the
    process-lived dispatcher of tests/fmi_helpers.py (a test's own logger dies with it)."""
    yield
    from fmi_helpers import reproxy
    reproxy()


@pytest.fixture(scope="session")
def paper_model() -> CasadiWheel:
    return CasadiWheel(**PAPER)


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fmus")


@pytest.fixture(scope="session")
def earth_fmu(fmu_dir) -> Path:
    """The paper's earth scene, built once (sources kept under fmu_dir/earth_build)."""
    scene = load_scene(SCENES / "paper_earth.toml")
    return build_fmu(scene, fmu_dir / "paper_earth.fmu", build_dir=fmu_dir / "earth_build").fmu


@pytest.fixture(scope="session")
def earth_loop(fmu_dir):
    """The Gyrover closed loop on earth (wheel + controller FMUs, .ssp) on the earth's course, built once."""
    from controller.closed_loop import build_closed_loop
    from controller.mission import course
    return build_closed_loop(load_scene(SCENES / "gyrover_mission_earth.toml"), fmu_dir / "closed_loop",
                             course("earth"))


@pytest.fixture(scope="session")
def earth_design(earth_loop):
    return earth_loop.design


@pytest.fixture(scope="session")
def controller_fmu(earth_loop):
    return earth_loop.controller_fmu


# ---- `gyrowheel export-c` (test_export_c.py, test_export_c_review.py) ----------------------------

@pytest.fixture(scope="session")
def earth(tmp_path_factory) -> Path:
    """paper_earth exported through the command line (with its strict compile check)."""
    from export_c_helpers import gyrowheel

    out = tmp_path_factory.mktemp("export") / "paper_earth"
    r = gyrowheel("export-c", SCENES / "paper_earth.toml", "-o", out)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(f"wrote {out}/") and r.stderr == ""
    return out


@pytest.fixture(scope="session")
def earth_gcc(earth, tmp_path_factory) -> dict:
    """The export's library object and both examples, gcc -O2, strict; and what gcc printed."""
    from export_c_helpers import STRICT, cc

    out = tmp_path_factory.mktemp("earth_gcc")
    built = {"obj": out / "paper_earth.o", "example": out / "example", "realtime": out / "realtime"}
    diagnostics = cc("gcc", *STRICT, "-O2", "-c", earth / "paper_earth.c", "-o", built["obj"]).stderr
    for name in ("example", "realtime"):
        src = earth / "examples" / ("main.c" if name == "example" else "realtime.c")
        diagnostics += cc("gcc", *STRICT, "-O2", f"-I{earth}", src, built["obj"], "-lm", "-o", built[name]).stderr
    built["diagnostics"] = diagnostics
    return built
