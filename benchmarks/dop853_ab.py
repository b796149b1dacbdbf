"""DOP853 (or another adaptive solver) of this tree against the same solver of another checkout
or git ref (default: the git ref main of this repository) and heyoka, one run.

For each scenario of work_precision.py (paper, long, near_flat) both trees build the FMU of the
same scene with their own fmu_build and c_src; every tolerance is timed for both FMUs in turn
(interleaved, thread CPU time, best of --repeat), heyoka (taylor_adaptive on the FMU's own
expression graph, as benchmarks/taylor_vs_heyoka.py) too.  Error = max abs error of the 8
states at the stop time against heyoka in long double at tol 1e-19.  Prints the cheapest time
to reach each target error and its ratio to heyoka's (< 1: faster than heyoka), plus the RHS
evaluations and rejected steps at a few tolerances.  Ratios come from one run on a shared
machine: re-measure on a quiet one.

    python benchmarks/dop853_ab.py [--ref main | --ref DIR] [--scenarios paper long near_flat] [--solver dopri5]

--ref: a directory holding another checkout, or a git ref of this repository (exported with
`git archive` into a temporary directory), in either layout of the project
(benchmarks/ref_tree.py): the reference's FMU is built by its own code.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from fmi_slave import FmuRunner, solver_counts  # noqa: E402
from ref_tree import RefTree  # noqa: E402
from taylor_vs_heyoka import TARGETS, SameGraph, rows_against_heyoka  # noqa: E402
from work_precision import SCENARIOS, SOLVER_CODES  # noqa: E402

from gyrowheel.fmu_build import build_fmu, parse_scene  # noqa: E402

TOLS = [10.0 ** -k for k in range(3, 15)]


def build_ref(ref: RefTree, name: str, work: Path) -> Path:
    """The scenario's FMU built by the reference's own fmu_build (a subprocess in its tree)."""
    text, _ = SCENARIOS[name]
    scene = f'[model]\nname = "ab_{name}"\n' + text
    ref.python(f"import sys; from pathlib import Path; from {ref.module('gyrowheel.fmu_build')} import build_fmu, "
               "parse_scene; build_fmu(parse_scene(sys.argv[1], sys.argv[2]), Path(sys.argv[3]), "
               "build_dir=Path(sys.argv[4]))", scene, f"{name}.toml", str(work / "ref.fmu"), str(work / "refb"))
    return work / "ref.fmu"


def run(name: str, ref: RefTree, work: Path, repeat: int, solver: str = "dop853") -> list[str]:
    text, stop = SCENARIOS[name]
    work = work / name
    work.mkdir()
    built = build_fmu(parse_scene(f'[model]\nname = "ab_{name}"\n' + text, f"{name}.toml"),
                      work / "new.fmu", build_dir=work / "newb")
    fmus = {"this tree": built.fmu, f"ref ({ref.ref})": build_ref(ref, name, work)}
    g = SameGraph(built, stop)
    names, ref_x = g.names, g.ref
    runners = {k: FmuRunner(v) for k, v in fmus.items()}
    pts: dict[str, list] = {k: [] for k in [*fmus, "heyoka"]}
    for tol in TOLS:
        secs = {k: float("inf") for k in fmus}
        vals = {}
        for _ in range(repeat):  # interleaved: both trees see the same machine load
            for k, r in runners.items():
                vals[k] = r.one_step(stop, names, solver=SOLVER_CODES[solver], rel_tol=tol, abs_tol=tol * 1e-2, max_step=stop)
                secs[k] = min(secs[k], r.last_seconds)
        for k in fmus:
            pts[k].append((secs[k], float(np.max(np.abs(np.array(vals[k]) - ref_x)))))
        pts["heyoka"].append(g.time_heyoka(tol, stop, repeat)[:2])
    for r in runners.values():
        r.free()
    lines = [f"### {name} ({stop:g} s): {solver} (abs_tol = rel_tol/100, max_step = T)", "",
             "| method | " + " | ".join(f"err <= {t:g}" for t in TARGETS) + " | floor |",
             "|---|" + "---|" * (len(TARGETS) + 1)]
    lines += rows_against_heyoka(pts, TARGETS)
    lines += ["", "In brackets: time / heyoka's.", ""]
    for tol in (1e-4, 1e-7, 1e-10, 1e-13):
        cnt = {k: solver_counts(v, stop, solver=SOLVER_CODES[solver], rel_tol=tol, abs_tol=tol * 1e-2, max_step=stop)
               for k, v in fmus.items()}
        lines.append(f"rel_tol {tol:g}: " + "; ".join(f"{k}: {c}" for k, c in cnt.items()))
    return lines + [""]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ref", default="main",
                        help="checkout directory or git ref to compare against (default: main)")
    parser.add_argument("--scenarios", nargs="*", default=["paper", "long", "near_flat"],
                        choices=["paper", "long", "near_flat"])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--solver", default="dop853", choices=["dop853", "dopri5", "rosenbrock"])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="gw-dop853-ab-") as tmp:
        ref = RefTree(args.ref, Path(tmp))
        for name in args.scenarios:
            print("\n".join(run(name, ref, Path(tmp), args.repeat, args.solver)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
