"""What the paper FMU costs: one RHS evaluation and the 20 s earth scenario.

Every number is printed next to a peer measured in the same run:
- RHS: the generated C (compiled with the FMU's own portable flags) versus the minimal
  hand-written closed form of the wheel (benchmarks/minimal_wheel.h; docs/performance.md's
  target: within 1.2x) and versus the same CasADi Function evaluated by CasADi's virtual machine from Python.
- 20 s scenario at rel_tol 1e-8: one fmi2DoStep(0, 20) of the FMU's DOPRI5, fmpy's
  simulate_fmu with 2001 output points, and CasADi's cvodes integrator on the same model.

    python benchmarks/paper_cost.py
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np
from fmpy import simulate_fmu

from gyrowheel.fmu_build import build_fmu, load_scene

ROOT = Path(__file__).resolve().parent.parent


def best_of(fn, repeat=5):
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def rhs_ns(sources: Path, work: Path, rounds: int = 5) -> tuple[float, float, float]:
    """(generated, minimal hand-written with libm's sin/cos, the same with gw_sincos2) ns per RHS
    evaluation: the best of `rounds` runs of rhs_bench, each timing all in the same process
    (benchmarks/rhs_timing.py)."""
    import rhs_timing
    exe = rhs_timing.build(sources, work / "rhs_bench")
    runs = [rhs_timing.run3(exe) for _ in range(rounds)]
    return min(r[0] for r in runs), min(r[1] for r in runs), min(r[2] for r in runs)


def main() -> None:
    scene = load_scene(ROOT / "examples" / "scenes" / "paper_earth.toml")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        built = build_fmu(scene, work / "earth.fmu", build_dir=work / "build")
        spec = built.spec
        fns = spec.functions()
        p = np.array([q.start for q in spec.parameters])
        x0 = np.array(fns["init"]([q.start for q in spec.starts], p)).ravel()

        c_ns, min_ns, min_fast_ns = rhs_ns(built.sources, work)
        print(f"RHS evaluation: generated C {c_ns:.1f} ns; minimal hand-written closed form {min_ns:.1f} ns "
              f"with libm's sin/cos (ratio {c_ns / min_ns:.2f}), {min_fast_ns:.1f} ns with the runtime's "
              f"gw_sincos2 as the generated code (ratio {c_ns / min_fast_ns:.2f})")
        ode = fns["ode"]
        n = 20000
        vm_ns = best_of(lambda: [ode(0.0, x0, [], p) for _ in range(n)], 3) / n * 1e9
        print(f"RHS evaluation: generated C {c_ns:.1f} ns; CasADi VM from Python {vm_ns:.0f} ns "
              f"(ratio {vm_ns / c_ns:.0f}x); expression: {ode.n_instructions()} instructions")

        from fmi_slave import one_step_seconds
        fmu_s = min(one_step_seconds(built.fmu, 20.0, rel_tol=1e-8, abs_tol=1e-10) for _ in range(7))
        sim_s = best_of(lambda: simulate_fmu(str(built.fmu), stop_time=20.0, output_interval=0.01,
                                             start_values={"rel_tol": 1e-8, "abs_tol": 1e-10}), 3)
        x = ca.SX.sym("x", spec.x.numel())
        dae = {"x": x, "ode": ode(0.0, x, ca.DM.zeros(0, 1), p)}
        cv = ca.integrator("cv", "cvodes", dae, 0.0, 20.0, {"reltol": 1e-8, "abstol": 1e-10})
        cv_s = best_of(lambda: cv(x0=x0), 5)
        print(f"20 s paper scenario, rel_tol 1e-8: fmi2DoStep(0, 20) {fmu_s * 1e3:.2f} ms; "
              f"simulate_fmu with 2001 outputs {sim_s * 1e3:.1f} ms; CasADi cvodes {cv_s * 1e3:.1f} ms "
              f"(cvodes / FMU = {cv_s / fmu_s:.1f}x)")


if __name__ == "__main__":
    import sys
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    main()
