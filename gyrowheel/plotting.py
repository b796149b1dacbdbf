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


CONTACT_MODES = ("rolling", "sliding", "flight")  # the contact_mode Enumeration's items, by value


def _has_flight(r: np.ndarray) -> bool:
    """A run of an FMU with the flight mode: outputs height, vz and contact_mode."""
    return all(n in r.dtype.names for n in ("height", "vz", "contact_mode"))


def _contact_panels(ax_height, ax_mode, r: np.ndarray) -> None:
    """The height of the lowest rim point [m] and the contact mode (a step line, its items named)
    against time; empty panels, titled so, for a run without flight beside one with it."""
    if not _has_flight(r):
        for ax in (ax_height, ax_mode):
            ax.set_axis_off()
        ax_height.set_title("no flight mode", fontsize=8)
        return
    t = r["time"]
    _panel(ax_height, t, r["height"], "height (lowest rim point)", "m")
    ax_mode.step(t, r["contact_mode"], where="post", lw=1.0)
    ax_mode.set_yticks(range(len(CONTACT_MODES)), CONTACT_MODES)
    ax_mode.set_ylim(-0.3, len(CONTACT_MODES) - 0.7)
    ax_mode.set_xlabel("t [s]")
    ax_mode.set_ylabel("contact mode")
    ax_mode.grid(True, alpha=0.3)


def changed_text(changed: dict[str, object] | None, width: int = 110) -> str:
    """'set: NAME=VALUE, ...' for the start values a run changed (as given: solver=rk4, not its
    number), wrapped to lines of at most `width` characters; '' when nothing was changed."""
    import textwrap

    if not changed:
        return ""
    items = ", ".join(f"{name}={value}" for name, value in changed.items())
    return "\n".join(textwrap.wrap(f"set: {items}", width, break_on_hyphens=False))


def plot_trajectories(results: dict[str, np.ndarray], path: str | Path, title: str = "",
                      changed: dict[str, object] | None = None) -> Path:
    """Write a PNG with one column per result (e.g. earth, Mars, moon): x-y path [m], lean beta
    [deg], heading alpha [deg], spin rate gamma_dot [rad/s] against time [s], and for an FMU with
    the flight mode (outputs height, vz, contact_mode) the lowest rim point's height [m] and the
    contact mode (rolling, sliding, flight) too; a run that fell has its fall marked.  results: {column title: fmpy's structured array with fields time, x, y,
    alpha, beta, gamma_dot (and fallen)}; title: the figure's title (not repeated when the only
    column already carries it); changed: {name: value} of the start values the run was given,
    listed under the title (simulate --set).  Returns the path; its directory must exist (it is
    not made: the rule of every output, gyrowheel.output_files)."""
    fig = trajectories_figure(results, title, changed)
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def trajectories_figure(results: dict[str, np.ndarray], title: str = "", changed: dict[str, object] | None = None):
    """The matplotlib Figure plot_trajectories writes (same arguments)."""
    names = list(results)
    flight = any(_has_flight(r) for r in results.values())
    rows = 6 if flight else 4
    fig, axes = plt.subplots(rows, len(names), figsize=(4.2 * len(names), 2.75 * rows), squeeze=False)
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
        if flight:
            _contact_panels(axes[4, col], axes[5, col], r)
        if "fallen" in r.dtype.names and bool(r["fallen"][-1]):
            axes[1, col].axvline(t[-1], color="r", ls="--", lw=0.8)
            axes[1, col].text(t[-1], math.degrees(float(r["beta"][-1])), " fallen", color="r", fontsize=8)
    heading = title if title and names != [title] else ""  # one column already has it as its title
    subtitle = changed_text(changed, width=int(40 * len(names)))
    if subtitle:
        heading = f"{heading}\n{subtitle}" if heading else subtitle
    if heading:
        fig.suptitle(heading, **({"fontsize": 10} if subtitle else {}))
    fig.tight_layout()
    return fig
