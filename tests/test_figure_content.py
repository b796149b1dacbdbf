"""What the figures people look at show, checked on the matplotlib Figure each plotting function
builds (synthetic data, no timing): simulate --plot names what --set changed, the steering
plot's legend has both tilt lines, the work-precision legend sits beside the data, every log axis
of the sweep cost figure has at least two labelled ticks."""
from __future__ import annotations

import importlib
import sys

import matplotlib
import numpy as np
import pytest

from conftest import ROOT

matplotlib.use("Agg")


def _module(folder: str, name: str):
    sys.path.insert(0, str(ROOT / folder))
    try:
        return importlib.import_module(name)
    finally:
        sys.path.remove(str(ROOT / folder))


def _run(n: int = 50, fields=("x", "y", "alpha", "beta", "gamma_dot", "tilt", "tilt_cmd")) -> np.ndarray:
    r = np.zeros(n, dtype=[("time", float)] + [(f, float) for f in fields] + [("fallen", bool)])
    r["time"] = np.linspace(0, 1, n)
    for k, f in enumerate(fields):
        r[f] = np.sin(r["time"] * (k + 1))
    r["beta"] += 1.2
    return r


def test_simulate_plot_lists_what_set_changed(earth_fmu, tmp_path, monkeypatch):
    """The run's start values given to simulate (--set) appear under the figure's one title, as
    given (solver=rk4, not its number); without any, no figure title (the column names the run)."""
    import matplotlib.figure

    import gyrowheel
    titles = []
    real = matplotlib.figure.Figure.suptitle
    monkeypatch.setattr(matplotlib.figure.Figure, "suptitle",
                        lambda self, text, **kw: (titles.append(text), real(self, text, **kw))[1])
    gyrowheel.simulate(earth_fmu, stop_time=0.1, start_values=["gamma_dot=8", "solver=rk4"],
                       plot=tmp_path / "p.png")
    assert titles == ["set: gamma_dot=8, solver=rk4"] and (tmp_path / "p.png").stat().st_size > 10_000
    gyrowheel.simulate(earth_fmu, stop_time=0.1, plot=tmp_path / "q.png")
    assert titles == ["set: gamma_dot=8, solver=rk4"]


def test_trajectories_title_and_changed_values_once():
    from gyrowheel.plotting import trajectories_figure
    r = _run()
    fig = trajectories_figure({"a": r, "b": r}, title="runs", changed={"M": 2.5})
    assert fig._suptitle.get_text() == "runs\nset: M=2.5"
    plain = trajectories_figure({"a": r, "b": r}, title="runs")._suptitle  # the figure title's own size
    from matplotlib.font_manager import FontProperties
    assert plain.get_fontsize() == FontProperties(size=matplotlib.rcParams["figure.titlesize"]).get_size_in_points()
    fig = trajectories_figure({"moon": r}, title="moon")
    assert fig._suptitle is None and fig.axes[0].get_title() == "moon"


def test_steering_legend_has_the_tilt_and_its_command():
    steering = _module("examples", "gyrover_steering")
    fig = steering.figure(_run())
    tilt_axes = fig.axes[3]
    assert [t.get_text() for t in tilt_axes.get_legend().get_texts()] == ["tilt", "tilt_cmd"]


def test_work_precision_legend_is_beside_the_points():
    """Fifteen methods' lines fill the axes, where any legend position covers some points: the
    legend is outside the axes, sharing no pixel with them."""
    wp = _module("benchmarks", "work_precision")
    points = [wp.Point(f"method {m}", tol, 1e-4 * (m + 1) / tol ** 0.1, tol * (m + 1), 0.0)
              for m in range(15) for tol in (1e-4, 1e-7, 1e-10, 1e-12)]
    fig = wp.figure("paper", points)
    fig.canvas.draw()
    ax = fig.axes[0]
    legend = ax.get_legend().get_window_extent()
    assert not legend.overlaps(ax.get_window_extent())
    assert legend.x1 <= fig.bbox.x1  # and within the figure


def test_sweep_cost_log_axes_have_two_labelled_ticks_or_more():
    """Axes spanning less than two decades, labelled only at powers of ten, show one number."""
    scaling = _module("benchmarks", "sweep_scaling")
    rows = ([("horizon [s]", h, 0.06 * h) for h in (5, 10, 20, 40, 80)]
            + [("rel_tol", t, 0.3 * (1e-4 / t) ** 0.16) for t in (1e-4, 1e-6, 1e-8, 1e-10, 1e-12)]
            + [("points", n, n / 1095) for n in (125, 250, 500, 1000, 2000)])
    fig = scaling.figure(rows, 1095.0)
    fig.canvas.draw()
    for ax in fig.axes:
        for axis, (lo, hi) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
            shown = [t for t in axis.get_major_ticks()
                     if lo * (1 - 1e-9) <= t.get_loc() <= hi * (1 + 1e-9) and t.label1.get_text()]
            assert len(shown) >= 2, (ax.get_xlabel(), axis.axis_name, [t.label1.get_text() for t in shown])


def test_a_drop_plots_its_height_and_contact_mode(example_build, earth_fmu, monkeypatch, tmp_path):
    """`simulate --plot` of the drop (examples/scenes/drop_bounce.toml, an FMU with height, vz and
    contact_mode): the figure has a height panel that starts at the drop height 0.1 m and a
    contact-mode panel whose step line starts in flight and ends rolling, its ticks the modes'
    names; a rolling-only FMU's figure keeps its four panels."""
    import gyrowheel
    from gyrowheel import plotting
    figures = []
    real = plotting.trajectories_figure
    monkeypatch.setattr(plotting, "trajectories_figure", lambda *a, **k: figures.append(real(*a, **k)) or figures[-1])
    gyrowheel.simulate(example_build("drop_bounce").fmu, stop_time=0.6, plot=tmp_path / "drop.png")
    gyrowheel.simulate(earth_fmu, stop_time=0.1, plot=tmp_path / "earth.png")
    drop, earth = figures
    labels = [ax.get_ylabel() for ax in drop.axes]
    assert labels == ["y [m]", "lean beta [deg]", "heading alpha [deg]", "spin rate gamma_dot [rad/s]",
                      "height (lowest rim point) [m]", "contact mode"]
    height = drop.axes[4].get_lines()[0].get_ydata()
    assert height[0] == pytest.approx(0.1, abs=1e-15) and height[-1] == 0.0
    mode = drop.axes[5].get_lines()[0].get_ydata()
    assert mode[0] == 2 and mode[-1] == 0
    assert [t.get_text() for t in drop.axes[5].get_yticklabels()] == ["rolling", "sliding", "flight"]
    assert len(earth.axes) == 4
