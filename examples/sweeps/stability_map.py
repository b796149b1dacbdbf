"""Stability map of the unactuated wheel: fall time or survival over (initial lean, spin rate),
on earth, Mars and the moon, with the critical spin w_c and the linearised eigenvalue boundary.

    python examples/sweeps/stability_map.py [--workers N | --scheduler ADDRESS] [--out DIR]

Runs one `gyrowheel sweep` (printed) over the paper's wheel started at lean beta0 with spin
gamma_dot0 (alpha_dot0 = beta_dot0 = 0), then draws the map (docs/img/sweep_stability.png) from its table.
"""
from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]

from gyrowheel.cli import main as gyrowheel  # noqa: E402
from gyrowheel.studies import read_table  # noqa: E402
from gyrowheel.model.steady import critical_spin  # noqa: E402
from gyrowheel.studies.steady import upright_boundary  # noqa: E402

WHEEL = dict(M=2.0, R=0.17, k_diam=0.25, k_axial=0.4)
GRAVITY = {"earth": 9.81, "mars": 3.721, "moon": 1.625}


def command(out: Path, execution: list[str], fall_deg: float) -> list[str]:
    return ["sweep", "examples/scenes/paper_earth.toml",
            "--grid", "g=earth,mars,moon", "--grid", "beta_deg=40:89.5:34", "--grid", "gamma_dot=0:12:49",
            "--set", f"beta_min_deg={fall_deg:g}", "--stop-time", "10", "--output-interval", "0.02",
            "--metrics", "survived,fall_time,max_lean", *execution, "-o", str(out)]


def plot(table, png: Path, fall_deg: float) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), sharey=True, constrained_layout=True)
    for ax, (name, g) in zip(axes, GRAVITY.items()):
        sub = table[table["g"] == name]
        lean = sub.pivot(index="gamma_dot", columns="beta_deg", values="max_lean").apply(np.degrees)
        fall = sub.pivot(index="gamma_dot", columns="beta_deg", values="fall_time")
        x, y = lean.columns.values, lean.index.values
        m1 = ax.pcolormesh(x, y, lean.where(fall.isna()).values, shading="nearest", cmap="Blues", vmin=0, vmax=90 - fall_deg)
        m2 = ax.pcolormesh(x, y, fall.values, shading="nearest", cmap="autumn", vmin=0,
                           vmax=float(np.nanmax(table["fall_time"])))
        failed = sub[sub["status"] != "ok"]
        ax.plot(failed["beta_deg"], failed["gamma_dot"], "kx", ms=5)
        wc = critical_spin(g=g, **WHEEL)
        w_eig = upright_boundary(g=g, **WHEEL)
        ax.axhline(wc, color="k", lw=2, label=f"$\\omega_c$ = {wc:.3f} rad/s (formula)")
        ax.plot(x, np.full_like(x, w_eig), "w--", lw=1.5,
                label=f"eigenvalue boundary {w_eig:.3f} rad/s")
        ax.set(title=f"{name} (g = {g} m/s$^2$)", xlabel=r"initial lean $\beta_0$ [deg] (90 = upright)")
        ax.legend(loc="upper left", fontsize=8)
    axes[0].set_ylabel(r"spin $\dot\gamma_0$ [rad/s]")
    fig.colorbar(m1, ax=axes, label="survived 10 s: largest lean from upright [deg]", pad=0.01, fraction=0.03)
    fig.colorbar(m2, ax=axes, label=f"fell (lean reached {fall_deg:g} deg): fall time [s]", pad=0.01,
                 fraction=0.03)
    fig.suptitle("Unactuated paper wheel (M = 2 kg, R = 0.17 m): upright rolling is stable above "
                 r"$\omega_c^2 = M g R I_{diam} / (I_{axial}(I_{axial} + M R^2))$")
    fig.savefig(png, dpi=110)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int)
    ap.add_argument("--scheduler")
    ap.add_argument("--fall-deg", type=float, default=30.0, help="lean counted as a fall (beta_min), deg")
    ap.add_argument("--out", default="results/sweeps", help="directory for the table")
    ap.add_argument("--png", help="the figure (default: OUT/sweep_stability.png; docs/img/sweep_stability.png "
                    "is this figure)")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    args.png = args.png or str(out / "sweep_stability.png")
    execution = (["--scheduler", args.scheduler] if args.scheduler else
                 ["--workers", str(args.workers)] if args.workers is not None else [])
    argv = command(out / "stability.parquet", execution, args.fall_deg)
    print("gyrowheel " + shlex.join(argv))
    code = gyrowheel(argv)
    if code:
        return code
    plot(read_table(out / "stability.parquet"), Path(args.png), args.fall_deg)
    print(f"wrote {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
