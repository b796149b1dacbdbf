"""The sweep's first-look plot (gyrowheel sweep --plot, studies/plot.py) on tables made here:
the default metric colours most cells, every axis has its unit, a yes/no metric is shown as a
fraction with its Wilson interval."""
from __future__ import annotations

import math

import matplotlib
import numpy as np
import pandas as pd
import pytest

from gyrowheel.studies.plot import default_metric, plot_table, table_figure, wilson

matplotlib.use("Agg")


def grid_table(fell: set[tuple[float, float]]) -> pd.DataFrame:
    """A 4 x 5 grid of (beta_deg, gamma_dot): the points in `fell` fell at 3 s, the rest survived."""
    rows = []
    for b in (60.0, 70.0, 80.0, 89.0):
        for w in (0.0, 3.0, 6.0, 9.0, 12.0):
            down = (b, w) in fell
            rows.append(dict(point=len(rows), beta_deg=b, gamma_dot=w, status="ok", reason="",
                             survived=not down, fall_time=3.0 if down else math.nan,
                             max_lean=math.radians(90 - b) + 0.1))
    return pd.DataFrame(rows)


def test_default_metric_of_a_map_where_most_points_survive_is_not_the_fall_time():
    """Two falls among 20 points: fall_time would leave 18 of 20 cells grey, so the default is
    the first metric with a value at most points, survived.  Where most points fell, fall_time
    is the default."""
    few = grid_table({(60.0, 0.0), (70.0, 0.0)})
    assert default_metric(few, ["beta_deg", "gamma_dot"]) == "survived"
    most = grid_table({(b, w) for b in (60.0, 70.0, 80.0, 89.0) for w in (0.0, 3.0, 6.0)})
    assert default_metric(most, ["beta_deg", "gamma_dot"]) == "fall_time"


def test_heat_map_axes_carry_units_and_grey_is_explained(tmp_path):
    table = grid_table({(60.0, 0.0), (70.0, 0.0)})
    fig = table_figure(table, ["beta_deg", "gamma_dot"], metric="fall_time", units={"gamma_dot": "rad/s"})
    ax = fig.axes[0]
    assert ax.get_xlabel() == "beta_deg [deg]" and ax.get_ylabel() == "gamma_dot [rad/s]"
    colorbar = fig.axes[-1].get_ylabel()
    assert colorbar.startswith("fall_time [s]") and "grey: no value, the wheel did not fall" in colorbar
    fig = table_figure(table, ["beta_deg", "gamma_dot"], units={"gamma_dot": "rad/s"})
    assert fig.axes[-1].get_ylabel() == "survived: fraction of the cell's points"
    assert plot_table(table, tmp_path / "m.png", ["beta_deg", "gamma_dot"]).stat().st_size > 10_000


def test_random_samples_of_a_yes_no_metric_are_fractions_with_wilson_intervals():
    """survived over random samples: per bin of each input the fraction of survivors with its
    95% Wilson interval (not 0/1 dots), and the overall fraction in the last panel's title.
    The interval against scipy's (z = 1.96 here, the exact quantile 1.959964 there: 1e-5 apart)."""
    from scipy.stats import binomtest
    for k, n in ((8, 10), (0, 20), (1146, 1778)):
        ci = binomtest(k, n).proportion_ci(method="wilson")
        assert wilson(k, n) == (pytest.approx(ci.low, abs=2e-5), pytest.approx(ci.high, abs=2e-5))
    rng = np.random.default_rng(1)
    M = rng.uniform(1.6, 2.4, 400)
    table = pd.DataFrame(dict(point=np.arange(400), M=M, status="ok", reason="", survived=M > 2.0,
                              fall_time=np.where(M > 2.0, np.nan, 5.0)))
    fig = table_figure(table, ["M"], metric="survived", units={"M": "kg"})
    scatter, summary = fig.axes[0], fig.axes[1]
    assert scatter.get_xlabel() == "M [kg]" and scatter.get_ylabel() == "survived: fraction (95% interval)"
    y = scatter.lines[0].get_ydata()
    assert len(y) == 10 and y[:4].max() == 0.0 and y[-4:].min() == 1.0  # bins below / above 2 kg
    k = int((M > 2.0).sum())
    a, b = wilson(k, 400)
    assert summary.get_title() == f"survived: {100 * k / 400:.1f}% [{100 * a:.1f}, {100 * b:.1f}] of 400"
