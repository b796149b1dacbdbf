"""The paper's Figs. 5 and 6 (speed of steady precession against the circle's radius and the lean,
earth / Mars / moon, eq. 53) with simulated points on top, and where steady precession is unstable.

    python examples/sweeps/paper_figs_5_6.py [--workers N | --scheduler ADDRESS] [--out DIR]

Four `gyrowheel sweep` runs (printed): Fig. 5 (beta = 80 deg, rho = 0.05..3 m), Fig. 6 (rho = 1 m,
beta = 45..89 deg), and a (rho, beta) grid for the paper's wheel and for k = 0.3/0.45 (where
docs/model.md found an unstable steady precession at 85 deg, rho = 0.2 m). Every run starts on
the steady precession of eqs. (52)/(49) with a 1e-6 rad/s nudge of the lean rate and checks, over
10 s, that the lean stays within 1e-3 rad and the centre's circle has radius rho to 1e-3
(examples/sweeps/steady_precession.py). The curves are eq. (53); the shading is where the
linearisation of the model's own equations (gyrowheel.studies.steady) has a growing mode.
"""
from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]

from gyrowheel.cli import main as gyrowheel  # noqa: E402
from gyrowheel.studies import read_table  # noqa: E402
from gyrowheel.model.steady import precession_speed  # noqa: E402
from gyrowheel.studies.steady import precession_growth_rate  # noqa: E402

HELPER = "examples/sweeps/steady_precession.py"
PAPER = dict(M=2.0, R=0.17, k_diam=0.25, k_axial=0.4)
OTHER = dict(PAPER, k_diam=0.3, k_axial=0.45)
GRAVITY = {"earth": 9.81, "mars": 3.721, "moon": 1.625}
COLORS = {"earth": "tab:blue", "mars": "tab:red", "moon": "tab:gray"}
FIG5_BETA, FIG6_RHO = 80.0, 1.0

SWEEPS = {
    "fig5": ["--grid", "g=earth,mars,moon", "--grid", f"beta_deg={FIG5_BETA:g}", "--grid", "rho=0.05:3:25"],
    "fig6": ["--grid", "g=earth,mars,moon", "--grid", f"rho={FIG6_RHO:g}", "--grid", "beta_deg=45:89:23"],
    "region_paper": ["--grid", "beta_deg=60:89:30", "--grid", "rho=0.05:3:30:log"],
    "region_k030_045": ["--grid", "beta_deg=60:89:30", "--grid", "rho=0.05:3:30:log",
                        "--set", "k_diam=0.3", "--set", "k_axial=0.45"],
}


def command(name: str, out: Path, execution: list[str]) -> list[str]:
    return ["sweep", "examples/scenes/paper_earth.toml", *SWEEPS[name], "--derive", f"{HELPER}:start",
            "--metric-function", f"{HELPER}:steadiness", "--metrics", "survived", "--stop-time", "10",
            "--output-interval", "0.02", *execution, "-o", str(out / f"steady_{name}.parquet")]


def unstable_spans(x: np.ndarray, growth: np.ndarray):
    """Contiguous x intervals where growth > 0 (for axvspan)."""
    bad = growth > 1e-6
    spans, start = [], None
    for i, b in enumerate(bad):
        if b and start is None:
            start = i
        if start is not None and (not b or i == len(bad) - 1):
            spans.append((x[start], x[i]))
            start = None
    return spans


def _points(ax, sub, x, model_v):
    steady = sub["steady"].fillna(False).astype(bool) & (sub["status"] == "ok")
    ax.plot(sub.loc[steady, x], sub.loc[steady, "v_sim"], "o", mfc="none", color="k", ms=5)
    ax.plot(sub.loc[~steady, x], model_v[~steady.values], "x", color="k", ms=6)


def plot(tables: dict, png: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(12, 9), constrained_layout=True)
    ax5, ax6, axp, axo = axes.ravel()
    rho = np.linspace(0.05, 3, 300)
    beta = np.radians(np.linspace(45, 89, 300))
    growth5 = np.array([precession_growth_rate(math.radians(FIG5_BETA), r, g=9.81, **PAPER) for r in rho])
    growth6 = np.array([precession_growth_rate(b, FIG6_RHO, g=9.81, **PAPER) for b in beta])
    for a, b in unstable_spans(rho, growth5):
        ax5.axvspan(a, b, color="orange", alpha=0.25, label="steady precession unstable (linearised)")
    for a, b in unstable_spans(np.degrees(beta), growth6):
        ax6.axvspan(a, b, color="orange", alpha=0.25, label="steady precession unstable (linearised)")
    for name, g in GRAVITY.items():
        ax5.plot(rho, precession_speed(math.radians(FIG5_BETA), rho, g=g, **PAPER), color=COLORS[name],
                 label=f"{name}, eq. (53)")
        ax6.plot(np.degrees(beta), precession_speed(beta, FIG6_RHO, g=g, **PAPER), color=COLORS[name],
                 label=f"{name}, eq. (53)")
        s5 = tables["fig5"][tables["fig5"]["g"] == name]
        _points(ax5, s5, "rho", precession_speed(math.radians(FIG5_BETA), s5["rho"].values, g=g, **PAPER))
        s6 = tables["fig6"][tables["fig6"]["g"] == name]
        _points(ax6, s6, "beta_deg", precession_speed(np.radians(s6["beta_deg"].values), FIG6_RHO, g=g, **PAPER))
    for ax in (ax5, ax6):
        ax.plot([], [], "o", mfc="none", color="k", label="simulated, stayed steady: mean speed")
        ax.plot([], [], "x", color="k", label="simulated, left the steady motion")
        ax.set_ylabel("centre speed v [m/s]")
        ax.legend(fontsize=8)
    ax5.set(xlabel=r"radius of the centre's circle $\rho$ [m]", title=rf"Fig. 5: $\beta$ = {FIG5_BETA:g} deg")
    ax6.set(xlabel=r"lean $\beta$ [deg] (90 = upright)", title=rf"Fig. 6: $\rho$ = {FIG6_RHO:g} m")
    for ax, key, wheel, label in ((axp, "region_paper", PAPER, "paper wheel (k 0.25 / 0.4)"),
                                  (axo, "region_k030_045", OTHER, "k 0.3 / 0.45")):
        rr = np.geomspace(0.05, 3, 120)
        bb = np.radians(np.linspace(60, 89, 120))
        G = np.array([[precession_growth_rate(b, r, g=9.81, **wheel) for r in rr] for b in bb])
        G = G / math.sqrt(9.81 / wheel["R"])
        mesh = ax.pcolormesh(rr, np.degrees(bb), np.where(G > 1e-6, G, np.nan), shading="nearest", cmap="Oranges",
                             vmin=0, vmax=1)
        ax.contour(rr, np.degrees(bb), G, levels=[1e-6], colors="darkorange", linewidths=1.5)
        t = tables[key]
        steady = t["steady"].fillna(False).astype(bool) & (t["status"] == "ok")
        ax.plot(t.loc[steady, "rho"], t.loc[steady, "beta_deg"], ".", color="tab:green", ms=3,
                label="simulated: stayed steady")
        ax.plot(t.loc[~steady, "rho"], t.loc[~steady, "beta_deg"], "x", color="k", ms=3,
                label="simulated: left the steady motion")
        ax.set(xscale="log", xlabel=r"$\rho$ [m]", ylabel=r"$\beta$ [deg]",
               title=f"unstable steady precession, {label}")
        ax.legend(fontsize=8, loc="lower left")
    axo.plot([0.2], [85.0], "*", color="magenta", ms=14, label="85 deg, 0.2 m (docs/model.md)")
    axo.legend(fontsize=8, loc="lower left")
    fig.colorbar(mesh, ax=[axp, axo], label=r"linearised growth rate / $\sqrt{g/R}$ (any g)")
    fig.savefig(png, dpi=110)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int)
    ap.add_argument("--scheduler")
    ap.add_argument("--out", default="results/sweeps", help="directory for the tables")
    ap.add_argument("--png", help="the figure (default: OUT/sweep_paper_figs_5_6.png; "
                    "docs/img/sweep_paper_figs_5_6.png is this figure)")
    ap.add_argument("--record", help="also write the counts of runs, steady runs and agreements with the "
                    "linearisation as JSON (make figures: docs/img/sweep_paper_figs_5_6.json)")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    args.png = args.png or str(out / "sweep_paper_figs_5_6.png")
    execution = (["--scheduler", args.scheduler] if args.scheduler else
                 ["--workers", str(args.workers)] if args.workers is not None else [])
    tables = {}
    for name in SWEEPS:
        argv = command(name, out, execution)
        print("gyrowheel " + shlex.join(argv))
        code = gyrowheel(argv)
        if code:
            return code
        tables[name] = read_table(out / f"steady_{name}.parquet")
    plot(tables, Path(args.png))
    print(f"wrote {args.png}")
    counts = agreement(tables)
    for name, c in counts.items():
        print(f"{name}: {c['runs']} runs, {c['steady']} stayed steady, {c['failed']} failed; simulation agrees "
              f"with the linearisation on {c['agree']}")
    if args.record:
        Path(args.record).write_text(json.dumps(counts, indent=1) + "\n")
        print(f"wrote {args.record}")
    return 0


def agreement(tables: dict) -> dict:
    """Per sweep: runs, runs that stayed steady, failed runs, and runs where the simulation and
    the linearisation (a growing mode or not) agree."""
    counts = {}
    for name, t in tables.items():
        wheel = OTHER if name == "region_k030_045" else PAPER
        g = t["g"].map(GRAVITY) if "g" in t else 9.81
        t = t.assign(g_value=g)
        linear = np.array([precession_growth_rate(math.radians(b), r, g=gv, **wheel) <= 1e-6
                           for b, r, gv in zip(t["beta_deg"], t["rho"], t["g_value"])])
        simulated = t["steady"].fillna(False).astype(bool).values
        counts[name] = dict(runs=len(t), steady=int(simulated.sum()), failed=int((t["status"] != "ok").sum()),
                            agree=int((linear == simulated).sum()))
    return counts


if __name__ == "__main__":
    sys.exit(main())
