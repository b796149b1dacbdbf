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
import json
import math
import shlex
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]

from gyrowheel.cli import main as gyrowheel  # noqa: E402
from gyrowheel.studies import read_table  # noqa: E402
from gyrowheel.studies.plot import binned_fraction, wilson  # noqa: E402

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


def success_panel(ax, ok, name: str, nominal: float, s: dict, horizon: float) -> None:
    """Success fraction in 10 bins of one uncertain value's deviation from nominal, each with its 95%
    Wilson interval; the overall rate and its interval as the grey band."""
    rel = (ok[name].astype(float) / nominal - 1) * 100
    c, frac, lo, hi = binned_fraction(rel, ok["survived"].astype(float))
    ax.axhspan(s["lo"], s["hi"], color="0.85", label=f"all runs: {100 * s['success']:.1f}%")
    ax.errorbar(c, frac, yerr=[np.maximum(frac - lo, 0), np.maximum(hi - frac, 0)], fmt="o-", ms=4, capsize=3,
                label="runs in the bin")  # at 0% or 100% the interval's end is the rate, to rounding
    ax.set(xlabel=f"{name}: deviation from nominal {nominal:g} [%]", ylim=(-0.02, 1.02),
           ylabel=f"success fraction ({horizon:g} s, 95% interval)")
    ax.grid(True, alpha=0.3)


def outcome_panel(ax, ok, horizon: float, title: str) -> None:
    """The fall times of the runs that fell; when none fell, the largest lean of every run."""
    fell = ok.loc[~ok["survived"].astype(bool), "fall_time"].astype(float)
    if len(fell):
        ax.hist(fell, bins=40, range=(0, horizon), color="tab:red")
        ax.set(xlabel="fall time of the runs that fell [s]", ylabel="runs", title=f"{title}, {len(fell)} fell")
    else:
        ax.hist(np.degrees(ok["max_lean"].astype(float)), bins=30, color="tab:blue")
        ax.set(xlabel="largest lean from upright [deg]", ylabel="runs", title=f"{title}, none fell")


def plot(table, png: Path, s: dict, title: str, horizon: float) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = table[table["status"] == "ok"]
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5), constrained_layout=True)
    outcome_panel(axes[0, 0], ok, horizon,
                  f"success {100 * s['success']:.1f}% [{100 * s['lo']:.1f}, {100 * s['hi']:.1f}]\nof {s['n']} runs")
    nominal = {n: v for n, v in NOMINAL.items() if n in table.columns}
    for ax in axes.ravel()[1 + len(nominal):]:
        ax.axis("off")
    for ax, name in zip(axes.ravel()[1:], nominal):
        success_panel(ax, ok, name, nominal[name], s, horizon)
    axes[0, 1].legend(loc="lower left", fontsize=8)
    fig.suptitle(f"{title}\nsuccess = above 30 deg for {horizon:g} s; worst lean of a success "
                 f"{s['worst_lean_deg']:.1f} deg from upright ({s['failed']} inadmissible samples)")
    fig.savefig(png, dpi=110)
    plt.close(fig)


def report_closed_loop(table, png: Path, horizon: float) -> dict:
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
        outcome_panel(row[0], ok, horizon,
                      f"{start}: success {100 * s['success']:.1f}% [{100 * s['lo']:.1f}, {100 * s['hi']:.1f}]\n"
                      f"of {s['n']} runs")
        for ax, name in zip(row[1:], CLOSED_LOOP_NOMINAL):
            success_panel(ax, ok, name, CLOSED_LOOP_NOMINAL[name], s, horizon)
        row[1].legend(loc="best", fontsize=8)
    fig.suptitle("Gyrover closed loop, earth mission 60 s, fixed nominal gains; wheel mass and inertia "
                 "uniform +/-20%; success = above 30 deg for the whole run")
    fig.savefig(png, dpi=100)
    plt.close(fig)
    print(f"wrote {png}")
    return {f"lean_deg={lean:g}": s for lean, s in cases.items()}


def samples_of(table, nominal: dict, count: int = 3) -> list[dict]:
    """The first `count` admissible points that survived and the first `count` that fell: their
    uncertain values and outcome, for a rerun that checks the figure is not stale."""
    ok = table[table["status"] == "ok"]
    picked = [ok[ok["survived"].astype(bool)].head(count), ok[~ok["survived"].astype(bool)].head(count)]
    rows = []
    for part in picked:
        for _, r in part.iterrows():
            fall = float(r["fall_time"])
            rows.append({**{n: float(r[n]) for n in nominal}, "survived": bool(r["survived"]),
                         "fall_time": None if math.isnan(fall) else fall})
    return rows


def write_record(path: Path, argv: list[str], summary_: dict, samples: list[dict]) -> None:
    """The numbers the figure shows (and docs/sweeps.md quotes) as JSON, with the command that made them."""
    def rounded(v):
        return {k: rounded(x) for k, x in v.items()} if isinstance(v, dict) else (
            (None if math.isnan(v) else round(v, 6)) if isinstance(v, float) else v)
    argv = [a if not a.startswith(str(ROOT)) else str(Path(a).relative_to(ROOT)) for a in argv]
    argv = argv[:-1] + [Path(argv[-1]).name]  # the table's directory is the caller's
    record = {"command": "gyrowheel " + shlex.join(argv), "summary": rounded(summary_), "samples": samples}
    path.write_text(json.dumps(record, indent=1) + "\n")
    print(f"wrote {path}")


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
    ap.add_argument("--record", help="also write the figure's numbers as JSON (make figures: "
                    "docs/img/sweep_monte_carlo[_closed_loop].json, which docs/sweeps.md quotes)")
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
        cases = report_closed_loop(table, png, horizon)
        if args.record:
            write_record(Path(args.record), argv, cases, [])
        return 0
    s = summary(table)
    print(f"success (above 30 deg for {horizon:g} s): {100 * s['success']:.1f}% of {s['n']} runs "
          f"(95% interval {100 * s['lo']:.1f}-{100 * s['hi']:.1f}%), {s['failed']} failed; "
          f"lean from upright of the successes: worst {s['worst_lean_deg']:.1f} deg, 95th percentile "
          f"{s['p95_lean_deg']:.1f} deg; median fall time {s['median_fall']:.2f} s")
    plot(table, png, s, title, horizon)
    print(f"wrote {png}")
    if args.record:
        write_record(Path(args.record), argv, s, samples_of(table, nominal))
    return 0


if __name__ == "__main__":
    sys.exit(main())
