"""What the step size controller costs: RHS evaluations (not time: no noise) to reach each error.

For the paper scenario (and optionally the others) and each adaptive gyrowheel solver, sweeps the
tolerance (rel_tol, abs_tol = rel_tol / 100, max_step = the stop time), reads the accepted and
rejected steps and RHS evaluations of the one fmi2DoStep (logSolver) and the error against heyoka's
long-double reference, and prints the fewest RHS evaluations that reach 1e-4, 1e-7, 1e-10, 1e-12 with
the rejected fraction there, and the error floor.  Used to choose GW_DOP853_BETA / GW_DOPRI5_BETA
(c_src/gw_solver.h): build with -DGW_DOP853_BETA=... is not possible from an FMU, so the study is
re-run after changing the constants.

    python benchmarks/controller_study.py [--scenarios paper long near_flat]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import peers  # noqa: E402
from fmi_slave import solver_counts  # noqa: E402
from work_precision import SCENARIOS, SOLVER_CODES, TARGETS, TOLS, Scenario, wheel_params  # noqa: E402


def study(sc: Scenario, solver: str) -> str:
    rows = []
    for tol in TOLS:
        values = dict(solver=SOLVER_CODES[solver], rel_tol=tol, abs_tol=tol * 1e-2, max_step=sc.stop)
        try:
            counts = solver_counts(sc.fmu, sc.stop, **values)
            states = sc.runner.one_step(sc.stop, sc.state_names, **values)
        except Exception as exc:  # noqa: BLE001 - a tolerance a solver cannot do is reported
            print(f"  {solver} {tol:g}: {exc}", file=sys.stderr)
            continue
        rows.append((tol, float(np.max(np.abs(np.asarray(states) - sc.reference))), counts))
    cells = []
    for target in TARGETS:
        ok = [(c["rhs"], c["rejected"] / max(1, c["accepted"] + c["rejected"])) for _, e, c in rows if e <= target]
        cells.append(f"{min(ok)[0]} ({min(ok)[1]:.0%} rej.)" if ok else "-")
    floor = min(e for _, e, _ in rows)
    return f"| {solver} | " + " | ".join(cells) + f" | {floor:.1e} |"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", nargs="*", default=["paper"], choices=["paper", "long", "near_flat"])
    parser.add_argument("--solvers", nargs="*", default=["dopri5", "dop853"])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenarios:
            text, stop = SCENARIOS[name]
            sc = Scenario(name, text, stop, Path(tmp))
            sc.reference = peers.reference(sc.x0, wheel_params(sc), stop)
            print(f"### {name} ({stop:g} s): fewest RHS evaluations to reach each error\n")
            print("| solver | " + " | ".join(f"{t:.0e}" for t in TARGETS) + " | error floor |")
            print("|---|" + "---|" * (len(TARGETS) + 1))
            for solver in args.solvers:
                print(study(sc, solver))
            print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
