"""A first look at a sweep table (gyrowheel sweep --plot): the shape of the inputs picks the plot.

- two or more inputs on a grid: a heat map of the metric over the first two, one panel per
  value of the third (e.g. g); NaN (e.g. fall_time of a wheel that survived) shown in grey;
- one varying input: the metric against it;
- random inputs: the metric against each of them (scatter) and its histogram.
Failed points are marked with a red x. The maps in docs/sweeps.md add physics on top of these.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

SKIP = {"point", "status", "reason", "wall_time", "event"}


def check_plot_path(path: str | Path | None) -> Path | None:
    """Refuse, before a sweep runs, a plot it could not write: an unknown image format or no such directory."""
    if path is None:
        return None
    from matplotlib.backend_bases import FigureCanvasBase

    from gyrowheel.studies.spec import SweepSpecError

    path = Path(path)
    formats = FigureCanvasBase.get_supported_filetypes()
    if path.suffix.lower().lstrip(".") not in formats:
        raise SweepSpecError(f"--plot {path}: unknown image format {path.suffix or '(no suffix)'!r}; "
                             f"use .{', .'.join(sorted(formats))}")
    if not path.parent.is_dir():
        raise SweepSpecError(f"--plot {path}: directory {path.parent} does not exist")
    return path


def default_metric(table: pd.DataFrame, inputs: list[str]) -> str:
    numeric = [c for c in table.columns if c not in SKIP and c not in inputs
               and pd.api.types.is_numeric_dtype(table[c])]
    if "fall_time" in numeric and table["fall_time"].notna().any():
        return "fall_time"
    if not numeric:
        raise ValueError("the table has no numeric metric to plot")
    return numeric[0]


def plot_table(table: pd.DataFrame, path: str | Path, inputs: list[str], metric: str | None = None) -> Path:
    """Write a PNG of `metric` over the sweep's inputs (see the module docstring); returns the path."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    metric = metric or default_metric(table, inputs)
    if metric not in table.columns:
        raise ValueError(f"--plot-metric {metric!r}: no such column; columns: {', '.join(table.columns)}")
    varying = [c for c in inputs if table[c].nunique() > 1]
    grid_like = [c for c in varying if table[c].nunique() < len(table)]
    values = table[metric].astype(float)
    failed = table["status"] != "ok"
    if len(grid_like) >= 2:
        facet = grid_like[2] if len(grid_like) > 2 else None
        groups = list(table.groupby(facet, sort=False)) if facet else [(None, table)]
        fig, axes = plt.subplots(1, len(groups), figsize=(4.8 * len(groups), 4), squeeze=False)
        x, y = grid_like[0], grid_like[1]
        lo, hi = np.nanmin(values), np.nanmax(values)
        for ax, (key, sub) in zip(axes[0], groups):
            pivot = sub.pivot_table(index=y, columns=x, values=metric, aggfunc="mean", dropna=False)
            ax.set_facecolor("0.85")
            mesh = ax.pcolormesh(pivot.columns.astype(float), pivot.index.astype(float),
                                 pivot.values.astype(float), shading="nearest", vmin=lo, vmax=hi)
            bad = sub[sub["status"] != "ok"]
            ax.plot(bad[x], bad[y], "rx", ms=4)
            ax.set(xlabel=x, ylabel=y, title=f"{facet} = {key}" if facet else "")
        fig.colorbar(mesh, ax=axes[0].tolist(), label=f"{metric} (grey: NaN)")
    elif len(varying) == 1 and grid_like:
        fig, ax = plt.subplots(figsize=(6, 4))
        x = varying[0]
        ax.plot(table[x], values, ".-")
        ax.plot(table.loc[failed, x], np.zeros(failed.sum()), "rx", label="failed")
        ax.set(xlabel=x, ylabel=metric)
    else:
        shown = varying[:3] or inputs[:1]
        fig, axes = plt.subplots(1, len(shown) + 1, figsize=(4 * (len(shown) + 1), 3.6), squeeze=False)
        for ax, x in zip(axes[0], shown):
            ax.plot(table[x], values, ".", ms=3)
            ax.plot(table.loc[failed, x], np.full(failed.sum(), np.nanmin(values) if values.notna().any() else 0),
                    "rx")
            ax.set(xlabel=x, ylabel=metric)
        axes[0][-1].hist(values.dropna(), bins=30)
        axes[0][-1].set(xlabel=metric, ylabel="points")
    fig.suptitle(f"{metric}: {len(table)} points, {int(failed.sum())} failed")
    path = Path(path)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path
