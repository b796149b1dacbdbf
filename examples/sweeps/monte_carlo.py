"""Monte Carlo robustness of the paper's unactuated scenario: mass, inertia and friction +/-20%.

    python examples/sweeps/monte_carlo.py [--samples 2000] [--workers N | --scheduler ADDRESS]

The paper's earth start (beta0 = 80 deg, gamma_dot0 = 6 rad/s) on the wheel of
examples/scenes/paper_earth_friction.toml (rolling resistance c_rr = 0.003, pivot friction
c_pivot = 1e-3 m), every uncertain value drawn uniformly within +/-20% of nominal. Success: in
the paper's 20 s the wheel never leans lower than 30 deg above the ground (beta_min = 30 deg, the
fall threshold of the stability map). Samples that break I_axial <= 2 I_diam (possible for any
rigid body) are refused by the FMU and stay in the table as failed rows with that reason; the
rates are over the admissible samples (uniform over the admissible part of the box). Prints the success rate (95% Wilson interval)
and the worst lean; draws the figure (docs/img/sweep_monte_carlo.png).

--closed-loop: the same study of the Gyrover's closed loop (wheel + gain-scheduled LQG
controller FMUs as an .ssp, built here with gyrowheel.controller.closed_loop.build_closed_loop for the earth
mission scene and course): wheel mass and inertia +/-20% around the design's nominal values (the
controller keeps its nominal gains), the mission's 5 deg lean with zero heading rate, 60 s. That wheel has no friction effects, so friction is not varied there.
"""
from __future__ import annotations

import argparse
import math
import shlex
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]

from gyrowheel.cli import main as gyrowheel  # noqa: E402
from gyrowheel.studies import read_table  # noqa: E402

NOMINAL = dict(M=2.0, k_diam=0.25, k_axial=0.4, c_rr=0.003, c_pivot=0.001)
CLOSED_LOOP_NOMINAL = dict(M=2.0, k_diam=0.25, k_axial=0.4)
SPREAD = 0.2


def command(out: Path, samples: int, seed: int, execution: list[str], source: str, nominal: dict,
            extra: list[str], stop_time: float) -> list[str]:
    randoms = []
    for name, value in nominal.items():
        randoms += ["--random", f"{name}=uniform:{value * (1 - SPREAD):.6g}:{value * (1 + SPREAD):.6g}"]
    return ["sweep", source, *randoms, "--samples", str(samples), "--seed", str(seed),
            "--set", "beta_min_deg=30", *extra, "--stop-time", f"{stop_time:g}", "--output-interval", "0.01",
            "--metrics", "survived,fall_time,max_lean,min_beta", *execution, "-o", str(out)]


def closed_loop_source(out: Path) -> tuple[str, list[str]]:
    """Build the earth mission's closed loop (.ssp); two starts: upright, and the mission's 5 deg lean."""
    from gyrowheel.controller.closed_loop import build_closed_loop
    from gyrowheel.controller.mission import course
    from gyrowheel.fmu_build import load_scene

    loop = build_closed_loop(load_scene(ROOT / "examples/scenes/gyrover_mission_earth.toml"), out / "closed_loop",
                             course("earth"))
    return str(loop.ssp), ["--grid", "lean_deg=0,-5", "--derive", "examples/sweeps/closed_loop_push.py:start"]


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95% Wilson score interval of a success rate k/n."""
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def summary(table) -> dict:
    ok = table[table["status"] == "ok"]
    if "lean_deg" in table and table["lean_deg"].nunique() > 1:
        return {lean: summary(table[table["lean_deg"] == lean].drop(columns="lean_deg"))
                for lean in sorted(table["lean_deg"].unique(), reverse=True)}
    k, n = int(ok["survived"].sum()), len(ok)
    lo, hi = wilson(k, n)
    survivors = ok[ok["survived"].astype(bool)]
    lean = np.degrees(survivors["max_lean"]) if len(survivors) else np.array([math.nan])
    return dict(n=n, failed=len(table) - n, success=k / n, lo=lo, hi=hi, worst_lean_deg=float(np.max(lean)),
                p95_lean_deg=float(np.percentile(lean, 95)), median_fall=float(ok["fall_time"].median()))


def plot(table, png: Path, s: dict, title: str, horizon: float) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = table[table["status"] == "ok"].copy()
    ok["t_end"] = ok["fall_time"].fillna(horizon)
    ok = ok.astype({"max_lean": float})
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5), constrained_layout=True)
    ax = axes[0, 0]
    ax.hist(ok["t_end"], bins=40, color="tab:blue")
    ax.axvline(horizon, color="k", ls="--")
    ax.set(xlabel=f"fall time [s] ({horizon:g}: success)", ylabel="runs",
           title=f"success {100 * s['success']:.1f}% [{100 * s['lo']:.1f}, {100 * s['hi']:.1f}] of {s['n']}")
    nominal = {n: v for n, v in NOMINAL.items() if n in table.columns}
    for ax in axes.ravel()[1 + len(nominal):]:
        ax.axis("off")
    for ax, name in zip(axes.ravel()[1:], nominal):
        rel = (ok[name] / nominal[name] - 1) * 100
        sc = ax.scatter(rel, ok["t_end"], c=np.degrees(ok["max_lean"]), s=6, cmap="viridis")
        corr = np.corrcoef(rel, ok["t_end"])[0, 1]
        ax.set(xlabel=f"{name}: deviation from nominal {nominal[name]:g} [%]", ylabel=f"fall time [s] ({horizon:g}: success)",
               title=f"correlation {corr:+.2f}")
    fig.colorbar(sc, ax=axes, label="largest lean from upright [deg]")
    fig.suptitle(f"{title}: worst lean of a success {s['worst_lean_deg']:.1f} deg from upright "
                 f"({s['failed']} inadmissible samples)")
    fig.savefig(png, dpi=110)
    plt.close(fig)


def report_closed_loop(table, png: Path, horizon: float) -> int:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = summary(table)
    fig, axes = plt.subplots(len(cases), 4, figsize=(15, 3.6 * len(cases)), constrained_layout=True, squeeze=False)
    for row, (lean, s) in zip(axes, cases.items()):
        start = "upright" if lean == 0 else f"{lean:g} deg push"
        print(f"{start}: success (above 30 deg for {horizon:g} s) {100 * s['success']:.1f}% of {s['n']} runs "
              f"(95% interval {100 * s['lo']:.1f}-{100 * s['hi']:.1f}%), {s['failed']} inadmissible; worst lean "
              f"of a success {s['worst_lean_deg']:.2f} deg (95th percentile {s['p95_lean_deg']:.2f} deg)")
        ok = table[(table["status"] == "ok") & (table["lean_deg"] == lean)]
        t_end = ok["fall_time"].fillna(horizon)
        row[0].hist(t_end, bins=30)
        row[0].set(xlabel=f"fall time [s] ({horizon:g}: success)", ylabel="runs",
                   title=f"{start}: success {100 * s['success']:.1f}% [{100 * s['lo']:.1f}, {100 * s['hi']:.1f}]")
        for ax, name in zip(row[1:], CLOSED_LOOP_NOMINAL):
            rel = (ok[name] / CLOSED_LOOP_NOMINAL[name] - 1) * 100
            sc = ax.scatter(rel, t_end, c=np.degrees(ok["max_lean"].astype(float)), s=6, cmap="viridis", vmin=0, vmax=60)
            ax.set(xlabel=f"{name}: deviation from nominal [%]", ylabel="fall time [s]")
    fig.colorbar(sc, ax=axes, label="largest lean from upright [deg]")
    fig.suptitle("Gyrover closed loop, earth mission 60 s, fixed nominal gains; wheel mass and inertia "
                 "uniform +/-20%")
    fig.savefig(png, dpi=100)
    plt.close(fig)
    print(f"wrote {png}")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", type=int)
    ap.add_argument("--scheduler")
    ap.add_argument("--source", default=str(ROOT / "examples" / "scenes" / "paper_earth_friction.toml"),
                    help="scene, FMU or system (.ssp) of the unactuated study")
    ap.add_argument("--closed-loop", action="store_true", help="the Gyrover's closed loop instead (see above)")
    ap.add_argument("--out", default="results/sweeps", help="directory for the table")
    ap.add_argument("--png", help="the figure (default: OUT/sweep_monte_carlo[_closed_loop].png; "
                    "docs/img/ holds these figures)")
    args = ap.parse_args()
    out = Path(args.out)
    png = Path(args.png or out / f"sweep_monte_carlo{'_closed_loop' if args.closed_loop else ''}.png")
    out.mkdir(parents=True, exist_ok=True)
    execution = (["--scheduler", args.scheduler] if args.scheduler else
                 ["--workers", str(args.workers)] if args.workers is not None else [])
    name = "monte_carlo_closed_loop" if args.closed_loop else "monte_carlo"
    if args.closed_loop:
        source, extra = closed_loop_source(out)
        nominal, horizon, title = CLOSED_LOOP_NOMINAL, 60.0, "Gyrover closed loop (earth mission, 5 deg push), " \
            "wheel mass / inertia uniform +/-20%"
    else:
        source, extra, nominal, horizon = args.source, [], NOMINAL, 20.0
        title = "Unactuated paper scenario on earth, mass / inertia / friction uniform +/-20%"
    argv = command(out / f"{name}.parquet", args.samples, args.seed, execution, source, nominal, extra, horizon)
    print("gyrowheel " + shlex.join(argv))
    code = gyrowheel(argv)
    if code:
        return code
    table = read_table(out / f"{name}.parquet")
    if args.closed_loop:
        return report_closed_loop(table, png, horizon)
    s = summary(table)
    print(f"success (above 30 deg for {horizon:g} s): {100 * s['success']:.1f}% of {s['n']} runs "
          f"(95% interval {100 * s['lo']:.1f}-{100 * s['hi']:.1f}%), {s['failed']} failed; "
          f"lean from upright of the successes: worst {s['worst_lean_deg']:.1f} deg, 95th percentile "
          f"{s['p95_lean_deg']:.1f} deg; median fall time {s['median_fall']:.2f} s")
    plot(table, png, s, title, horizon)
    print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
