"""What `gyrowheel simulate` and the scene reader tell a user, checked against what is true:

- the events summary counts each event and gives its first and last time; for the upright drop
  of examples/scenes/drop_bounce.toml (h = 0.1 m, e = 0.5) the touchdowns are at
  t_1 = sqrt(2 h / g) and t_(k+1) = t_k + 2 e^k g t_1 / g, so the 11th at t_1 (3 - 2 e^10);
- the flag contact_switched says what sets it (every firing of contact_slip, a re-pointed slip
  direction too), and a run where it fires while the wheel keeps sliding agrees;
- the Painleve warning says D / W_nn <= the margin (a switch may land below it);
- drop_bounce's comment: the upright rest is unstable, the lean's offset from vertical grows as
  e^(lambda t) with lambda = sqrt(g / (R (1 + k_diam))) (the inverted pendulum about the rim
  point: (I_diam + M R^2) beta'' = M g R beta, I_diam = k_diam M R^2) until the wheel falls;
- a string for a numeric setting without presets is refused as "must be a number";
- a refused combination names both values and where each came from;
- every option of every subcommand has a help line;
- the docs list every start value of the measured runs they quote.
"""
from __future__ import annotations

import argparse
import math
import re
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT, SCENES
from gyrowheel.cli import PAINLEVE_STOP, events_summary, make_parser
from gyrowheel.fmu_build import parse_scene
from gyrowheel.fmu_build.scene import SceneError

G_EARTH = 9.81  # model/effects/gravity.py, the preset "earth" of drop_bounce
R, K_DIAM = 0.17, 0.25  # examples/scenes/drop_bounce.toml
H0, E = 0.1, 0.5


@pytest.fixture(scope="module")
def drop(example_build):
    return str(example_build("drop_bounce").fmu)


def simulate(fmu, tmp_path, *args):
    return subprocess.run([sys.executable, "-m", "gyrowheel", "simulate", fmu, "-o", str(tmp_path / "r.csv"),
                           *map(str, args)], capture_output=True, text=True)


def test_events_summary_counts_the_bounces_at_their_analytic_times(drop, tmp_path):
    r = simulate(drop, tmp_path)
    assert r.returncode == 0, r.stderr
    m = re.search(r"contact_flight: (\d+) times, t = (\S+) \.\. (\S+) s", r.stdout)
    assert m, r.stdout
    t1 = math.sqrt(2 * H0 / G_EARTH)
    assert int(m.group(1)) == 11
    assert float(m.group(2)) == pytest.approx(t1, abs=1e-6)
    assert float(m.group(3)) == pytest.approx(t1 * (3 - 2 * E ** 10), abs=1e-6)


def test_events_summary_wording():
    assert events_summary([]) == ""
    assert events_summary([("impact", 0.5), ("fall", 2.0), ("impact", 1.25), ("impact", 1.5)]) == (
        " (events: impact: 3 times, t = 0.5 .. 1.5 s; fall at t = 2 s)")


@pytest.fixture(scope="module")
def warn_slip(tmp_path_factory) -> str:
    """paper_earth with the slip check set to warn at mu = 0.143: at gamma_dot = 15 the friction
    needed exceeds mu once every precession cycle, about 0.33 s."""
    root = tmp_path_factory.mktemp("warn_slip")
    text = (SCENES / "paper_earth.toml").read_text().replace('name = "paper_earth"', 'name = "warn_slip"').replace(
        "[initial]", '[effects.contact_forces]\nmu = 0.143\non_slip = "warn"\n\n[initial]')
    (root / "warn_slip.toml").write_text(text)
    built = subprocess.run([sys.executable, "-m", "gyrowheel", "build", str(root / "warn_slip.toml"), "-o",
                            str(root / "warn_slip.fmu")], capture_output=True, text=True)
    assert built.returncode == 0, built.stderr
    return str(root / "warn_slip.fmu")


def test_a_warning_event_is_one_line_with_its_count(warn_slip, tmp_path):
    """on_slip = "warn": stderr has one line for the slip check, with its count and first and
    last time, not one line per firing.  A slip that holds from the start (mu = 0.01) is a
    warning too, its own line, without a doubled "warning:"."""
    r = simulate(warn_slip, tmp_path, "--set", "gamma_dot=15")
    assert r.returncode == 0, r.stderr
    lines = r.stderr.splitlines()
    m = re.fullmatch(r"gyrowheel: warning: event slip: (\d+) times, t = (\S+) \.\. (\S+) s", lines[0])
    assert len(lines) == 1 and m, r.stderr
    n, first, last = int(m.group(1)), float(m.group(2)), float(m.group(3))
    assert n > 20 and first == pytest.approx(0.101206, abs=1e-6) and last > 19.0
    assert f"slip: {n} times, t = {first:.6g} .. {last:.6g} s" in r.stdout  # the summary: the same words
    r = simulate(warn_slip, tmp_path, "--set", "gamma_dot=15", "--set", "mu=0.01", "--stop-time", 1)
    assert r.stderr.splitlines() == ["gyrowheel: warning: event slip holds already at the start t=0"], r.stderr
    assert "(events: slip at t = 0 s)" in r.stdout, r.stdout  # listed among the events too


def test_a_warning_event_warns_at_each_call_of_simulate(warn_slip):
    """gyrowheel.simulate(..., events=[]): one FmuWarning per event and call, attributed to the
    caller's line (not to gyrowheel's own), so that Python's default filter shows a second call's
    warning too."""
    import warnings

    import gyrowheel
    from gyrowheel.simulation import FmuWarning
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        gyrowheel.simulate(warn_slip, start_values={"gamma_dot": 15.0}, events=[])
        gyrowheel.simulate(warn_slip, start_values={"gamma_dot": 15.0}, events=[])
    slips = [w for w in caught if issubclass(w.category, FmuWarning)]
    assert len(slips) == 2 and all(w.filename == __file__ for w in slips), [(w.filename, w.lineno) for w in slips]
    assert str(slips[0].message).startswith("event slip: ") and slips[0].lineno != slips[1].lineno


# the reported run: thrown leaning and spinning; it lands, slides, and contact_slip fires while it
# keeps sliding (the slip direction re-pointed), never rolling
THROWN = ("--stop-time", 3, "--set", "height=0.5", "--set", "vz=1", "--set", "beta=1.2", "--set", "gamma_dot=30",
          "--set", "alpha_dot=2", "--set", "beta_dot=1", "--set", "mu=0.3", "--set", "mu_k=0.3")


def test_contact_switched_is_described_as_every_firing_of_contact_slip(drop, tmp_path):
    import gyrowheel
    r = simulate(drop, tmp_path, *THROWN)
    assert r.returncode == 0, r.stderr
    out = np.genfromtxt(tmp_path / "r.csv", delimiter=",", names=True)
    assert out["contact_switched"][-1] and not (out["contact_mode"] == 0).any()  # fired, never rolled
    summary = r.stdout[r.stdout.index("(events: "):]
    assert "contact_slip at t = " in summary and "contact_switched" not in summary
    described = gyrowheel.info(drop).variable("contact_switched").description
    assert "contact_slip has fired" in described and "re-pointed" in described


def test_painleve_warning_says_at_or_below_the_margin():
    from gyrowheel.model.painleve import PAINLEVE_MARGIN
    assert f"D / W_nn <= {PAINLEVE_MARGIN:g}," in PAINLEVE_STOP


def test_upright_rest_is_unstable_at_the_inverted_pendulum_rate(drop, tmp_path):
    r = simulate(drop, tmp_path, "--stop-time", 8, "--output-interval", 0.01)
    assert r.returncode == 0, r.stderr
    out = np.genfromtxt(tmp_path / "r.csv", delimiter=",", names=True)
    offset = np.abs(out["beta"] - math.pi / 2)
    grow = (offset > 1e-10) & (offset < 1e-4) & (out["contact_mode"] == 0)
    rate = np.polyfit(out["time"][grow], np.log(offset[grow]), 1)[0]
    assert grow.sum() > 50
    assert rate == pytest.approx(math.sqrt(G_EARTH / (R * (1 + K_DIAM))), rel=0.01)
    assert out["fallen"][-1] and 5.8 < out["time"][-1] < 6.0
    comment = (SCENES / "drop_bounce.toml").read_text()
    assert "unstable equilibrium" in comment and "about 5.9 s" in comment


SLIDE = '[effects.gravity]\n[effects.contact_forces]\non_slip = "slide"\non_lift_off = "fly"\n'


@pytest.mark.parametrize("key", ["restitution", "mu", "mu_k"])
def test_a_string_for_a_number_without_presets_asks_for_a_number(key):
    with pytest.raises(SceneError) as err:
        parse_scene(f'[model]\nname = "s"\n{SLIDE}{key} = "0.5"\n', "s.toml")
    assert f"[effects.contact_forces] {key}: must be a number (no presets), got str '0.5'" in str(err.value)
    assert "preset '0.5'" not in str(err.value)


def test_a_string_for_a_number_with_presets_lists_them():
    with pytest.raises(SceneError, match=r"g: unknown preset '0.5'; valid: earth, mars, moon or a number"):
        parse_scene('[model]\nname = "s"\n[effects.gravity]\ng = "0.5"\n', "s.toml")


def test_a_refused_combination_names_both_values_and_their_sources(drop, tmp_path):
    r = simulate(drop, tmp_path, "--set", "mu=0")
    assert r.returncode == 2
    assert "mu_k (0.3, the FMU's start value) must be <= mu (0, given)" in r.stderr
    r = simulate(drop, tmp_path, "--set", "mu_k=0.5")
    assert "mu_k (0.5, given) must be <= mu (0.3, the FMU's start value)" in r.stderr
    with pytest.raises(SceneError, match=r"got mu_k = 0.9 > mu = 0.8 \(the default\)"):
        parse_scene(f'[model]\nname = "s"\n{SLIDE}mu_k = 0.9\n', "s.toml")
    with pytest.raises(SceneError, match=r"got mu_k = 0.5 > mu = 0.4 \(the scene's\)"):
        parse_scene(f'[model]\nname = "s"\n{SLIDE}mu_k = 0.5\nmu = 0.4\n', "s.toml")
    with pytest.raises(SceneError, match=r"got 0.6 with k_diam 0.25 \(the default\)"):
        parse_scene('[model]\nname = "s"\n[wheel]\nk_axial = 0.6\n[effects.gravity]\n', "s.toml")


def test_every_option_of_every_subcommand_has_help():
    missing = []

    def walk(parser, path):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, f"{path} {name}")
            elif action.help is None:
                missing.append(f"{path} {action.option_strings or action.dest}")
    walk(make_parser(), "gyrowheel")
    assert missing == []
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "simulate", "--help"], capture_output=True, text=True)
    assert "end time [s]" in r.stdout and "time between result rows" in r.stdout


def test_docs_quote_every_start_value_of_the_measured_runs():
    from test_painleve import THROWN
    text = (ROOT / "docs" / "effects.md").read_text()
    stop = text[text.index("**The Painleve stop.**"):]
    stop = stop[:stop.index("stops at t = 0.19795 s")]
    command = re.search(r"`gyrowheel simulate drop_bounce.fmu([^`]*)`", stop).group(1)
    sets = dict(re.findall(r"--set (\w+)=(\S+)", " ".join(command.split())))
    assert {k: float(v) for k, v in sets.items()} == {**{k: float(v) for k, v in THROWN.items()}, "mu_k": 1.15}
    assert "--stop-time 1.5" in " ".join(command.split())
    row = next(line for line in text.splitlines() if "(0.617722, 0.450674)" in line)
    for start in ("alpha = 0.7", "beta = pi/2", "gamma_dot 10", "height 0.3", "vz 1", "mu = 0.3", "g = 9.81",
                  "rel_tol 1e-12", "abs_tol 1e-14", "k_diam = 0.25", "k_axial = 0.4"):
        assert start in row, start
    # the drag and tumbling rows (tests/test_flight_effects.py): every value the tests start from
    for case, starts in (("air drag, linear", ("c_lin = 0.8", "cm_spin = 0.5", "rho_air = 1.225", "2 m/s from 1 m",
                                               "beta = pi/2", "gamma_dot 40", "0.4 s")),
                         ("air drag, quadratic", ("cd_area = 0.3", "rho_air = 1.225", "3 m/s from 1.5 m",
                                                  "beta = pi/2", "alpha = 0.4", "gamma_dot 20", "0.5 s")),
                         ("slope th = 0.15", ("psi = 1.0", "rho_air = 1.225", "cd_area = 0.3", "c_lin = 0.2",
                                              "cm_spin = 0.5", "height 0.1", "vz 0.5", "beta 1.2", "gamma_dot 25",
                                              "alpha_dot 2", "beta_dot 1", "0.8 s"))):
        row = next(line for line in text.splitlines() if line.startswith(f"| {case}"))
        for start in starts:
            assert start in row, (case, start)
