"""A first look at a sweep table (gyrowheel sweep --plot): the shape of the inputs picks the plot.

- two or more inputs on a grid: a heat map of the metric over the first two, one panel per
  value of the third (e.g. g); a cell without a value (fall_time of a wheel that did not fall)
  is grey, and the colour bar says what grey means;
- one varying input: the metric against it;
- random inputs: the metric against each of them (scatter) and its histogram; a yes/no metric
  (survived) as the fraction of yes in bins of each input, with its 95% Wilson interval.
A text metric (an Enumeration output's items, final:contact_mode) is plotted as categories
(studies/plot_categories.py). Failed points are marked with a red x. Every axis carries its
unit: the FMU's unit of an input (deg for NAME_deg), the metric's own (studies/metrics.py). The
default metric is one that has a value at most points (fall_time only if most points fell). The
maps in docs/sweeps.md add physics on top of these.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from gyrowheel.studies.plot_categories import category_figure, is_categorical

SKIP = {"point", "status", "reason", "wall_time", "event"}


def check_plot_path(path: str | Path | None) -> Path | None:
    """Refuse, before a sweep runs, a plot it could not write: returns the path, absolute (the
    file written after the run, wherever the working directory went), or None.

    Raises SweepSpecError (`--plot ...`, argument 'plot') for a path that exists and is not a
    regular file (a directory, a device such as /dev/full or a link to it, a FIFO, a socket), a
    directory that does not exist (gyrowheel.output_files.check_output_file), or a suffix that
    is no image format matplotlib writes (FigureCanvasBase.get_supported_filetypes)."""
    if path is None:
        return None
    from matplotlib.backend_bases import FigureCanvasBase

    from gyrowheel.output_files import check_output_file
    from gyrowheel.studies.spec import SweepSpecError

    path = Path(path)
    check_output_file(path, "--plot", error=SweepSpecError, argument="plot")
    formats = FigureCanvasBase.get_supported_filetypes()
    if path.suffix.lower().lstrip(".") not in formats:
        raise SweepSpecError(f"--plot {path}: unknown image format {path.suffix or '(no suffix)'!r}; "
                             f"use .{', .'.join(sorted(formats))}", argument="plot")
    return path.absolute()


# units of the built-in metrics (studies/metrics.py); final:/max:/min:/mean:NAME take NAME's unit
METRIC_UNITS = {"survived": "fraction", "fall_time": "s", "end_time": "s", "min_beta": "rad", "max_beta": "rad",
                "max_lean": "rad", "final_x": "m", "final_y": "m", "energy_drift": "1"}


def default_metric(table: pd.DataFrame, inputs: list[str]) -> str:
    """The column plotted when none is asked for: fall_time if it has a value at half the points
    or more (most points fell), else the first numeric metric with a value at half the points or
    more (survived, when the sweep computed it), else the first numeric metric.  Raises ValueError
    when the table has no numeric metric."""
    numeric = [c for c in table.columns if c not in SKIP and c not in inputs
               and pd.api.types.is_numeric_dtype(table[c])]
    if not numeric:
        raise ValueError("the table has no numeric metric to plot")
    filled = {c: table[c].notna().mean() >= 0.5 for c in numeric}
    if "fall_time" in numeric and filled["fall_time"]:
        return "fall_time"
    return next((c for c in numeric if filled[c]), numeric[0])


def unit_of(column: str, units: dict[str, str] | None = None) -> str:
    """The unit of a table column: an input's from `units` ({name: unit}, the FMU's), deg for
    NAME_deg, a metric's from METRIC_UNITS (final:NAME and the like: NAME's); '' if unknown."""
    units = units or {}
    if column in units and units[column]:
        return units[column]
    if column.endswith("_deg"):
        return "deg"
    if column in METRIC_UNITS:
        return METRIC_UNITS[column]
    for prefix in ("final_", "max_", "min_", "mean_"):
        if column.startswith(prefix) and units.get(column[len(prefix):]):
            return units[column[len(prefix):]]
    return ""


def label(column: str, units: dict[str, str] | None = None) -> str:
    """'column [unit]', or the column alone when its unit is unknown."""
    unit = unit_of(column, units)
    return f"{column} [{unit}]" if unit else column


def _is_yes_no(values: pd.Series) -> bool:
    present = values.dropna()
    return len(present) > 0 and bool(present.isin([0, 1]).all())


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The 95% Wilson score interval (Wilson 1927) of a fraction k/n; (nan, nan) for n = 0."""
    if n == 0:
        return math.nan, math.nan
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def binned_fraction(x: pd.Series, yes: pd.Series, bins: int = 10) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                            np.ndarray]:
    """The fraction of yes (0/1) in `bins` equal bins of x: (bin centres, fractions, lower and
    upper ends of the 95% Wilson intervals); empty bins are left out."""
    edges = np.linspace(float(x.min()), float(x.max()), bins + 1)
    which = np.clip(np.digitize(x, edges) - 1, 0, bins - 1)
    centres, fraction, lo, hi = [], [], [], []
    for b in range(bins):
        sel = yes[which == b]
        if len(sel) == 0:
            continue
        k, n = int(sel.sum()), len(sel)
        a, c = wilson(k, n)
        centres.append(0.5 * (edges[b] + edges[b + 1]))
        fraction.append(k / n)
        lo.append(a)
        hi.append(c)
    return np.array(centres), np.array(fraction), np.array(lo), np.array(hi)


def plot_table(table: pd.DataFrame, path: str | Path, inputs: list[str], metric: str | None = None,
               units: dict[str, str] | None = None) -> Path:
    """Write a PNG of `metric` over the sweep's inputs (see the module docstring); returns the path.

    table: the sweep's table (a row per point: its inputs, status and metrics); inputs: the
    table's input columns; metric: the column to plot (default: default_metric); units: {input
    name: unit} for the axes (the FMU's variables' units).  The file is written whole or not at
    all (gyrowheel.output_files.replaced_atomically). Raises ValueError when `metric` names no
    column or the table has no numeric metric; SweepSpecError (a ValueError) when `path` cannot
    be written (check_plot_path)."""
    import matplotlib.pyplot as plt

    from gyrowheel.output_files import replaced_atomically
    from gyrowheel.studies.spec import SweepSpecError

    fig = table_figure(table, inputs, metric, units)
    path = Path(path)
    try:
        with replaced_atomically(path, "--plot", error=SweepSpecError, argument="plot") as part:
            fig.savefig(part, dpi=110, bbox_inches="tight")
    finally:
        plt.close(fig)
    return path


def table_figure(table: pd.DataFrame, inputs: list[str], metric: str | None = None,
                 units: dict[str, str] | None = None):
    """The matplotlib Figure plot_table writes (same arguments, same errors)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    metric = metric or default_metric(table, inputs)
    if metric not in table.columns and metric.replace(":", "_", 1) in table.columns:
        metric = metric.replace(":", "_", 1)  # as --metrics names it (final:contact_mode): its column
    if metric not in table.columns:
        raise ValueError(f"--plot-metric {metric!r}: no such column; columns: {', '.join(table.columns)}")
    varying = [c for c in inputs if table[c].nunique() > 1]
    grid_like = [c for c in varying if table[c].nunique() < len(table)]
    if is_categorical(table[metric]):  # an Enumeration output's item names: categories, not numbers
        return category_figure(table, metric, varying, grid_like, inputs, lambda c: label(c, units))
    values = table[metric].astype(float)
    failed = table["status"] != "ok"
    yes_no = _is_yes_no(values)
    metric_label = label(metric, units)
    if len(grid_like) >= 2:
        facet = grid_like[2] if len(grid_like) > 2 else None
        groups = list(table.groupby(facet, sort=False)) if facet else [(None, table)]
        fig, axes = plt.subplots(1, len(groups), figsize=(4.8 * len(groups), 4), squeeze=False)
        x, y = grid_like[0], grid_like[1]
        lo, hi = (0.0, 1.0) if yes_no else (np.nanmin(values), np.nanmax(values))
        grey = False
        for ax, (key, sub) in zip(axes[0], groups):
            pivot = sub.pivot_table(index=y, columns=x, values=metric, aggfunc="mean", dropna=False)
            grey = grey or bool(np.isnan(pivot.values.astype(float)).any())
            ax.set_facecolor("0.85")
            mesh = ax.pcolormesh(pivot.columns.astype(float), pivot.index.astype(float),
                                 pivot.values.astype(float), shading="nearest", vmin=lo, vmax=hi)
            bad = sub[sub["status"] != "ok"]
            ax.plot(bad[x], bad[y], "rx", ms=4)
            ax.set(xlabel=label(x, units), ylabel=label(y, units),
                   title=f"{facet} = {key}" if facet else "")
        if yes_no:
            metric_label = f"{metric}: fraction of the cell's points"
        if grey:
            metric_label += "\n(grey: no value" + (", the wheel did not fall)" if metric == "fall_time" else ")")
        fig.colorbar(mesh, ax=axes[0].tolist(), label=metric_label)
    elif len(varying) == 1 and grid_like:
        fig, ax = plt.subplots(figsize=(6, 4))
        x = varying[0]
        ax.plot(table[x], values, ".-")
        ax.plot(table.loc[failed, x], np.zeros(failed.sum()), "rx", label="failed")
        ax.set(xlabel=label(x, units), ylabel=metric_label)
    else:
        shown = varying[:3] or inputs[:1]
        fig, axes = plt.subplots(1, len(shown) + 1, figsize=(4 * (len(shown) + 1), 3.6), squeeze=False)
        ok = table[~failed]
        for ax, x in zip(axes[0], shown):
            if yes_no and ok[x].nunique() > 1:
                c, frac, a, b = binned_fraction(ok[x].astype(float), ok[metric].astype(float))
                ax.errorbar(c, frac, yerr=[np.maximum(frac - a, 0), np.maximum(b - frac, 0)], fmt="o-", ms=4,
                            capsize=3)  # at 0% or 100% the interval's end is the rate, to rounding
                ax.set(ylim=(-0.02, 1.02), ylabel=f"{metric}: fraction (95% interval)")
            else:
                ax.plot(table[x], values, ".", ms=3)
                ax.set(ylabel=metric_label)
            ax.plot(table.loc[failed, x], np.full(failed.sum(), np.nanmin(values) if values.notna().any() else 0),
                    "rx")
            ax.set(xlabel=label(x, units))
        if yes_no:
            k, n = int(ok[metric].astype(float).sum()), len(ok)
            a, b = wilson(k, n)
            axes[0][-1].bar(["no", "yes"], [n - k, k])
            axes[0][-1].set(ylabel="points", title=f"{metric}: {100 * k / max(n, 1):.1f}% "
                            f"[{100 * a:.1f}, {100 * b:.1f}] of {n}")
        else:
            axes[0][-1].hist(values.dropna(), bins=30)
            axes[0][-1].set(xlabel=metric_label, ylabel="points")
    fig.suptitle(f"{metric}: {len(table)} points, {int(failed.sum())} failed")
    return fig
