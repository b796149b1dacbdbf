"""A sweep table's text metric plotted as categories (gyrowheel sweep --plot-metric
final:contact_mode): the items of an Enumeration output, `rolling`, `sliding`, `flight`, one
colour each, never coerced to numbers.

- two or more inputs on a grid: a map of the category over the first two (a panel per value of
  the third), its colour bar labelled with the items; a cell whose points disagree (an input not
  on the axes varies in it) shows the category most of them reached, ties to the first in order;
- otherwise: the category against each varying input (one row per item on the y axis), and the
  number of points in each category.
Failed points (no value) are marked with a red x below the items.
"""
from __future__ import annotations

import numpy as np
import pandas as pd


def is_categorical(values: pd.Series) -> bool:
    """True for a text column (object or string dtype with at least one str value)."""
    return not pd.api.types.is_numeric_dtype(values) and any(isinstance(v, str) for v in values.dropna())


def categories(values: pd.Series) -> list[str]:
    """The column's distinct values as text, sorted: the y ticks and colour order of the plot."""
    return sorted({str(v) for v in values.dropna()})


def category_figure(table: pd.DataFrame, metric: str, varying: list[str], grid_like: list[str], inputs: list[str],
                    axis_label):
    """The matplotlib Figure of the text column `metric` (see the module docstring). table: the
    sweep's table (status column: 'ok' or the failure); varying, grid_like: the inputs that vary,
    those that repeat (a grid); axis_label(column) -> 'column [unit]'. Returns the Figure."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm, ListedColormap

    names = categories(table[metric])
    code = {name: k for k, name in enumerate(names)}
    codes = table[metric].map(lambda v: code.get(str(v), np.nan) if pd.notna(v) else np.nan).astype(float)
    failed = table["status"] != "ok"
    colours = ListedColormap(plt.get_cmap("tab10").colors[:max(len(names), 1)])
    norm = BoundaryNorm(np.arange(-0.5, len(names) + 0.5), colours.N)
    if len(grid_like) >= 2:
        facet = grid_like[2] if len(grid_like) > 2 else None
        coded = table.assign(**{metric: codes})
        groups = list(coded.groupby(facet, sort=False)) if facet else [(None, coded)]
        fig, axes = plt.subplots(1, len(groups), figsize=(4.8 * len(groups), 4), squeeze=False)
        x, y = grid_like[0], grid_like[1]
        for ax, (key, sub) in zip(axes[0], groups):
            pivot = sub.pivot_table(index=y, columns=x, values=metric, dropna=False,
                                    aggfunc=lambda s: s.mode().min() if s.notna().any() else np.nan)
            ax.set_facecolor("0.85")
            mesh = ax.pcolormesh(pivot.columns.astype(float), pivot.index.astype(float), pivot.values.astype(float),
                                 shading="nearest", cmap=colours, norm=norm)
            bad = sub[sub["status"] != "ok"]
            ax.plot(bad[x], bad[y], "rx", ms=4)
            ax.set(xlabel=axis_label(x), ylabel=axis_label(y), title=f"{facet} = {key}" if facet else "")
        bar = fig.colorbar(mesh, ax=axes[0].tolist(), ticks=range(len(names)), label=metric)
        bar.ax.set_yticklabels(names)
    else:
        shown = varying[:3] or inputs[:1]
        fig, axes = plt.subplots(1, len(shown) + 1, figsize=(4 * (len(shown) + 1), 3.6), squeeze=False)
        for ax, x in zip(axes[0], shown):
            ax.scatter(table[x], codes, c=codes, cmap=colours, norm=norm, s=9)
            ax.plot(table.loc[failed, x], np.full(int(failed.sum()), -1.0), "rx")
            ax.set(xlabel=axis_label(x), ylabel=metric, yticks=range(len(names)), yticklabels=names,
                   ylim=(-1.5 if failed.any() else -0.5, len(names) - 0.5))
        counts = [int((codes == k).sum()) for k in range(len(names))]
        axes[0][-1].bar(names, counts, color=[colours(k) for k in range(len(names))])
        axes[0][-1].set(xlabel=metric, ylabel="points")
    fig.suptitle(f"{metric}: {len(table)} points, {int(failed.sum())} failed")
    return fig
