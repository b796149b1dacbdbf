"""What each effect costs: the base wheel, each effect added alone to gravity, all together.

For every effect set the script builds the FMU (sources kept), then measures
- states, FMI outputs (Boolean event flags included) and the CasADi instructions of the
  ode function (before the common-subexpression elimination of code generation);
- ns per RHS evaluation of the generated C (benchmarks/rhs_bench.c compiled against the
  kept sources with the FMU's own flags, as in paper_cost.py), and next to it, measured in
  the same run, the same ode Function evaluated by CasADi's virtual machine from Python;
- ns per fmi2DoStep for communication steps of 1 ms (10 s of simulated time, DOPRI5 at
  rel_tol 1e-8 inside the FMU, called through fmpy's FMU2Slave; only the loop of doStep
  calls is timed, so the figure includes fmpy's Python/ctypes call overhead, printed below the
  table). The runtime ends every internal step on the communication point, so each 1 ms
  doStep costs at least one DOPRI5 step (6 RHS evaluations, FSAL) plus the event indicators.

Scene: the paper wheel (M = 2 kg, R = 0.17 m, k_diam = 0.25, k_axial = 0.4, beta0 = 80 deg)
on earth with gamma_dot0 = 12 rad/s, effects at their defaults. A run that ends early (the
wheel fell, a "terminate" event) is flagged in the table.

    .venv/bin/python benchmarks/effect_costs.py          (about 1 minute on 2 cores)
"""
from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from fmpy import read_model_description

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from fmi_slave import _open, many_steps_seconds  # noqa: E402
from paper_cost import best_of  # noqa: E402

from gyrowheel.fmu_build import build_fmu  # noqa: E402
import rhs_timing  # noqa: E402
from gyrowheel.fmu_build.scene import parse_scene  # noqa: E402
from gyrowheel.model.effects import CATALOGUE  # noqa: E402

STEP = 1e-3  # communication step [s]
N_STEPS = 10000  # 10 s of simulated time: with rolling resistance the wheel falls at 10.7 s
VM_CALLS = 2000
RHS_CALLS = 50000  # per repetition; rhs_bench.c takes the best of 5 repetitions
RHS_RUNS = 4  # runs of rhs_bench per round: many short samples (this VM's speed is bimodal)
ROUNDS = 6

SCENE = """
[model]
name = "{name}"

# [wheel]: the defaults, the paper wheel (M 2 kg, R 0.17 m, k 0.25 / 0.4, beta_min 0.02)

{effects}
[initial]
beta_deg = 80.0
gamma_dot = 12.0

[experiment]
stop_time = 20.0
solver = "dopri5"
rel_tol = 1e-8
abs_tol = 1e-10
max_step = 0.05
"""


def effect_sets() -> list[tuple[str, list[str]]]:
    sets = [("base (gravity)", ["gravity"])]
    sets += [(f"+ {name}", ["gravity", name]) for name in CATALOGUE if name != "gravity"]
    # the Coulomb laws' other law (the default is true stiction: docs/effects.md, "Stiction")
    sets += [(f"+ {name} (law smoothed)", ["gravity", f"{name}:smoothed"]) for name in ("rolling_resistance",
                                                                                      "spin_friction")]
    sets.append(("all effects", list(CATALOGUE)))
    return sets


def scene_for(label: str, effects: list[str]):
    """The scene of an effect set; "name:law" chooses a law (rolling_resistance:smoothed)."""
    ident = "cost_" + "_".join(e for e in effects if e != "gravity") if len(effects) < len(CATALOGUE) else "cost_all"
    ident = ident.replace(":", "_")
    if ident == "cost_":
        ident = "cost_base"
    tables = "[effects.gravity]\ng = \"earth\"\n" + "".join(
        f"[effects.{e}]\n" if ":" not in e else "[effects.{}]\nlaw = \"{}\"\n".format(*e.split(":"))
        for e in effects if e != "gravity")
    return parse_scene(SCENE.format(name=ident, effects=tables), f"<{label}>")


def fmpy_call_overhead_ns(fmu: Path) -> float:
    """ns of one trivial FMI call through FMU2Slave (fmi2GetRealStatus: same wrapper as doStep)."""
    from fmpy.fmi2 import FMU2Slave, fmi2LastSuccessfulTime
    md, unzipdir = _open(fmu)
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier)
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    get, n = s.getRealStatus, 20000
    sec = best_of(lambda: [get(fmi2LastSuccessfulTime) for _ in range(n)], 5)
    s.terminate()
    s.freeInstance()
    return sec / n * 1e9


def rhs_exe(sources: Path, out: Path) -> Path:
    """benchmarks/rhs_bench.c linked against the kept sources, with the FMU's flags (rhs_timing.build)."""
    return rhs_timing.build(sources, out)


def rhs_run_ns(exe: Path) -> float:
    return rhs_timing.run(exe, RHS_CALLS)[0]


def main() -> None:
    t_start = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory(prefix="effect-costs-") as tmp:
        work = Path(tmp)
        for label, effects in effect_sets():
            scene = scene_for(label, effects)
            built = build_fmu(scene, work / f"{scene.name}.fmu", build_dir=work / scene.name)
            spec = built.spec
            md = read_model_description(str(built.fmu))
            fns = spec.functions()
            p = np.array([q.start for q in spec.parameters])
            rows.append(dict(
                label=label, fmu=built.fmu, nx=spec.x.numel(), ode=fns["ode"], p=p,
                u=np.array([q.start for q in spec.inputs]),
                x0=np.array(fns["init"]([q.start for q in spec.starts], p)).ravel(),
                ny=sum(v.causality == "output" for v in md.modelVariables),
                instr=fns["ode"].n_instructions(),
                exe=rhs_exe(built.sources, work / f"rhs_{scene.name}"),
                c_ns=float("inf"), vm_ns=float("inf"), step_s=float("inf")))
        print(f"  built and compiled: {time.perf_counter() - t_start:.0f} s", file=sys.stderr)
        overhead = float("inf")
        # rounds over all effect sets, best of each: spreads the machine's noise evenly
        for r in rows:  # warm-up (CPU clock, caches, the FMUs' first load), not counted
            subprocess.run([str(r["exe"]), "1000"], capture_output=True, check=True)
            many_steps_seconds(r["fmu"], 1000, STEP)
        for rnd in range(ROUNDS):
            for r in rows[rnd % len(rows):] + rows[:rnd % len(rows)]:  # rotated: no set always first
                r["c_ns"] = min(r["c_ns"], *(rhs_run_ns(r["exe"]) for _ in range(RHS_RUNS)))
                ode, x0, u, p = r["ode"], r["x0"], r["u"], r["p"]
                r["vm_ns"] = min(r["vm_ns"], best_of(lambda: [ode(0.0, x0, u, p) for _ in range(VM_CALLS)], 1)
                                 / VM_CALLS * 1e9)
                for _ in range(2):
                    sec, r["reached"], r["terminated"], r["finals"] = many_steps_seconds(
                        r["fmu"], N_STEPS, STEP, read=("beta", "gamma_dot"))
                    r["step_s"] = min(r["step_s"], sec)
            overhead = min(overhead, fmpy_call_overhead_ns(rows[0]["fmu"]))
            print(f"  round {rnd + 1}/{ROUNDS}: {time.perf_counter() - t_start:.0f} s", file=sys.stderr)

    for r in rows:
        r["step_ns"] = r["step_s"] / max(1, round(r["reached"] / STEP)) * 1e9
    base = rows[0]
    print("| effect set | states | outputs | ode instructions | ns/RHS (generated C) "
          "| peer: ns/RHS CasADi VM from Python | ns/fmi2DoStep (1 ms) | ratio to base (RHS / DoStep) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        note = f" (terminated at t = {r['reached']:.3f} s)" if r["terminated"] else ""
        print(f"| {r['label']}{note} | {r['nx']} | {r['ny']} | {r['instr']} | {r['c_ns']:.0f} | {r['vm_ns']:.0f} "
              f"| {r['step_ns']:.0f} | {r['c_ns'] / base['c_ns']:.2f} / {r['step_ns'] / base['step_ns']:.2f} |")
    print()
    print(f"fmpy/ctypes overhead of one trivial FMI call through FMU2Slave (fmi2GetRealStatus): {overhead:.0f} ns "
          f"(included in every ns/fmi2DoStep figure).")
    print(f"End of the {N_STEPS * STEP:g} s runs (beta [deg], gamma_dot [rad/s]): " + "; ".join(
        f"{r['label']}: {np.degrees(r['finals']['beta']):.1f}, {r['finals']['gamma_dot']:.2f}" for r in rows))
    print(f"Total run time {time.perf_counter() - t_start:.0f} s.")


if __name__ == "__main__":
    main()
