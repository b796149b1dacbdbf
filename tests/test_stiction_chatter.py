"""A stiction law whose mode switches faster than an explicit solver can follow: the error names
the event, says what it means and advises what runs (docs/effects.md, "Stiction").

The unit: examples/scenes/paper_earth.toml with [effects.spin_friction] (d_pivot = 0.01), built
without the Taylor kernel (solver auto is dop853). At d_pivot = 1e6 N.m.s the viscous pivot time
scale, inertia / damping, is about 1e-8 s (I_diam = M R^2 / 4 = 0.0145 kg m^2): dop853's steps
overshoot w_k = 0, the law sticks and releases again within each step, and the communication
step ending at 0.51 s exceeds the runtime's limit of events. References the code did not
produce: with that damping the pivot rate w_k = alpha_dot + gamma_dot cos(beta), 1.04 rad/s at
the start, must stop within microseconds (the viscous time scale) and stay stopped, which the
implicit solver the message advises gives; the smaller damping it advises runs with dop853.
"""
from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import gyrowheel
from gyrowheel.simulation import SimulationError

M, R, K_DIAM = 2.0, 0.17, 0.25


@pytest.fixture(scope="module")
def spin_fmu(tmp_path_factory) -> Path:
    scene = Path(__file__).parents[1] / "examples" / "scenes" / "paper_earth.toml"
    root = tmp_path_factory.mktemp("spin")
    text = scene.read_text().replace('name = "paper_earth"', 'name = "spin"')
    (root / "spin.toml").write_text(text + "\n[effects.spin_friction]\nd_pivot = 0.01\n")
    return gyrowheel.build(root / "spin.toml", root / "spin.fmu", taylor=False).fmu


def _simulate(fmu, events=None, **start):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gyrowheel.simulate(fmu, start_values=start, events=events)


def _simulate_events(fmu, **start) -> list:
    events: list = []
    assert _simulate(fmu, events, **start)["time"][-1] == 20.0
    return events


def test_the_message_names_the_event_its_meaning_and_the_remedy(spin_fmu, capsys):
    """The user's command: gyrowheel simulate spin.fmu --set d_pivot=1e6 (exit status 1)."""
    from gyrowheel.cli import main
    assert main(["simulate", str(spin_fmu), "--set", "d_pivot=1e6", "-o", str(spin_fmu.with_suffix(".csv"))]) == 1
    err = capsys.readouterr().err
    assert "more than 1000 events in one communication step, from t=0.5 to t=0.5046" in err
    assert "pivot_stiction kept firing" in err
    assert "faster than solver dop853 can follow" in err
    assert "a stiction law's viscous one, inertia / damping" in err
    assert "try solver rosenbrock" in err and "a smaller damping coefficient" in err


def test_the_advised_solver_runs_it_and_the_pivot_stops_at_once(spin_fmu):
    """solver rosenbrock: the 20 s, 45 pivot_stiction events (as with the scene's d_pivot = 0.01);
    the pivot stops on the viscous time scale and stays stopped."""
    viscous = K_DIAM * M * R**2 / 1e6  # s, inertia / damping
    assert viscous == pytest.approx(1.4e-8, rel=0.05)
    events: list = []
    r = _simulate(spin_fmu, events, d_pivot=1e6, solver="rosenbrock")
    assert r["time"][-1] == 20.0
    names = {name for name, _ in events}
    assert names == {"pivot_stiction"} and 20 <= len(events) <= 100
    w_k = r["alpha_dot"] + r["gamma_dot"] * np.cos(r["beta"])
    assert abs(w_k[0]) == pytest.approx(6.0 * math.cos(math.radians(80.0)), rel=1e-12)
    assert events[0][1] < 1000 * viscous  # stuck after microseconds
    assert np.max(np.abs(w_k[1:])) < 1e-6  # and the pivot rate stays 0 to the tolerance
    # the scene's own damping: about as many switches
    assert 20 <= len(_simulate_events(spin_fmu, d_pivot=0.01)) <= 100



def test_the_advised_smaller_damping_runs_with_dop853(spin_fmu):
    """d_pivot = 100 N.m.s (time scale 1.4e-4 s): dop853 runs the 20 s; 1e5 still fails the same way."""
    assert len(_simulate_events(spin_fmu, d_pivot=100.0)) <= 100
    with pytest.raises(SimulationError, match=r"pivot_stiction kept firing: .* solver dop853"):
        _simulate(spin_fmu, d_pivot=1e5)
