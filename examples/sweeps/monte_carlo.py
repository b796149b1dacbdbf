"""Monte Carlo robustness of the paper's unactuated scenario: mass, inertia and friction +/-20%.

    python examples/sweeps/monte_carlo.py [--samples 2000] [--workers N | --scheduler ADDRESS]

The paper's earth start (beta0 = 80 deg, gamma_dot0 = 6 rad/s) on the wheel of
examples/scenes/paper_earth_friction.toml (rolling resistance c_rr = 0.003, pivot friction
c_pivot = 1e-3 m), every uncertain value drawn uniformly within +/-20% of nominal. Success: in
the paper's 20 s the wheel never leans lower than 30 deg above the ground (beta_min = 30 deg, the
fall threshold of the stability map). Samples that break I_axial <= 2 I_diam (possible for any
rigid body) are refused by the FMU and stay in the table as failed rows with that reason; the
rates are over the admissible samples (uniform over the admissible part of the box). Prints the success rate (95% Wilson interval)
and the worst lean; draws docs/img/sweep_monte_carlo.png.

The sweep's source can be any target (fmu_build.sweep.target): once the closed-loop system of
issue 9 exists, pass its target instead of the scene and the same study measures the controller.
"""
from __future__ import annotations

import argparse
import math
import shlex
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from fmu_build.cli import main as gyrowheel  # noqa: E402
from fmu_build.sweep import read_table  # noqa: E402

NOMINAL = dict(M=2.0, k_diam=0.25, k_axial=0.4, c_rr=0.003, c_pivot=0.001)
SPREAD = 0.2


def command(out: Path, samples: int, seed: int, execution: list[str], source: str) -> list[str]:
    randoms = []
    for name, value in NOMINAL.items():
        randoms += ["--random", f"{name}=uniform:{value * (1 - SPREAD):.6g}:{value * (1 + SPREAD):.6g}"]
    return ["sweep", source, *randoms, "--samples", str(samples), "--seed", str(seed),
            "--set", "beta_min_deg=30", "--stop-time", "20", "--output-interval", "0.01", "--metrics", "survived,fall_time,max_lean,min_beta",
            *execution, "-o", str(out)]


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95% Wilson score interval of a success rate k/n."""
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def summary(table) -> dict:
    ok = table[table["status"] == "ok"]
    k, n = int(ok["survived"].sum()), len(ok)
    lo, hi = wilson(k, n)
    survivors = ok[ok["survived"].astype(bool)]
    lean = np.degrees(survivors["max_lean"]) if len(survivors) else np.array([math.nan])
    return dict(n=n, failed=len(table) - n, success=k / n, lo=lo, hi=hi, worst_lean_deg=float(np.max(lean)),
                p95_lean_deg=float(np.percentile(lean, 95)), median_fall=float(ok["fall_time"].median()))


def plot(table, png: Path, s: dict) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = table[table["status"] == "ok"].copy()
    ok["t_end"] = ok["fall_time"].fillna(20.0)
    ok = ok.astype({"max_lean": float})
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5), constrained_layout=True)
    ax = axes[0, 0]
    ax.hist(ok["t_end"], bins=40, color="tab:blue")
    ax.axvline(20.0, color="k", ls="--")
    ax.set(xlabel="fall time [s] (20: success)", ylabel="runs",
           title=f"success {100 * s['success']:.1f}% [{100 * s['lo']:.1f}, {100 * s['hi']:.1f}] of {s['n']}")
    for ax, name in zip(axes.ravel()[1:], NOMINAL):
        rel = (ok[name] / NOMINAL[name] - 1) * 100
        sc = ax.scatter(rel, ok["t_end"], c=np.degrees(ok["max_lean"]), s=6, cmap="viridis")
        corr = np.corrcoef(rel, ok["t_end"])[0, 1]
        ax.set(xlabel=f"{name}: deviation from nominal {NOMINAL[name]:g} [%]", ylabel="fall time [s] (20: success)",
               title=f"correlation {corr:+.2f}")
    fig.colorbar(sc, ax=axes, label="largest lean from upright [deg]")
    fig.suptitle("Unactuated paper scenario on earth, mass / inertia / friction uniform +/-20%: "
                 f"worst lean of a success {s['worst_lean_deg']:.1f} deg from upright ({s['failed']} inadmissible samples)")
    fig.savefig(png, dpi=110)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", type=int)
    ap.add_argument("--scheduler")
    ap.add_argument("--source", default="examples/scenes/paper_earth_friction.toml",
                    help="scene, FMU (later: the closed-loop system)")
    ap.add_argument("--out", default="results/sweeps", help="directory for the table")
    ap.add_argument("--png", default=str(ROOT / "docs" / "img" / "sweep_monte_carlo.png"))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    execution = (["--scheduler", args.scheduler] if args.scheduler else
                 ["--workers", str(args.workers)] if args.workers is not None else [])
    argv = command(out / "monte_carlo.parquet", args.samples, args.seed, execution, args.source)
    print("gyrowheel " + shlex.join(argv))
    code = gyrowheel(argv)
    if code:
        return code
    table = read_table(out / "monte_carlo.parquet")
    s = summary(table)
    print(f"success (above 30 deg for 20 s): {100 * s['success']:.1f}% of {s['n']} runs "
          f"(95% interval {100 * s['lo']:.1f}-{100 * s['hi']:.1f}%), {s['failed']} failed; "
          f"lean from upright of the successes: worst {s['worst_lean_deg']:.1f} deg, 95th percentile "
          f"{s['p95_lean_deg']:.1f} deg; median fall time {s['median_fall']:.2f} s")
    plot(table, Path(args.png), s)
    print(f"wrote {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
