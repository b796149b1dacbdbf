"""The real-time figures of docs/c_api.md, regenerated: the paper scene exported with
`gyrowheel export-c` in both formulations (reduced, the default, and Lagrange multipliers), each
export's examples/realtime.c built with the C compiler and run: a fixed-step loop at 1 kHz for
10^6 steps (1000 s simulated) with every explicit solver, then RK4 paced to the wall clock.
Prints a markdown table (and writes it to OUT/realtime.md).

    python examples/c_realtime.py [--steps 1000000] [--paced-steps 10000] [--fifo] [--out results/c]

Every figure of one table comes from one run on one machine; the cost per step depends on the
machine and on what else runs on it (see docs/c_api.md, "Reading the numbers").
--fifo runs the paced loop with SCHED_FIFO priority 50 (chrt; needs the right to).
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from pathlib import Path

from gyrowheel.fmu_build.compiler import OPTIMISE, STANDARD, WARNINGS, compiler  # noqa: E402
from gyrowheel.fmu_build.export_c import export_c  # noqa: E402
from gyrowheel.fmu_build.scene import load_scene, parse_scene  # noqa: E402

SCENE = Path(__file__).resolve().parent / "scenes" / "paper_earth.toml"


def build(formulation: str, out: Path) -> Path:
    """Export the paper scene in `formulation` and build its real-time example; the binary."""
    scene = load_scene(SCENE)
    if formulation != scene.formulation:
        text = scene.source.replace('name = "paper_earth"',
                                    f'name = "paper_earth_{formulation}"\nformulation = "{formulation}"')
        scene = parse_scene(text, str(SCENE))
    directory = out / scene.name
    if directory.exists():
        shutil.rmtree(directory)
    export_c(scene, directory, check=False)
    exe = out / f"{scene.name}_realtime"
    subprocess.run([compiler(), *STANDARD, *WARNINGS, *OPTIMISE, f"-I{directory}", str(directory / "examples" / "realtime.c"),
                    str(directory / f"{scene.name}.c"), "-lm", "-o", str(exe)], check=True)
    return exe


def run(cmd: list[str]) -> tuple[str, list[dict[str, str]]]:
    """The program's report and its RESULT lines as dicts."""
    proc = subprocess.run(cmd, capture_output=True, text=True, check=True)
    rows = []
    for line in proc.stdout.splitlines():
        if line.startswith("RESULT solver="):
            rows.append(dict(kv.split("=", 1) for kv in line.split()[1:]))
    return proc.stdout, rows


def table(rows: list[tuple[str, str, dict[str, str]]]) -> str:
    head = ("| formulation | solver | loop | RHS/step | energy drift | error at 20 s | error at end | "
            "constraint violation [m/s] | wall p50 / p99.9 / max [us] | CPU p50 / p99.9 / max [us] |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for formulation, loop, r in rows:
        fmt = lambda k: f"{float(r[k]):.2e}" if r[k] != "nan" else "-"  # noqa: E731
        ended = " (fell)" if r["terminated"] == "1" else ""
        lines.append(
            f"| {formulation} | {r['solver']} | {loop}, {int(r['steps']):,} steps{ended} | "
            f"{float(r['rhs_per_step']):.2f} | {fmt('energy_drift')} | {fmt('err_20')} | {fmt('err_end')} | "
            f"{fmt('violation')} | "
            f"{float(r['wall_p50_us']):.2f} / {float(r['wall_p999_us']):.2f} / {float(r['wall_max_us']):.0f} | "
            f"{float(r['cpu_p50_us']):.2f} / {float(r['cpu_p999_us']):.2f} / {float(r['cpu_max_us']):.0f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=1_000_000, help="steps of the back-to-back loops")
    ap.add_argument("--paced-steps", type=int, default=10_000, help="steps of the paced RK4 loop (0: none)")
    ap.add_argument("--fifo", action="store_true", help="paced loop with SCHED_FIFO (chrt -f 50)")
    ap.add_argument("--out", default="results/c", help="directory for the exports, binaries and realtime.md")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, reports = [], []
    for formulation in ("reduced", "multipliers"):
        exe = build(formulation, out)
        cmd = [str(exe), "--steps", str(args.steps)] + (["--compare"] if formulation == "reduced" else [])
        report, results = run(cmd)
        reports.append(report)
        rows += [(formulation, "back to back", r) for r in results]
        if formulation == "reduced" and args.paced_steps > 0:
            paced = [str(exe), "--steps", str(args.paced_steps), "--paced", "--mlock"]
            if args.fifo:
                paced = ["chrt", "-f", "50", *paced]
            report, results = run(paced)
            reports.append(report)
            for r in results:
                late = f"paced{' FIFO' if args.fifo else ''} (late <= {float(r['max_wake_late_us']):.0f} us, {r['misses']} missed)"
                rows.append((formulation, late, r))
    text = table(rows)
    print("\n".join(reports))
    print(text)
    (out / "realtime.md").write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
