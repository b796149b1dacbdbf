"""A sweep's text metric (final:contact_mode, an Enumeration output's item names) plotted as
categories (studies/plot_categories.py): each item one colour, labelled with its name, never
coerced to a number (which failed: "could not convert string to float: 'rolling'"). The tables
are made here, with the item each cell must show; the user's command runs on drop_bounce, whose
final modes are known (tests/test_sweep_contact_metrics.py: sliding without friction, rolling
with it, flight at restitution 1)."""
from __future__ import annotations

import matplotlib
import numpy as np
import pandas as pd
import pytest

from gyrowheel.studies.plot import table_figure

matplotlib.use("Agg")

ITEMS = ["flight", "rolling", "sliding"]  # sorted: the colour and tick order


def mode_of(restitution: float, mu: float) -> str:
    return "flight" if restitution == 1.0 else ("sliding" if mu == 0.0 else "rolling")


def grid_table() -> pd.DataFrame:
    rows = [dict(point=k, restitution=e, mu=m, final_contact_mode=mode_of(e, m), status="ok", reason="")
            for k, (e, m) in enumerate((e, m) for e in (0.0, 0.25, 0.5, 0.75, 1.0) for m in (0.0, 0.3))]
    return pd.DataFrame(rows)


def test_a_grid_maps_each_cell_to_its_items_colour_and_name():
    import matplotlib.pyplot as plt
    from matplotlib.collections import QuadMesh
    table = grid_table()
    fig = table_figure(table, ["restitution", "mu"], "final:contact_mode")
    try:
        mesh = next(c for c in fig.axes[0].collections if isinstance(c, QuadMesh))
        shown = np.asarray(mesh.get_array()).reshape(2, 5)  # rows: mu 0, 0.3; columns: restitution
        expected = [[ITEMS.index(mode_of(e, m)) for e in (0.0, 0.25, 0.5, 0.75, 1.0)] for m in (0.0, 0.3)]
        assert shown.tolist() == expected
        bar = fig.axes[-1]
        assert [t.get_text() for t in bar.get_yticklabels()] == ITEMS
        # each item's colour is the one the colour bar shows against its name
        assert [mesh.norm(k) for k in range(3)] == [0, 1, 2]
        assert fig._suptitle.get_text() == "final_contact_mode: 10 points, 0 failed"
    finally:
        plt.close(fig)


def test_random_inputs_show_items_on_the_axis_and_their_counts():
    import matplotlib.pyplot as plt
    rng = np.random.default_rng(3)
    e = rng.uniform(0, 1, 40)
    modes = np.where(e > 0.9, "flight", "rolling")
    table = pd.DataFrame(dict(point=range(40), restitution=e, final_contact_mode=modes, status="ok", reason=""))
    table.loc[5, ["status", "final_contact_mode"]] = ["failed", None]  # a failed point: no item
    fig = table_figure(table, ["restitution"], "final_contact_mode")
    try:
        scatter_ax, bars_ax = fig.axes
        assert [t.get_text() for t in scatter_ax.get_yticklabels()] == ["flight", "rolling"]
        heights = [p.get_height() for p in bars_ax.patches]
        ok = table["status"] == "ok"
        assert heights == [int((table.loc[ok, "final_contact_mode"] == m).sum()) for m in ("flight", "rolling")]
        assert sum(heights) == 39
    finally:
        plt.close(fig)


@pytest.fixture(scope="module")
def drop_fmu(example_build):
    return example_build("drop_bounce").fmu


def test_the_users_command_plots_final_contact_mode(drop_fmu, tmp_path):
    """`gyrowheel sweep ... --metrics final:contact_mode --plot-metric final:contact_mode`:
    exit 0, the PNG written (the metric named as --metrics names it)."""
    from gyrowheel.cli import main
    png = tmp_path / "modes.png"
    assert main(["sweep", str(drop_fmu), "--grid", "restitution=0:1:5", "--grid", "mu=0,0.3", "--set", "mu_k=0",
                 "--workers", "0", "--metrics", "final:contact_mode", "--plot-metric", "final:contact_mode",
                 "--plot", str(png), "-o", str(tmp_path / "s.csv")]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
