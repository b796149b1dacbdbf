"""Every solver of the FMU with the contact modes: the errors at the switches against closed forms
(docs/runtime.md, "Contact modes with each solver").

    .venv/bin/python benchmarks/contact_solvers.py        (about 40 s: one FMU build)

One FMU, examples/scenes/drop_bounce.toml built with the Taylor kernel, run in Co-Simulation
(fmpy, rel_tol 1e-12, abs_tol 1e-14) with each solver; rk4 and euler with max_step 1e-4 s. Cases:
- backspin: upright, v0 = 2 m/s, gamma_dot0 = -5 rad/s, mu_k = 0.25: the switch to rolling
  against t* = |s0| / (mu_k g (1 + 1/k_axial)) and the speed after against
  v* = (v0 + k_axial R gamma_dot0) / (1 + k_axial);
- drop: upright, h = 0.1 m, e = 0.5: the rest (last impact) against the truncated series' time
  (tests/test_contact_flight.py, drop_series) and the largest apex error against e^(2k) h;
- ice: leaning 80 deg, gamma_dot0 = 8 rad/s, mu = 0.1, mu_k = 0.08, 3 s: the switches, their
  largest distance from DOPRI5's, and the number of switches.
"""
from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
from fmi_helpers import simulate_logged  # noqa: E402
from gyrowheel.fmu_build import build_fmu, load_scene  # noqa: E402
from paper_wheel import G, KA, R  # noqa: E402
from test_contact_flight import drop_series  # noqa: E402

TIGHT = {"rel_tol": 1e-12, "abs_tol": 1e-14}
SOLVERS = {"dopri5": {"solver": 3}, "dop853": {"solver": 5}, "rosenbrock": {"solver": 4}, "taylor": {"solver": 6},
           "rk4 (max_step 1e-4)": {"solver": 2, "max_step": 1e-4},
           "euler (max_step 1e-4)": {"solver": 1, "max_step": 1e-4}}
OUT = ["vx", "vz", "height", "contact_mode", "slip_long"]


def backspin(fmu: str, solver: dict) -> tuple[float, float]:
    v0, w0, mu_k = 2.0, -5.0, 0.25
    s0 = v0 - R * w0
    t_star = abs(s0) / (mu_k * G * (1 + 1 / KA))
    r, events = simulate_logged(fmu, 0.6, 0.01, OUT, {**TIGHT, **solver, "beta": math.pi / 2, "gamma_dot": w0,
                                                       "slip_long": s0, "mu_k": mu_k, "height": 0.0})
    return events[0][1] - t_star, r["vx"][-1] / ((v0 + KA * R * w0) / (1 + KA)) - 1


def drop(fmu: str, solver: dict) -> tuple[float, float]:
    h, e = 0.1, 0.5
    _, rest, _, _ = drop_series(h, e)
    r, events = simulate_logged(fmu, 0.5, 0.001, OUT, {**TIGHT, **solver, "height": h, "restitution": e})
    times = [t for name, t in events if name == "contact_flight"]
    t, worst = r["time"], 0.0
    for k in range(1, len(times) - 1):
        inside = (t > times[k - 1] + 1e-6) & (t < times[k] - 1e-6)
        if inside.any():
            apex = r["height"][inside] + r["vz"][inside] ** 2 / (2 * G)
            worst = max(worst, float(np.max(np.abs(apex - e ** (2 * k) * h))))
    return times[-1] - rest, worst, len(times)


def ice(fmu: str, solver: dict) -> list[float]:
    _, events = simulate_logged(fmu, 3.0, 0.01, OUT, {**TIGHT, **solver, "beta": math.radians(80), "gamma_dot": 8.0,
                                                       "mu": 0.1, "mu_k": 0.08, "height": 0.0})
    return [t for _, t in events]


def main() -> None:
    with tempfile.TemporaryDirectory() as d:
        fmu = str(build_fmu(load_scene(ROOT / "examples" / "scenes" / "drop_bounce.toml"), Path(d) / "hybrid.fmu",
                            taylor=True).fmu)
        reference = ice(fmu, SOLVERS["dopri5"])
        print("| solver | backspin: switch - t* (s) | v / v* - 1 | drop: impacts | rest - series (s) | apex error (m) "
              "| ice: switches | ice: switch times - DOPRI5's (s) |")
        print("|---|---|---|---|---|---|---|---|")
        for name, solver in SOLVERS.items():
            dt, dv = backspin(fmu, solver)
            rest, apex, impacts = drop(fmu, solver)
            times = ice(fmu, solver)
            n = min(len(times), len(reference))
            off = max(abs(a - b) for a, b in zip(times[:n], reference[:n]))
            print(f"| {name} | {dt:.2g} | {dv:.2g} | {impacts} | {rest:.2g} | {apex:.2g} | {len(times)} | {off:.2g} |")
        print("ice, DOPRI5's switches (s):", ", ".join(f"{t:.10f}" for t in reference))


if __name__ == "__main__":
    main()
