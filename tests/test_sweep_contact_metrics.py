"""Sweep metrics of a unit with contact modes (examples/scenes/drop_bounce.toml): energy_drift
measures the energy balance energy + dissipated_energy (docs/effects.md), which impacts conserve,
not T + V, which they lose; final:contact_mode gives the Enumeration's item name. References: the
conservation law, and fmpy's own simulation of the same FMU."""
from __future__ import annotations

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from gyrowheel.studies import sweep
from gyrowheel.studies.spec import SweepSpecError


@pytest.fixture(scope="module")
def drop_fmu(example_build):
    return example_build("drop_bounce").fmu


def test_energy_drift_is_the_balance_and_contact_mode_its_item(drop_fmu):
    """The user's sweep: restitution 0 .. 1, mu 0 and 0.3, mu_k 0. The impacts dissipate up to
    all of the fall's energy, yet energy + dissipated_energy is constant, so the drift is the
    integration error (< 1e-10) at every point; each point's final contact mode is the item
    fmpy's run ends in."""
    table = sweep(drop_fmu, grid={"restitution": "0:1:5", "mu": [0.0, 0.3]}, fixed={"mu_k": 0.0},
                  metrics=["energy_drift", "final:contact_mode", "final:energy"], workers=0)
    assert len(table) == 10 and (table["status"] == "ok").all()
    md = read_model_description(str(drop_fmu))
    items = {int(i.value): i.name for t in md.typeDefinitions for i in t.items if t.name == "ContactMode"}
    assert sorted(items.values()) == ["flight", "rolling", "sliding"]
    lost = []
    for _, row in table.iterrows():
        assert row["energy_drift"] < 1e-10, row
        ref = simulate_fmu(str(drop_fmu), stop_time=1.0, output_interval=0.001,
                           start_values={"restitution": row["restitution"], "mu": row["mu"], "mu_k": 0.0})
        assert row["final_contact_mode"] == items[int(ref["contact_mode"][-1])]
        balance = ref["energy"] + ref["dissipated_energy"]
        assert row["energy_drift"] == pytest.approx(np.max(np.abs(balance - balance[0])) / abs(balance[0]),
                                                    abs=1e-15)
        lost.append((ref["energy"][0] - ref["energy"][-1]) / ref["energy"][0])
    # what T + V alone would have called drift: the impacts' real loss, tens of per cent for e < 1
    assert max(lost) > 0.3
    assert set(table["final_contact_mode"]) <= {"rolling", "sliding", "flight"}


def test_contact_mode_is_read_at_the_end_only(drop_fmu):
    with pytest.raises(SweepSpecError, match=r"'contact_mode' is an Integer/Enumeration output.*final:contact_mode"):
        sweep(drop_fmu, grid={"restitution": [0.5]}, metrics=["max:contact_mode"], workers=0)
    with pytest.raises(SweepSpecError, match=r"no Real output 'nope'.*Integer/Enumeration outputs \(final: only\): "
                                             r"contact_mode"):
        sweep(drop_fmu, grid={"restitution": [0.5]}, metrics=["final:nope"], workers=0)


def test_the_cli_sweep_takes_final_contact_mode(drop_fmu, tmp_path, capsys):
    """The user's command line with --metrics energy_drift,final:contact_mode: the table holds
    the item names."""
    from gyrowheel.cli import main
    from gyrowheel.studies import read_table
    out = tmp_path / "s.csv"
    assert main(["sweep", str(drop_fmu), "--grid", "restitution=0:1:5", "--grid", "mu=0,0.3", "--set", "mu_k=0",
                 "--workers", "0", "--metrics", "energy_drift,final:contact_mode", "-o", str(out)]) == 0
    table = read_table(out)
    assert len(table) == 10 and (table["energy_drift"] < 1e-10).all()
    assert list(table["final_contact_mode"]) == ["sliding", "rolling"] * 4 + ["flight"] * 2
