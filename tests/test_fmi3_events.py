"""gyrowheel simulate reports the same events, names and times, from an FMU's FMI 2.0 and FMI 3.0
builds (the same core behind either layer, docs/fmi.md), through the CLI and the Python API.

FMI 3.0's layer puts the name of the call before each message of the core (`fmi3DoStep: event
fall at t=...`), FMI 2.0's does not (`event fall at t=...`); gyrowheel.simulation reads both.
The times are checked against what the code did not produce:

- drop_bounce (examples/scenes/drop_bounce.toml: dropped upright from h = 0.1 m, restitution
  e = 0.5, g = 9.81 m/s2): contact_flight fires at each touchdown, the first at
  t_1 = sqrt(2 h / g), then after flights of 2 e^k t_1 each (the rebound speed e^k sqrt(2 g h)),
  so the k-th at t_1 (3 - 2 e^(k-1)); 11 firings in the scene's 1 s;
- paper_earth started at beta = 0.00100001 rad, at rest in beta (beta_dot = alpha_dot = 0,
  gamma_dot = 6 rad/s): it falls when beta reaches beta_min = 0.001 rad, after
  sqrt(2 (beta_0 - beta_min) / |beta''|) with beta'' from the independent Newton-Euler model
  (tests/reference/newton_euler.py); the next term of the series changes it by about 1e-8
  relative;
- lunar_rover (on_slip = "warn") at mu = 0.1, gamma_dot = 12 rad/s: its slip warnings, the same
  FmuWarnings from both builds, and with mu = 0.01 the slip that holds at the start.
"""
from __future__ import annotations

import math
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

import gyrowheel
from conftest import PAPER
from gyrowheel.simulation import FmuWarning, core_message

H0, E, G_EARTH = 0.1, 0.5, 9.81  # examples/scenes/drop_bounce.toml
BETA_0, BETA_MIN, GAMMA_DOT = 0.00100001, 0.001, 6.0  # the falling paper_earth run; beta_min: the default


def touchdowns() -> list[float]:
    t1 = math.sqrt(2 * H0 / G_EARTH)
    return [t1 * (3 - 2 * E ** (k - 1)) for k in range(1, 12)]


@pytest.fixture(scope="module")
def fall_time() -> float:
    from reference import newton_euler as ne
    state = [0.0, 0.0, 0.0, BETA_0, 0.0, 0.0, 0.0, GAMMA_DOT]
    beta_ddot = ne.accelerations(state, [PAPER[k] for k in ne.PARAM_NAMES])[1]
    return math.sqrt(2 * (BETA_0 - BETA_MIN) / abs(beta_ddot))


# (scene, --set values, the events' names)
RUNS = {"drop_bounce": ({}, ["contact_flight"] * 11), "paper_earth": ({"beta": BETA_0}, ["fall"])}


@pytest.fixture(scope="module")
def builds(example_build, fmi3_build):
    """{(scene, 2 or 3): the FMU}: the suite's shared builds."""
    return {(scene, fmi): str((example_build(scene) if fmi == 2 else fmi3_build(scene)).fmu)
            for scene in ("drop_bounce", "paper_earth", "lunar_rover") for fmi in (2, 3)}


@pytest.mark.parametrize("scene", list(RUNS))
def test_the_api_reports_the_same_events_from_fmi2_and_fmi3(builds, scene, fall_time):
    values, names = RUNS[scene]
    expected = touchdowns() if scene == "drop_bounce" else [fall_time]
    reported = {}
    for fmi in (2, 3):
        events: list = []
        gyrowheel.simulate(builds[scene, fmi], start_values=values, events=events)
        reported[fmi] = events
        assert [name for name, _ in events] == names, (fmi, events)
        assert [t for _, t in events] == pytest.approx(expected, rel=1e-6, abs=1e-9), (fmi, events)
    assert [n for n, _ in reported[3]] == [n for n, _ in reported[2]]
    assert [t for _, t in reported[3]] == pytest.approx([t for _, t in reported[2]], rel=1e-12, abs=0)


@pytest.mark.parametrize("scene", ["drop_bounce", "paper_earth", "lunar_rover"])
def test_the_api_records_the_same_rows_from_fmi2_and_fmi3(builds, scene):
    """The same table from both builds: the rows at the communication points (and a fall's at its
    located time), equal bit for bit.  fmpy also records a row where an FMI 3.0 FMU returns early
    at an event inside a step; drop_bounce's 11 touchdowns gave 1012 rows against 1001."""
    values = RUNS.get(scene, ({"mu": 0.1, "gamma_dot": 12.0}, None))[0]
    r2, r3 = (gyrowheel.simulate(builds[scene, fmi], start_values=values) for fmi in (2, 3))
    assert r3.dtype.names == r2.dtype.names and len(r3) == len(r2) >= 2
    for name in r2.dtype.names:  # exact equality (an Enumeration is int32 in one, int64 in the other)
        np.testing.assert_array_equal(r3[name], r2[name], err_msg=name)


@pytest.mark.parametrize("scene, summary", [
    ("drop_bounce", "(events: contact_flight: 11 times, t = 0.142784 .. 0.428074 s)"),
    ("paper_earth", "(events: fall at t = 2.08142e-05 s)"),
])
def test_the_cli_prints_the_same_events_from_fmi2_and_fmi3(builds, scene, summary, tmp_path, fall_time):
    """The reported runs: `gyrowheel simulate earth3.fmu --set beta=0.00100001` and drop_bounce's
    FMI 3.0 FMU print the events line of their FMI 2.0 twins, whose times are the analytic ones."""
    t = touchdowns()
    assert summary.endswith(f"t = {t[0]:.6g} .. {t[-1]:.6g} s)" if scene == "drop_bounce" else
                            f"t = {fall_time:.6g} s)")
    sets = [f"{k}={v!r}" for k, v in RUNS[scene][0].items()]
    lines = {}
    for fmi in (2, 3):
        r = subprocess.run([sys.executable, "-m", "gyrowheel", "simulate", builds[scene, fmi],
                            *[a for s in sets for a in ("--set", s)], "-o", str(tmp_path / f"{fmi}.csv")],
                           capture_output=True, text=True)
        assert r.returncode == 0 and r.stderr == "", r.stderr
        assert r.stdout.rstrip().endswith(summary), (fmi, r.stdout)
        lines[fmi] = r.stdout
    assert lines[3][lines[3].index("(events"):] == lines[2][lines[2].index("(events"):]


@pytest.mark.parametrize("values", [{"mu": 0.1, "gamma_dot": 12.0}, {"mu": 0.01}])
def test_warning_events_are_the_same_from_fmi2_and_fmi3(builds, values):
    """lunar_rover's slip check warns: the same FmuWarnings (`event slip: 2 times, ...`, `event
    slip holds already at the start t=0`, not prefixed with the FMI 3.0 call) and events."""
    seen = {}
    for fmi in (2, 3):
        events: list = []
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            gyrowheel.simulate(builds["lunar_rover", fmi], stop_time=20.0, start_values=values, events=events)
        seen[fmi] = ([str(w.message) for w in caught if issubclass(w.category, FmuWarning)], events)
    texts, events = seen[2]
    assert seen[3] == seen[2]
    assert events[0][0] == "slip"
    if values["mu"] == 0.01:
        assert texts == ["event slip holds already at the start t=0"] and events[0] == ("slip", 0.0)
    else:
        assert len(texts) == 1 and re.fullmatch(r"event slip: 2 times, t = \S+ \.\. \S+ s", texts[0]), texts


def test_a_warning_event_holding_at_the_start_and_firing_later_is_one_warning(builds):
    """lunar_rover at mu = 0.05 from 60 deg: the slip holds at the start and fires again later.
    One warning counts both firings, in the words of the CLI's events summary (it was two
    warnings, 'holds already at the start t=0' and 'event slip at t = ...')."""
    from gyrowheel.cli import events_summary
    for fmi in (2, 3):
        events: list = []
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            gyrowheel.simulate(builds["lunar_rover", fmi], start_values={"mu": 0.05, "beta_deg": 60.0}, events=events)
        texts = [str(w.message) for w in caught if issubclass(w.category, FmuWarning)]
        slips = [t for name, t in events if name == "slip"]
        assert len(slips) >= 2 and slips[0] == 0.0, (fmi, events)
        phrase = f"slip: {len(slips)} times, t = 0 .. {slips[-1]:.6g} s"
        assert texts == [f"event {phrase}"], (fmi, texts)
        assert phrase in events_summary(events)


@pytest.mark.parametrize("logged, read", [
    ("fmi3DoStep: event fall at t=0.5: simulation terminated at t=0.5", "event fall at t=0.5: simulation terminated "
                                                                        "at t=0.5"),
    ("fmi3DoStep: warning: event slip at t=1.25", "warning: event slip at t=1.25"),
    ("fmi3ExitInitializationMode: warning: event slip holds already at the start t=0",
     "warning: event slip holds already at the start t=0"),
    ("event fall at t=0.5: simulation terminated at t=0.5", "event fall at t=0.5: simulation terminated at t=0.5"),
    # not an event: the call stays (the errors before the run are told by it)
    ("fmi3SetFloat64: M (mass) must be > 0", "fmi3SetFloat64: M (mass) must be > 0"),
    ("fmi3DoStep: fall at t=0.5: the simulation terminated inside the step to t=1",
     "fmi3DoStep: fall at t=0.5: the simulation terminated inside the step to t=1"),
])
def test_an_events_message_is_read_without_the_fmi3_call(logged, read):
    assert core_message(logged) == read
