"""The run's budget of internal steps at a stiff onset (docs/fmi.md, "Bounded calls"; docs/hard_cases.md,
family 11).

    .venv/bin/python benchmarks/run_budget.py        (about 1 min: one FMU build, two runs)

examples/scenes/euler_disk_end.toml run with DOPRI5 (its own solver is rosenbrock) in 1 ms
communication steps, the stop time 12 s given to fmi2SetupExperiment, as `gyrowheel simulate
--set solver=dopri5` runs it. The slip onset at 3.519 s holds DOPRI5 at its stability bound.
Prints, from the FMU's solver log (accepted + rejected steps of every fmi2DoStep):
- with the default budget (max_internal_steps 1e6): where the run's budget refuses the rest, the
  internal steps of the whole run, the wall time;
- with the largest budget (2^31 - 1, the run's budget then ~2e11 steps, out of reach): the steps
  and the wall time of each of the 5 communication steps after the onset, and the rest of the run
  projected from them (steps per second of simulated time times the 8.5 s to go).
"""
from __future__ import annotations

import re
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
from fmi_helpers import Slave  # noqa: E402
from gyrowheel.fmu_build import build_fmu, load_scene  # noqa: E402

DOPRI5, STOP, H, ONSET = 3, 12.0, 0.001, 3.518


def steps(text: str) -> int:
    return sum(int(a) + int(b) for a, b in re.findall(r"accepted=(\d+) rejected=(\d+)", text))


def run(fmu: Path, budget: int, n_after: int | None) -> None:
    s = Slave(fmu)
    try:
        s.init(stop_time=STOP, solver=DOPRI5, max_internal_steps=budget)
        start = time.perf_counter()
        s.slave.doStep(0.0, ONSET)
        t, k = ONSET, 0
        while t < STOP - H / 2 and (n_after is None or k < n_after):
            before, wall = len(s.messages), time.perf_counter()
            try:
                s.slave.doStep(t, H)
            except Exception:
                print(f"budget {budget}: refused at t = {t:.4f} s, {steps(s.log_text())} internal steps in all, "
                      f"{time.perf_counter() - start:.1f} s wall")
                print("  " + next(m for _, _, m in reversed(s.messages) if "budget" in m)[:160] + " ...")
                return
            t, k = t + H, k + 1
            if n_after is not None:
                n = steps("\n".join(m for _, _, m in s.messages[before:]))
                print(f"budget {budget}: step to t = {t:.4f} s: {n} internal steps, {time.perf_counter() - wall:.2f} s "
                      f"wall; the rest at this rate: {n * (STOP - t) / H:.2g} steps")
    finally:
        s.free()


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        fmu = build_fmu(load_scene(ROOT / "examples" / "scenes" / "euler_disk_end.toml"),
                        Path(tmp) / "euler_disk_end.fmu", build_dir=Path(tmp) / "build").fmu
        run(fmu, 1_000_000, None)
        run(fmu, 2**31 - 1, 5)


if __name__ == "__main__":
    main()
