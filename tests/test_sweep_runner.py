"""The sweep engine in one process (workers=0): metrics against references the engine did not
produce (fmpy's own simulation loop, scipy's fall time on the CasADi model, eq. 52 steady
precession), failing points as rows, points that set different variables, user functions,
derived inputs, the table on disk, the CLI. Sweeps refused before running: test_sweep_errors.py."""
from __future__ import annotations

import math
import shutil
import textwrap

import pandas as pd
import pytest
from fmpy import simulate_fmu

from gyrowheel.cli import main
from gyrowheel.studies import read_table, sweep
from gyrowheel.studies.steady import precession_rates
from gyrowheel.model.build import BETA_MIN_DEFAULT

PAPER = dict(M=2.0, R=0.17, k_diam=0.25, k_axial=0.4, g=9.81)


def _same(a: pd.DataFrame, b: pd.DataFrame) -> None:
    cols = [c for c in a.columns if c != "wall_time"]
    pd.testing.assert_frame_equal(a[cols].reset_index(drop=True), b[cols].reset_index(drop=True), check_exact=True)


def test_final_values_equal_fmpy_simulation_bit_for_bit(earth_fmu):
    """Same FMU, same start values, same communication grid: the batch runner's end state is
    fmpy.simulate_fmu's, exactly (the sweep adds nothing to the physics)."""
    table = sweep(earth_fmu, grid={"gamma_dot": [4.0, 7.5]}, fixed={"beta_deg": 75.0}, stop_time=2.0,
                  output_interval=0.01, metrics=["final:x", "final:y", "final:beta", "max:beta"], workers=0)
    for _, row in table.iterrows():
        ref = simulate_fmu(str(earth_fmu), stop_time=2.0, output_interval=0.01,
                           start_values={"beta": math.radians(75.0), "gamma_dot": row["gamma_dot"]})
        assert row["final_x"] == ref["x"][-1] and row["final_y"] == ref["y"][-1]
        assert row["final_beta"] == ref["beta"][-1] and row["max_beta"] == ref["beta"].max()


def test_fall_time_matches_scipy_reference(earth_fmu, paper_model):
    """A wheel without spin falls sideways; the fall (beta = beta_min) is a metric, not a failure."""
    table = sweep(earth_fmu, grid={"beta_deg": [70.0, 85.0]}, fixed={"gamma_dot": 0.0}, stop_time=3.0,
                  output_interval=0.1, workers=0)
    assert (table["status"] == "ok").all() and not table["survived"].any()
    assert (table["event"] == "fallen").all() and (table["end_time"] == table["fall_time"]).all()
    assert table["min_beta"].tolist() == pytest.approx([BETA_MIN_DEFAULT] * 2, abs=1e-9)
    for _, row in table.iterrows():
        ref = paper_model.fall_time(BETA_MIN_DEFAULT, 1e-11, 1e-12, t_end=3.0, beta=math.radians(row["beta_deg"]),
                                    gamma_dot=0.0, alpha_dot=0.0)
        assert row["fall_time"] == pytest.approx(ref, rel=1e-6)


def test_steady_precession_lean_and_energy(earth_fmu):
    """Eq. (52) start: the lean never moves (max_lean = |beta0 - pi/2|), energy is conserved."""
    beta = math.radians(80.0)
    alpha_dot, gamma_dot = precession_rates(beta, 1.0, **PAPER)
    table = sweep(earth_fmu, points=[dict(beta=beta, alpha_dot=alpha_dot, gamma_dot=gamma_dot)],
                  stop_time=5.0, output_interval=0.05, workers=0)
    row = table.iloc[0]
    assert row["survived"] and math.isnan(row["fall_time"]) and row["end_time"] == 5.0
    assert row["max_lean"] == pytest.approx(math.pi / 2 - beta, abs=1e-7)
    assert row["energy_drift"] < 1e-7


def test_failing_points_are_rows_and_the_sweep_goes_on(earth_fmu, tmp_path):
    """A bad mass is refused by the FMU (fmi2Error, reason logged); a user metric that raises
    fails only its point; the other points run and the table says why each failed one did."""
    metric = tmp_path / "m.py"
    metric.write_text("def picky(traj, point):\n    if point['gamma_dot'] > 5: raise ValueError('too fast')\n"
                      "    return float(traj['beta'][-1])\n")
    table = sweep(earth_fmu, grid={"M": [2.0, -1.0, 3.0], "gamma_dot": [4.0, 8.0]}, stop_time=0.5,
                  metric_functions=[f"{metric}:picky"], workers=0, output=tmp_path / "t.csv")
    assert len(table) == 6
    bad_mass = table[table["M"] == -1.0]
    assert (bad_mass["status"] == "error").all()
    assert bad_mass["reason"].str.contains("M \\(mass\\) must be > 0").all()
    fast = table[(table["M"] > 0) & (table["gamma_dot"] == 8.0)]
    assert (fast["status"] == "error").all()
    assert fast["reason"].str.contains("metric function .*picky: ValueError: too fast").all()
    ok = table[table["status"] == "ok"]
    assert len(ok) == 2 and ok["picky"].notna().all() and (ok["reason"] == "").all()
    on_disk = read_table(tmp_path / "t.csv")
    assert len(on_disk) == 6 and list(on_disk["status"]) == list(table["status"])


def test_batches_and_order_do_not_change_results(earth_fmu):
    """Every point starts from fmi2Reset: batch size and the points before it change nothing."""
    kw = dict(grid={"beta_deg": "60:88:3", "gamma_dot": [0.0, 3.0, 9.0], "M": [2.0, -2.0]}, stop_time=1.0,
              output_interval=0.02, workers=0)
    one = sweep(earth_fmu, batch_size=100, **kw)
    small = sweep(earth_fmu, batch_size=2, **kw)
    cols = [c for c in one.columns if c != "wall_time"]
    pd.testing.assert_frame_equal(one[cols], small[cols], check_exact=True)
    backwards = sweep(earth_fmu, points=one[["beta_deg", "gamma_dot", "M"]].iloc[::-1], stop_time=1.0,
                      output_interval=0.02, workers=0)
    a = one.drop(columns=["point", "wall_time"]).reset_index(drop=True)
    b = backwards.drop(columns=["point", "wall_time"]).iloc[::-1].reset_index(drop=True)
    pd.testing.assert_frame_equal(a, b, check_exact=True)


def test_a_variable_a_point_does_not_name_keeps_its_start_value(earth_fmu):
    """Points that set different variables: a variable a point does not name keeps the unit's start
    value (every point starts from fmi2Reset), also after a point that set it (solver included)."""
    kw = dict(stop_time=1.0, output_interval=0.02, metrics=["survived", "max_lean", "final:x"], workers=0)
    mixed = sweep(earth_fmu, points=[{"beta_deg": 80.0, "gamma_dot": 9.0, "solver": "rk4"}, {"beta_deg": 75.0},
                                     {"beta_deg": 70.0, "gamma_dot": None}], **kw)
    assert (mixed["status"] == "ok").all(), mixed["reason"].tolist()
    alone = sweep(earth_fmu, points=[{"beta_deg": 75.0}, {"beta_deg": 70.0}], **kw)
    _same(mixed.drop(columns=["point", "gamma_dot", "solver"]).iloc[1:], alone.drop(columns="point"))
    assert mixed["gamma_dot"].isna().tolist() == [False, True, True]  # the table keeps what was given


def test_a_missing_enumeration_item_is_no_error(earth_fmu):
    table = sweep(earth_fmu, points=pd.DataFrame({"solver": ["rk4", None], "beta_deg": [80.0, 80.0]}),
                  stop_time=0.2, workers=0, metrics="final:beta")
    assert (table["status"] == "ok").all()


def test_derive_and_metric_function_from_files(earth_fmu, tmp_path):
    """Inputs the FMU does not have (rho) become FMU values through a derive function."""
    helper = tmp_path / "helper.py"
    helper.write_text(textwrap.dedent("""
        from gyrowheel.studies.steady import precession_rates
        def start(point, values):
            keys = ("M", "R", "k_diam", "k_axial", "g")
            a, c = precession_rates(values["beta"], point["rho"], **{k: values[k] for k in keys})
            return {"alpha_dot": a, "gamma_dot": c}
        def lean_range(traj):
            return {"lean_range": float(traj["beta"].max() - traj["beta"].min())}
    """))
    table = sweep(earth_fmu, grid={"rho": [1.0, 2.0], "beta_deg": [80.0]}, derive=f"{helper}:start",
                  metrics=["survived"], metric_functions=[f"{helper}:lean_range"], stop_time=3.0, workers=0)
    assert (table["status"] == "ok").all() and (table["lean_range"] < 1e-7).all()
    assert list(table.columns) == ["point", "rho", "beta_deg", "survived", "lean_range", "status", "reason",
                                   "wall_time"]


def test_random_samples_reproducible(earth_fmu):
    kw = dict(random={"M": "uniform:1.6:2.4", "k_diam": "normal:0.25:0.02"}, samples=5, seed=3,
              stop_time=0.3, workers=0, metrics="final:beta")
    a, b = sweep(earth_fmu, **kw), sweep(earth_fmu, **kw)
    pd.testing.assert_frame_equal(a.drop(columns="wall_time"), b.drop(columns="wall_time"), check_exact=True)
    assert a["M"].between(1.6, 2.4).all()


def test_cli_sweep_writes_table_and_plot(earth_fmu, tmp_path, capsys):
    out, png = tmp_path / "s.parquet", tmp_path / "s.png"
    code = main(["sweep", str(earth_fmu), "--grid", "beta_deg=70:85:3", "--grid", "gamma_dot=0:8:3",
                 "--stop-time", "1", "--solver", "rk4", "--max-step", "0.005", "--workers", "0",
                 "--no-progress", "-o", str(out), "--plot", str(png)])
    assert code == 0, capsys.readouterr().err
    table = read_table(out)
    assert len(table) == 9 and (table["status"] == "ok").all()
    assert table["survived"].dtype == bool and not table.loc[table["gamma_dot"] == 0, "survived"].any()
    assert png.stat().st_size > 10_000


def test_upper_case_fmu_suffix_and_booleans_in_csv(earth_fmu, tmp_path):
    fmu = tmp_path / "EARTH.FMU"
    shutil.copy(earth_fmu, fmu)
    table = sweep(fmu, grid={"gamma_dot": [0.0, 6.0], "M": [2.0, -1.0]}, fixed={"beta_deg": 80.0}, stop_time=1.0,
                  workers=0, output=tmp_path / "t.csv", metrics="survived")
    back = read_table(tmp_path / "t.csv")
    assert back["survived"].dtype == table["survived"].dtype == "boolean"
    assert back["survived"].tolist() == table["survived"].tolist() == [False, pd.NA, True, pd.NA]
