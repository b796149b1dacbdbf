"""Cost of the contact modes: a sliding and a bouncing scene, per simulated second and per event,
against the soft-contact reference in the same run (docs/effects.md, "Flight").

    .venv/bin/python benchmarks/contact_cost.py        (about a minute: two FMU builds)

Scenes: examples/scenes/ice_slide.toml (slides, then rolls: 3 switches in 5 s) and
examples/scenes/drop_bounce.toml (11 impacts, then standing; 1 s), each run with fmpy in
Co-Simulation at the scene's rel_tol, the best of REPEAT runs (wall time, fmpy's overhead
included). The reference: tests/reference/soft_contact_scenarios.drop() of the same wheel and
drop (scipy's solve_ivp, kappa 1e6 1/s^2, rtol 1e-8).
"""
from __future__ import annotations

import re
import sys
import tempfile
import time
from pathlib import Path

from fmpy import simulate_fmu

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
from gyrowheel.fmu_build import build_fmu, load_scene  # noqa: E402
from reference.soft_contact_scenarios import drop  # noqa: E402

REPEAT = 5


def timed_scene(name: str, tmp: Path) -> tuple[float, float, int]:
    """(simulated s, best wall s, events) of an example scene's FMU."""
    scene = load_scene(ROOT / "examples" / "scenes" / f"{name}.toml")
    fmu = str(build_fmu(scene, tmp / f"{name}.fmu", build_dir=tmp / name).fmu)
    stop = scene.experiment.stop_time
    best, events = float("inf"), 0
    for _ in range(REPEAT):
        logs: list[str] = []

        def logger(*args):
            text = args[-1]
            logs.append(text.decode() if isinstance(text, bytes) else str(text))
        t0 = time.perf_counter()
        simulate_fmu(fmu, stop_time=stop, debug_logging=True, logger=logger)
        best = min(best, time.perf_counter() - t0)
        events = sum(1 for line in logs if re.search(r"event \w+ at t=", line))
    return stop, best, events


def main() -> None:
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        rows = [(name, *timed_scene(name, tmp)) for name in ("ice_slide", "drop_bounce")]
    t0 = time.perf_counter()
    ref = drop(0.1, 0.5, stiffness=1e6, t_end=1.0)
    ref_wall = time.perf_counter() - t0
    rows.append(("soft reference drop (kappa 1e6)", 1.0, ref_wall, len(ref["touchdowns"])))
    print("| run | simulated (s) | wall (s) | per simulated s (ms) | events | per event (ms) |")
    print("|---|---|---|---|---|---|")
    for name, stop, wall, events in rows:
        per_event = f"{1e3 * wall / events:.2f}" if events else "-"
        print(f"| {name} | {stop:g} | {wall:.3f} | {1e3 * wall / stop:.2f} | {events} | {per_event} |")


if __name__ == "__main__":
    main()
