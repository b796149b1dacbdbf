"""Trajectory figures in the spirit of the paper's Figs. 7-9."""
from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def _panel(ax, t, y, label, unit):
    ax.plot(t, y, lw=1.0)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(f"{label} [{unit}]")
    ax.grid(True, alpha=0.3)


def plot_trajectories(results: dict[str, np.ndarray], path: str | Path, title: str = "") -> Path:
    """One column per result (e.g. earth, Mars, moon): x-y path, lean, heading, spin rate."""
    names = list(results)
    fig, axes = plt.subplots(4, len(names), figsize=(4.2 * len(names), 11), squeeze=False)
    for col, name in enumerate(names):
        r = results[name]
        t = r["time"]
        ax = axes[0, col]
        ax.plot(r["x"], r["y"], lw=1.0)
        ax.plot(r["x"][:1], r["y"][:1], "go", ms=4, label="start")
        ax.plot(r["x"][-1:], r["y"][-1:], "rs", ms=4, label="end")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_title(name)
        ax.legend(fontsize=7)
        ax.grid(True, alpha=0.3)
        _panel(axes[1, col], t, np.degrees(r["beta"]), "lean beta", "deg")
        _panel(axes[2, col], t, np.degrees(r["alpha"]), "heading alpha", "deg")
        _panel(axes[3, col], t, r["gamma_dot"], "spin rate gamma_dot", "rad/s")
        if "fallen" in r.dtype.names and bool(r["fallen"][-1]):
            axes[1, col].axvline(t[-1], color="r", ls="--", lw=0.8)
            axes[1, col].text(t[-1], math.degrees(float(r["beta"][-1])), " fallen", color="r", fontsize=8)
    if title and names != [title]:  # one column already has it as its title
        fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
