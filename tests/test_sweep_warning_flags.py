"""The sweep's `event` metric and final: of a Boolean output report every Boolean output true at
the end of a run, warning events (the run goes on) as well as terminating ones (docs/sweeps.md).

The unit: examples/scenes/paper_earth.toml with the slip check set to warn. The friction needed,
friction_use = |F_t| / F_n, peaks at 0.4540912 once per precession period (0.914 s, 22 times in
20 s); the slip warning fires where it exceeds mu. Warning events leave the trajectory as it is,
so the reference is the unit's own Real output friction_use: a point whose mu lies below
friction_use at a communication point must come out slipping, one whose mu lies above its peak
(sampled every 1e-5 s) must not. The plain loop (one FMU run per point) also locates the short
exceedance mu = 0.4540912 gives (5e-5 s a period), as gyrowheel.simulate does (22 slip events).
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import gyrowheel
from gyrowheel.studies import SweepSpecError, sweep

MU = [0.45, 0.454, 0.45409, 0.4540912, 0.4540913, 0.5]
METRICS = ["event", "survived", "final:slipping", "final:fallen"]


@pytest.fixture(scope="module")
def slipwarn_fmu(tmp_path_factory) -> Path:
    scene = Path(__file__).parents[1] / "examples" / "scenes" / "paper_earth.toml"
    root = tmp_path_factory.mktemp("slipwarn")
    text = scene.read_text() + '\n[effects.contact_forces]\non_slip = "warn"\n'
    (root / "slipwarn.toml").write_text(text.replace('name = "paper_earth"', 'name = "slipwarn"'))
    return gyrowheel.build(root / "slipwarn.toml", root / "slipwarn.fmu", taylor=True).fmu


def _friction_use(fmu, interval: float, stop_time: float = 20.0) -> np.ndarray:
    """friction_use over a run whose slip check never fires (mu = 0.8): the trajectory every mu has."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = gyrowheel.simulate(fmu, stop_time=stop_time, output_interval=interval,
                               start_values={"mu": 0.8, "solver": "taylor"})
    return r["friction_use"]


def test_a_warning_flag_is_in_the_event_metric_of_both_paths(slipwarn_fmu):
    """The user's sweep, through the ensemble (solver taylor) and the plain loop."""
    sampled = float(np.max(_friction_use(slipwarn_fmu, 0.01)))  # at the sweep's communication points
    peak = float(np.max(_friction_use(slipwarn_fmu, 1e-5, stop_time=0.47)))  # the first peak, t = 0.4569 s
    assert 0.45409 < sampled < 0.4540912 < peak < 0.4540913
    tables = {ens: sweep(slipwarn_fmu, grid={"mu": MU}, fixed={"solver": "taylor"}, metrics=METRICS,
                         workers=0, ensemble=ens) for ens in (True, False)}
    for ens, table in tables.items():
        assert (table["status"] == "ok").all() and table["survived"].all()
        assert not table["final_fallen"].any()
        for _, row in table.iterrows():
            assert row["event"] in ("slipping", ""), row
            assert row["final_slipping"] == (row["event"] == "slipping")
            if row["mu"] < sampled:  # above mu at a communication point, a step end of either path
                assert row["event"] == "slipping", (ens, row)
            if row["mu"] > peak:
                assert row["event"] == "", (ens, row)
    plain = tables[False]
    assert list(plain["event"]) == ["slipping"] * 4 + [""] * 2  # mu = 0.4540912: 5e-5 s above mu, found
    # the ensemble looks at its step ends only (docs/sweeps.md): it may miss that exceedance, and
    # agrees with the plain loop everywhere else
    ens = tables[True]
    seen = ens["mu"] != 0.4540912
    assert list(ens["event"][seen]) == list(plain["event"][seen])


def test_the_plain_loop_agrees_with_a_single_run(slipwarn_fmu):
    """mu = 0.4540912: gyrowheel.simulate ends with slipping true after 22 slip events; the
    sweep's row says the same."""
    events = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = gyrowheel.simulate(slipwarn_fmu, start_values={"mu": 0.4540912, "solver": "taylor"}, events=events)
    assert bool(r["slipping"][-1]) and len(events) == 22
    row = sweep(slipwarn_fmu, grid={"mu": [0.4540912]}, fixed={"solver": "taylor"}, metrics=METRICS,
                workers=0, ensemble=False).iloc[0]
    assert row["event"] == "slipping" and bool(row["final_slipping"])


def test_a_boolean_output_is_read_at_the_end_only(slipwarn_fmu):
    with pytest.raises(SweepSpecError, match=r"'slipping' is a Boolean output.*final:slipping"):
        sweep(slipwarn_fmu, grid={"mu": [0.5]}, metrics=["max:slipping"], workers=0)
    with pytest.raises(SweepSpecError, match=r"no Real output 'nope'.*Boolean outputs \(final: only\): "
                                             r"fallen, lifted_off, slipping"):
        sweep(slipwarn_fmu, grid={"mu": [0.5]}, metrics=["final:nope"], workers=0)


def test_the_cli_table_holds_the_warning(slipwarn_fmu, tmp_path):
    """The user's command line: the event column names the warning, final:slipping is a bool column."""
    from gyrowheel.cli import main
    from gyrowheel.studies import read_table
    out = tmp_path / "s.csv"
    assert main(["sweep", str(slipwarn_fmu), "--grid", "mu=0.45,0.454,0.45409,0.4540912", "--solver", "taylor",
                 "--metrics", "event,survived,final:slipping", "--no-ensemble", "--workers", "0",
                 "-o", str(out)]) == 0
    table = read_table(out)
    assert list(table["event"]) == ["slipping"] * 4
    assert list(table["final_slipping"]) == [True] * 4


def test_a_run_that_ends_at_lift_off_keeps_its_earlier_warning(slipwarn_fmu):
    """gamma_dot = 0: the wheel falls over; the friction it needs passes mu = 0.3 on the way and
    F_n reaches 0 (lift-off, which terminates) at 0.371 s. Both paths give both flags, in the
    order of the unit's Boolean outputs, as the single run's final values."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = gyrowheel.simulate(slipwarn_fmu, start_values={"mu": 0.3, "gamma_dot": 0.0, "solver": "taylor"})
    assert r["time"][-1] == pytest.approx(0.3714, abs=1e-4)
    assert [bool(r[name][-1]) for name in ("fallen", "lifted_off", "slipping")] == [False, True, True]
    for ens in (True, False):
        row = sweep(slipwarn_fmu, points=[{"mu": 0.3, "gamma_dot": 0.0}], fixed={"solver": "taylor"},
                    metrics=METRICS + ["end_time"], workers=0, ensemble=ens).iloc[0]
        assert row["event"] == "lifted_off,slipping" and not row["survived"], ens
        assert row["end_time"] == pytest.approx(r["time"][-1], abs=1e-9)
