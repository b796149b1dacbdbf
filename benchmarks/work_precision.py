"""Work-precision benchmark: what accuracy costs in time, for every solver, against peers.

Scenarios (each a scene, built into two FMUs: the default build and one with the Taylor kernel):
  paper      the paper's earth scenario, examples/scenes/paper_earth.toml, 20 s
  long       the same scene for 1000 s (conservative rolling)
  stiff      Gyrover with a 10^4 rpm flywheel and a stiff tilt servo (double eigenvalue -2e4 1/s)
  near_flat  Euler-disk-like precession at 10 deg above the ground
Methods:
  default settings (auto), only the tolerance set
                      the default build of the scene (solver auto, the Taylor kernel where it
                      applies, max_step and abs_tol at their defaults) given only a tolerance,
                      the FMI way: fmi2SetupExperiment's tolerance (as fmpy's simulate_fmu passes
                      its relative_tolerance; the FMU takes it as rel_tol), nothing else set;
                      compared with the best named solver setting, and a candidate of gyrowheel best
  gyrowheel/<solver>  the FMU's internal solvers through fmpy's FMU2Slave, as a user runs an
                      instance it holds: reset, set the solver settings, initialise, one
                      fmi2DoStep(0, T) with max_step = T, read the 8 states (instantiation not
                      timed; the doStep alone is kept in the JSON as step_seconds).  Solver
                      taylor runs in the FMU built with the Taylor kernel (--taylor), every other
                      solver in the default build
  heyoka              heyoka's adaptive Taylor method (LLVM), taylor_adaptive, one trajectory, on
                      the minimal closed form of the base wheel (benchmarks/peers.py), timed as a
                      user calls it: set time and state, propagate_until, read the state
  heyoka batch N      (peer heyoka-batch) heyoka's batch mode, N trajectories together, time per
                      trajectory
  plain C DOP853      Hairer's DOP853 in plain C around the minimal hand-written RHS
  casadi/cvodes       CasADi's integrator on the FMU's expression graph (BDF; cvodes-adams: Adams)
  scipy/<method>      scipy.integrate.solve_ivp (DOP853, Radau, LSODA) calling the CasADi function
  fmpy-ME/CVode       fmpy's CVODE driving the FMU through Model Exchange
The peers on the minimal form run only on the base-wheel scenarios (paper, long, near_flat), after a
check that the minimal form equals the FMU's right-hand side at random states.
Error: max abs error of the 8 states at the stop time against a reference: heyoka in 80-bit long
double at tolerance 1e-19 on the base-wheel scenarios (cross-checked against the FMU's DOP853 at
1e-13), the FMU's DOP853 at 1e-13 otherwise; also the relative energy drift.
Tables, per scenario: rows = methods, columns = target errors (1e-4, 1e-7, 1e-10, 1e-12), each
cell the cheapest time to reach that error (over the tolerance grid, --per-decade tolerances per
decade from 1e-3 to 10^-14.5, 4 by default, the same grid for gyrowheel and heyoka; a method's
settings families,
e.g. taylor with abs_tol = rel_tol / 100 and = rel_tol, count as one row) and the ratio heyoka's
time / that time (above 1: faster than heyoka); the row "gyrowheel best" is the fastest
gyrowheel solver.  Then the limit per target (benchmarks/work_limit.py: the fewest Taylor steps
x order x the operations of the minimal closed form x a measured cost per operation) and each
method's distance from it (time / limit).  Time = CPU time of the calling thread (time.thread_time: time
the scheduler gives to other processes does not count, so runs of 0.2 ms and of 100 ms compare on a
loaded machine), best of --repeat (3) rounds: each round runs every setting of gyrowheel, heyoka and
the plain DOP853 once, so that a setting's repetitions are spread over the whole run (timed_rounds);
compilation (heyoka's JIT, the FMU) is not timed.

    python benchmarks/work_precision.py [--quick] [--scenarios paper stiff] [--peers heyoka plain]
                                        [--solvers dopri5 dop853 taylor] [--repeat 3]
                                        [--out results/bench] [--png-dir DIR]

Writes <out>/work_precision_<scenario>.png (in --png-dir if given), the figure's points as
<out>/work_precision_<scenario>.json (method, setting, seconds, error, energy_drift),
<out>/work_precision.md and prints the tables.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import peers  # noqa: E402
import work_limit  # noqa: E402
from fmi_slave import FmuRunner, solver_counts  # noqa: E402

from gyrowheel.fmu_build import build_fmu, parse_scene  # noqa: E402

PAPER_SCENE = HERE.parent / "examples" / "scenes" / "paper_earth.toml"
WHEEL = ""  # [wheel] at the scene defaults: the paper wheel (M 2 kg, R 0.17 m, k 0.25 / 0.4, beta_min 0.02)


def scene_body(path: Path) -> str:
    """A scene file's text without its [model] table (each benchmark names its own model)."""
    kept, in_model = [], False
    for line in path.read_text().splitlines():
        if line.strip().startswith("["):
            in_model = line.strip() == "[model]"
        if not in_model:
            kept.append(line)
    return "\n".join(kept) + "\n"


PAPER = scene_body(PAPER_SCENE)  # Nandy & Xu's earth scenario, as a user has it
SCENARIOS = {
    "paper": (PAPER, 20.0),
    "long": (PAPER, 1000.0),
    "stiff": (WHEEL + "[effects.gravity]\ng = 9.81\n[effects.gyrover]\nflywheel_rate = 1047.2\n"
              "tilt_omega = 20000.0\n[initial]\nbeta_deg = 85.0\ngamma_dot = 8.0\ntilt = 0.2\n", 2.0),
    "near_flat": ("[wheel]\nk_axial = 0.5\n" + "[effects.gravity]\ng = 9.81\n"
                  "[initial]\nbeta_deg = 10.0\nalpha_dot = 24.5195\ngamma_dot = -24.1470\n", 5.0),
}
TARGETS = (1e-4, 1e-7, 1e-10, 1e-12)
PER_DECADE = 4  # --per-decade: tolerances per decade of the grid TOLS


def tolerance_grid(per_decade: int) -> list[float]:
    """The tolerances 10^(-k / per_decade) from 1e-3 to 10^-14.5 (rel_tol's range ends at 10 eps),
    descending.  A method whose error follows its tolerance continuously (gyrowheel's solvers)
    reaches a target error at a tolerance between two points of a coarse grid and is charged
    the tighter point's time: on the paper scenario at 1e-4, 0.0975 ms at rel_tol 1e-4 on half
    decades against 0.093 ms at 1.78e-4 on quarter decades.  heyoka's error is a step function
    of its tolerance (its order changes at e^(-2 k), its step size does not follow the
    tolerance in between), so a finer grid leaves its cheapest points where they were."""
    if per_decade < 1:
        raise ValueError(f"per_decade must be a positive integer, got {per_decade}")
    return [10.0 ** -(k / per_decade) for k in range(3 * per_decade, int(14.5 * per_decade) + 1)]


def per_decade_option(text: str) -> int:
    """argparse type of --per-decade (this script's and ensemble_scaling.py's): a positive integer."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


# the tolerances of gyrowheel's solvers, heyoka and plain C (a decade grid put a method's cheapest
# point for a target up to 10x too tight); the slower peers: decades
TOLS = tolerance_grid(PER_DECADE)  # 1e-3 .. 10^-14.5
DECADES = [10.0 ** -k for k in range(3, 16)]
BASE_WHEEL = ("paper", "long", "near_flat")  # gravity only: the minimal closed form applies
PEERS = ("heyoka", "heyoka-batch", "plain", "cvodes", "scipy", "fmpy", "multipliers")
HEYOKA_BATCH = 4
HEYOKA = "heyoka (taylor_adaptive, one trajectory)"
# settings families of one solver: one row of the tables (the cheapest of either counts)
FAMILY_LABELS = (" (rel_tol only)", " (abs_tol = rel_tol)")
try:  # a benchmark dependency (pyproject.toml [bench]), not a core one
    import heyoka  # noqa: F401
    HAVE_HEYOKA = True
except ImportError:
    HAVE_HEYOKA = False
FIXED_STEPS = [10.0 ** -k for k in (2, 2.5, 3, 3.5, 4)]
SOLVER_CODES = {"euler": 1, "rk4": 2, "dopri5": 3, "rosenbrock": 4, "dop853": 5, "taylor": 6, "auto": 7}
AUTO_ROW = "default settings (auto), only the tolerance set"


@dataclass
class Point:
    method: str
    setting: float
    seconds: float
    error: float
    energy_drift: float
    steps: int = 0  # Taylor runs: steps taken (accepted + rejected), for the limit
    order: int = 0  # Taylor runs: the order
    step_seconds: float = float("nan")  # gyrowheel: the fmi2DoStep call alone


def best_time(fn, repeat: int) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.thread_time()
        out = fn()
        best = min(best, time.thread_time() - t0)
    return best, out


class Scenario:
    def __init__(self, name: str, text: str, stop: float, work: Path, formulation: str = "reduced",
                 default_build: bool = False):
        """runner: the FMU built with the Taylor kernel; default_runner and default_sources (with
        default_build): the default build of the same scene and its C sources, None otherwise."""
        self.name, self.stop = name, stop
        header = f'[model]\nname = "bench_{name}"\nformulation = "{formulation}"\n'
        scene = parse_scene(header + text, f"{name}.toml")
        built = build_fmu(scene, work / f"{name}.fmu", build_dir=work / name, taylor=True)
        self.fmu, self.spec, self.sources = built.fmu, built.spec, built.sources
        self.runner = FmuRunner(self.fmu)
        self.default_runner, self.default_sources = None, None
        if default_build:
            plain = build_fmu(scene, work / f"{name}_default.fmu", build_dir=work / f"{name}_default")
            self.default_runner, self.default_sources = FmuRunner(plain.fmu), plain.sources
        self.fns = self.spec.functions()
        self.p = np.array([q.start for q in self.spec.parameters], dtype=float)
        self.s0 = np.array([q.start for q in self.spec.starts], dtype=float)
        self.x0 = np.array(self.fns["init"](self.s0, self.p)).ravel()
        self.u = np.array([q.start for q in self.spec.inputs], dtype=float)
        self.state_names = [q.name for q, _ in self.spec.outputs][:8]
        out_names = [q.name for q, _ in self.spec.outputs]
        self.state_rows = [out_names.index(n) for n in self.state_names]
        self.energy_row = out_names.index("energy")
        self.reference = None
        self.counts: dict = {}  # solver_counts of a setting (run_internal)
        self.refused: set = set()  # settings a solver refused (run_internal), reported once
        self.heyoka = None  # peers.Heyoka, its integrators compiled once (run_heyoka)
        self.E0 = float(np.array(self.fns["out"](0.0, self.x0, self.u, self.p)).ravel()[self.energy_row])

    def outputs_of(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        y = np.array(self.fns["out"](self.stop, x, self.u, self.p)).ravel()
        return y[self.state_rows], float(y[self.energy_row])

    def score(self, method, setting, seconds, states, energy) -> Point:
        err = float(np.max(np.abs(np.asarray(states) - self.reference)))
        return Point(method, setting, seconds, err, abs(energy - self.E0) / abs(self.E0))


def timed_rounds(sc: Scenario, args, plain, repeat: int, base: bool) -> list[Point]:
    """The points of the timed methods (gyrowheel's solvers and default settings, heyoka, the plain
    C DOP853), each setting's time the best of `repeat` rounds, each round running every setting of
    every method once.  A setting's repetitions are spread over the whole measurement, not run
    back to back: on a virtual machine the speed of a thread changes for a fraction of a second to
    seconds at a time (up to 1.5x, as the host's other load comes and goes), so best-of-repeat
    within a few milliseconds times one such period, and two methods measured at different
    moments differed by it."""
    best: dict[tuple[str, float], Point] = {}
    for _ in range(repeat):
        for p in timed_round(sc, args, plain, base):
            kept = best.setdefault((p.method, p.setting), p)
            kept.seconds = min(kept.seconds, p.seconds)
            kept.step_seconds = min(kept.step_seconds, p.step_seconds)  # NaN (peers) stays NaN
    return list(best.values())


def timed_round(sc: Scenario, args, plain, base: bool) -> list[Point]:
    """One round of timed_rounds: every setting of every timed method once."""
    repeat = 1
    points: list[Point] = []
    for solver in ("euler", "rk4"):
        if solver in args.solvers and (sc.name != "long" or solver == "rk4"):
            points += run_internal(sc, solver, FIXED_STEPS, repeat)
    for solver in ("dopri5", "dop853", "rosenbrock"):
        if solver in args.solvers:
            points += run_internal(sc, solver, TOLS, repeat)
    if "dop853" in args.solvers:
        points += run_internal(sc, "dop853", TOLS, repeat, " (rel_tol only)", tolerance_only=True)
    if "auto" in args.solvers:
        points += run_default(sc, TOLS, repeat)
    if "taylor" in args.solvers:  # the Taylor step is set by the weights: abs_tol = rel_tol too
        points += run_internal(sc, "taylor", TOLS, repeat)
        points += run_internal(sc, "taylor", TOLS, repeat, " (abs_tol = rel_tol)", atol_per_rtol=1.0)
    if base and "heyoka" in args.peers and HAVE_HEYOKA:
        points += run_heyoka(sc, repeat, batch="heyoka-batch" in args.peers)
    if base and plain is not None:
        points += run_plain(sc, plain, repeat)
    return points


def run_internal(sc: Scenario, solver: str, settings, repeat: int, label: str = "",
                 tolerance_only: bool = False, atol_per_rtol: float = 1e-2) -> list[Point]:
    """tolerance_only: set rel_tol alone (abs_tol left at the scene default, 0 = rel_tol / 100);
    otherwise abs_tol = atol_per_rtol * rel_tol.  Solver taylor runs in the FMU with the Taylor
    kernel (and its steps are counted, for the limit), the others in the default build when the
    scenario has one.  seconds: the whole call (FmuRunner.last_call_seconds), best of repeat."""
    runner = sc.runner if solver == "taylor" or sc.default_runner is None else sc.default_runner
    points = []
    for value in settings:
        values = {"solver": SOLVER_CODES[solver], "max_internal_steps": 2**31 - 1}
        if solver in ("euler", "rk4"):
            values["max_step"] = value
        elif tolerance_only:
            values.update(rel_tol=value, max_step=sc.stop)
        else:
            values.update(rel_tol=value, abs_tol=value * atol_per_rtol, max_step=sc.stop)
        try:
            seconds = step_seconds = float("inf")
            for _ in range(repeat):
                res = runner.one_step(sc.stop, sc.state_names + ["energy"], **values)
                seconds = min(seconds, runner.last_call_seconds)
                step_seconds = min(step_seconds, runner.last_seconds)
        except Exception as exc:  # a solver that cannot do this scenario at this setting
            if (solver, label, value) not in sc.refused:  # said once, not in every round
                sc.refused.add((solver, label, value))
                print(f"  {solver} {value:g}: {exc}", file=sys.stderr)
            continue
        point = sc.score(f"gyrowheel/{solver}{label}", value, seconds, res[:-1], res[-1])
        point.step_seconds = step_seconds
        if solver == "taylor":
            key = tuple(sorted(values.items()))  # counted once: every round takes the same steps
            counts = sc.counts[key] = sc.counts.get(key) or solver_counts(sc.fmu, sc.stop, **values)
            point.steps, point.order = counts["accepted"] + counts["rejected"], work_limit.taylor_order(value)
        points.append(point)
    return points


def run_default(sc: Scenario, settings, repeat: int) -> list[Point]:
    """AUTO_ROW: the scene's default build given only a tolerance, fmi2SetupExperiment's (the FMU
    takes it as rel_tol; solver, abs_tol, max_step and the budget at the FMU's defaults); seconds
    as run_internal's."""
    points = []
    for value in settings:
        seconds = step_seconds = float("inf")
        try:
            for _ in range(repeat):
                res = sc.default_runner.one_step(sc.stop, sc.state_names + ["energy"], tolerance=value)
                seconds = min(seconds, sc.default_runner.last_call_seconds)
                step_seconds = min(step_seconds, sc.default_runner.last_seconds)
        except Exception as exc:  # a tolerance outside the FMU's range
            print(f"  auto {value:g}: {exc}", file=sys.stderr)
            continue
        point = sc.score(AUTO_ROW, value, seconds, res[:-1], res[-1])
        point.step_seconds = step_seconds
        points.append(point)
    return points


def run_multipliers(sc: Scenario, work: Path, repeat: int) -> tuple[list[Point], list[str]]:
    """The paper's route (Lagrange multipliers, velocity-stabilised) against the same reference."""
    text, _ = SCENARIOS[sc.name]
    mult = Scenario(sc.name + "_mult", text, sc.stop, work, formulation="multipliers")
    mult.reference, mult.E0 = sc.reference, sc.E0
    points = run_internal(mult, "dopri5", DECADES[:10], repeat, label=" (multipliers)")
    notes = []
    for tol in dict.fromkeys((DECADES[0], DECADES[len(DECADES) // 2], DECADES[-1])):  # (--quick: two)
        v = mult.runner.one_step(sc.stop, ["constraint_violation"], solver=SOLVER_CODES["dopri5"], rel_tol=tol,
                                 abs_tol=tol * 1e-2, max_step=sc.stop)[0]
        notes.append(f"rel_tol {tol:g}: |A q_dot| = {v:.1e} m/s")
    return points, notes


def run_cvodes(sc: Scenario, repeat: int, method: str = "bdf") -> list[Point]:
    x = ca.SX.sym("x", sc.x0.size)
    dae = {"x": x, "ode": sc.fns["ode"](0.0, x, sc.u, sc.p)}
    points = []
    for tol in DECADES[:10]:
        integ = ca.integrator("cv", "cvodes", dae, 0.0, sc.stop, {"reltol": tol, "abstol": tol * 1e-2,
                                                                 "max_num_steps": 10**7,
                                                                 "linear_multistep_method": method})
        try:
            seconds, res = best_time(lambda: integ(x0=sc.x0), repeat)
        except RuntimeError as exc:
            print(f"  cvodes {method} {tol:g}: {exc}", file=sys.stderr)
            continue
        states, energy = sc.outputs_of(np.array(res["xf"]).ravel())
        points.append(sc.score("casadi/cvodes" + ("-adams" if method == "adams" else ""), tol, seconds, states,
                               energy))
    return points


def wheel_params(sc: Scenario) -> tuple[float, ...]:
    """(M, R, k_diam, k_axial, g) of a base-wheel scenario, for the minimal form."""
    names = [q.name for q in sc.spec.parameters]
    return tuple(float(sc.p[names.index(n)]) for n in ("M", "R", "k_diam", "k_axial", "g"))


def energy_of(sc: Scenario, x: np.ndarray) -> float:
    return sc.outputs_of(np.asarray(x, dtype=float))[1]


def run_heyoka(sc: Scenario, repeat: int, batch: bool = False) -> list[Point]:
    """heyoka, one trajectory (and batch mode with batch), on the minimal form (compilation not
    timed)."""
    hy = sc.heyoka = sc.heyoka or peers.Heyoka(wheel_params(sc), sc.x0, sc.stop)
    points = []
    for tol in TOLS:
        seconds, x, steps, order = hy.single(tol, repeat)
        point = sc.score(HEYOKA, tol, seconds, x, energy_of(sc, x))
        point.steps, point.order = steps, order
        points.append(point)
        if batch:
            seconds, x = hy.batch(tol, HEYOKA_BATCH, repeat)
            points.append(sc.score(f"heyoka batch {HEYOKA_BATCH} (per trajectory)", tol, seconds, x,
                                   energy_of(sc, x)))
    return points


def run_plain(sc: Scenario, plain: peers.PlainDop853, repeat: int) -> list[Point]:
    points = []
    for tol in TOLS:
        try:
            seconds, x = plain.run(wheel_params(sc), sc.x0, sc.stop, tol, tol * 1e-2, repeat)
        except RuntimeError as exc:
            print(f"  {exc}", file=sys.stderr)
            continue
        points.append(sc.score("plain C DOP853 (minimal RHS)", tol, seconds, x, energy_of(sc, x)))
    return points


def run_scipy(sc: Scenario, method: str, repeat: int) -> list[Point]:
    from scipy.integrate import solve_ivp
    ode, jac = sc.fns["ode"], sc.fns["jac"]

    def f(t, x):
        return np.array(ode(t, x, sc.u, sc.p)).ravel()

    def J(t, x):
        return np.array(jac(t, x, sc.u, sc.p))
    points = []
    for tol in DECADES[: (9 if method == "DOP853" else 6)]:
        kw = {"jac": J} if method in ("Radau", "LSODA") else {}
        seconds, sol = best_time(lambda: solve_ivp(f, (0.0, sc.stop), sc.x0, method=method, rtol=tol,
                                                   atol=tol * 1e-2, **kw), repeat)
        if not sol.success:
            continue
        states, energy = sc.outputs_of(sol.y[:, -1])
        points.append(sc.score(f"scipy/{method}", tol, seconds, states, energy))
    return points


def run_fmpy_me(sc: Scenario, repeat: int) -> list[Point]:
    from fmpy import simulate_fmu
    points = []
    for tol in DECADES[:8]:
        try:
            # fmpy's CVode allows 500 steps per output interval: 2000 outputs over the run
            seconds, r = best_time(lambda: simulate_fmu(str(sc.fmu), fmi_type="ModelExchange", solver="CVode",
                                                        stop_time=sc.stop, output_interval=sc.stop / 2000,
                                                        relative_tolerance=tol), repeat)
        except Exception as exc:
            print(f"  fmpy ME: {exc}", file=sys.stderr)
            return points
        points.append(sc.score("fmpy-ME/CVode", tol, seconds, [r[n][-1] for n in sc.state_names], r["energy"][-1]))
    return points


def cheapest(points: list[Point], target: float) -> dict[str, float]:
    out: dict[str, float] = {}
    for p in points:
        if p.error <= target and p.seconds < out.get(p.method, float("inf")):
            out[p.method] = p.seconds
    return out


def plot(name: str, points: list[Point], path: Path) -> None:
    """Write the work-precision figure of one scenario (error against CPU time, log-log)."""
    import matplotlib.pyplot as plt
    fig = figure(name, points)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def figure(name: str, points: list[Point]):
    """The matplotlib Figure plot writes: one line per method, the legend beside the axes (inside,
    it would cover points), log axes labelled at every decade."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker as ticker
    fig, ax = plt.subplots(figsize=(10, 5.5))
    colours = plt.cm.tab20.colors
    for k, method in enumerate(dict.fromkeys(p.method for p in points)):
        pts = sorted((p for p in points if p.method == method), key=lambda p: p.seconds)
        style = "-o" if method.startswith("gyrowheel") else "--s"
        ax.loglog([p.seconds for p in pts], [max(p.error, 1e-16) for p in pts], style, ms=3.5, label=method,
                  color=colours[(2 * k) % 20 if k < 10 else (2 * k + 1) % 20])
    ax.set_xlabel("CPU time [s]")
    ax.set_ylabel("final-state error (max norm)")
    ax.set_title(f"work-precision: {name}")
    ax.grid(True, which="both", alpha=0.3)
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(ticker.LogLocator(base=10, numticks=30))
        axis.set_minor_locator(ticker.LogLocator(base=10, subs=np.arange(2, 10), numticks=30))
        axis.set_minor_formatter(ticker.NullFormatter())
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    fig.tight_layout()
    return fig


def error_floor(points: list[Point], prefix: str = "gyrowheel") -> float:
    return min((p.error for p in points if p.method.startswith(prefix)), default=float("nan"))


def row_of(method: str) -> str:
    """The table row of a method: its settings families (FAMILY_LABELS) are one row."""
    for label in FAMILY_LABELS:
        if method.endswith(label):
            return method[: -len(label)]
    return method


def cheapest_rows(points: list[Point], target: float) -> dict[str, float]:
    """{row: the cheapest seconds reaching target} over the settings of each row."""
    out: dict[str, float] = {}
    for method, seconds in cheapest(points, target).items():
        row = row_of(method)
        out[row] = min(seconds, out.get(row, float("inf")))
    return out


def table(name: str, points: list[Point]) -> str:
    """Rows = methods, columns = target errors; each cell the cheapest time to reach the error
    and (in parentheses) heyoka's time / that time: above 1, faster than heyoka (docs/performance.md)."""
    cols = " | ".join(f"{t:.0e}" for t in TARGETS)
    per = {t: cheapest_rows(points, t) for t in TARGETS}
    rows = list(dict.fromkeys(row_of(p.method) for p in points))
    ours = [r for r in rows if r.startswith("gyrowheel")]
    floor = error_floor(points)

    def cell(seconds, target) -> str:
        if seconds is None:
            return "-"
        ref = per[target].get(HEYOKA)
        return f"{seconds * 1e3:.3g} ms" + (f" ({ref / seconds:.2f})" if ref is not None else "")
    lines = [f"### {name}", "", f"| method | {cols} |", "|---|" + "---|" * len(TARGETS)]
    cells = []
    for t in TARGETS:  # every gyrowheel configuration, the defaults included
        best = min(((per[t][r], r) for r in ours + [AUTO_ROW] if r in per[t]), default=None)
        cells.append(f"not reached (floor {floor:.1e})" if best is None
                     else f"{cell(best[0], t)}, {'auto' if best[1] == AUTO_ROW else best[1].removeprefix('gyrowheel/')}")
    lines.append("| gyrowheel best | " + " | ".join(cells) + " |")
    if any(AUTO_ROW in per[t] for t in TARGETS):  # beside the best: its time and time / best
        auto = []
        for t in TARGETS:
            best = min((per[t][r] for r in ours if r in per[t]), default=None)
            seconds = per[t].get(AUTO_ROW)
            auto.append("-" if seconds is None or best is None
                        else f"{seconds * 1e3:.3g} ms, {seconds / best:.2f}x best solver")
        lines.append(f"| {AUTO_ROW} | " + " | ".join(auto) + " |")
    for row in rows:
        if row != AUTO_ROW:
            lines.append(f"| {row} | " + " | ".join(cell(per[t].get(row), t) for t in TARGETS) + " |")
    lines.append("")
    lines.append("Cheapest time to reach each final-state error (max abs error of the 8 states), thread CPU time "
                 "of the whole call, best of the rounds (each round every setting once); in parentheses heyoka's "
                 f"time over it (above 1: faster than heyoka; \"-\": not reached). gyrowheel's error floor: {floor:.1e}.")
    return "\n".join(lines)


def limit_section(name: str, sc: Scenario, points: list[Point], work: Path) -> str:
    """The limit per target and each method's distance from it (benchmarks/work_limit.py)."""
    work.mkdir(parents=True, exist_ok=True)
    n_ops = work_limit.operation_count(wheel_params(sc))
    t_rhs = work_limit.rhs_seconds(sc.default_sources, work)  # rhs_bench builds on the default build
    lim = work_limit.limits(points, TARGETS, t_rhs)
    per = {t: cheapest_rows(points, t) for t in TARGETS}
    rows = {row: {t: per[t][row] for t in TARGETS if row in per[t]}
            for row in dict.fromkeys(row_of(p.method) for p in points)}
    return work_limit.limit_table(name, rows, lim, TARGETS, n_ops, t_rhs)


def step_counts(sc: Scenario, solver: str = "dop853") -> str:
    """Accepted / rejected steps of one gyrowheel solver over the tolerances (the controller's record)."""
    parts = []
    for tol in (1e-4, 1e-7, 1e-10, 1e-13):
        try:
            c = solver_counts(sc.fmu, sc.stop, solver=SOLVER_CODES[solver], rel_tol=tol, abs_tol=tol * 1e-2,
                              max_step=sc.stop)
        except Exception as exc:  # noqa: BLE001 - a run that fails is reported, not fatal
            parts.append(f"rel_tol {tol:g}: {exc}")
            continue
        frac = c["rejected"] / max(1, c["accepted"] + c["rejected"])
        parts.append(f"rel_tol {tol:g}: {c['accepted']} accepted, {c['rejected']} rejected ({frac:.0%})")
    return f"{solver} steps: " + "; ".join(parts)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", nargs="*", default=list(SCENARIOS), choices=list(SCENARIOS))
    parser.add_argument("--peers", nargs="*", default=list(PEERS), choices=list(PEERS),
                        help="peers to measure beside gyrowheel (default: all)")
    parser.add_argument("--solvers", nargs="*",
                        default=["euler", "rk4", "dopri5", "dop853", "rosenbrock", "taylor", "auto"],
                        choices=list(SOLVER_CODES), help="gyrowheel solvers to measure")
    parser.add_argument("--quick", action="store_true", help="few settings, no repetitions (a smoke run)")
    parser.add_argument("--repeat", type=int, default=3, help="repetitions of each timing, best counted")
    parser.add_argument("--per-decade", type=per_decade_option, default=None,
                        help=f"tolerances per decade of the grid (default {PER_DECADE}; not with --quick)")
    parser.add_argument("--out", default="results/bench")
    parser.add_argument("--png-dir", help="directory for the figures (default: --out; make figures: docs/img)")
    args = parser.parse_args()
    if args.per_decade is not None and args.quick:
        parser.error("--quick runs its own two tolerances (1e-4, 1e-7): leave out --per-decade")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.png_dir:
        Path(args.png_dir).mkdir(parents=True, exist_ok=True)
    repeat = 1 if args.quick else args.repeat
    global TOLS, DECADES, FIXED_STEPS
    TOLS = tolerance_grid(args.per_decade or PER_DECADE)
    if args.quick:
        TOLS, DECADES, FIXED_STEPS = [1e-4, 1e-7], [1e-4, 1e-7], [1e-2, 1e-3]
    report = ["# Work-precision results", "",
              "Timings from one run on a shared machine: ratios are measured in the same run; "
              "re-run on a quiet machine for final numbers.", ""]
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        plain = peers.PlainDop853(Path(tmp)) if "plain" in args.peers else None
        for name in args.scenarios:
            text, stop = SCENARIOS[name]
            if args.quick:
                stop = min(stop, 2.0)
            sc = Scenario(name, text, stop, Path(tmp), default_build=True)
            ref_fmu = np.asarray(sc.runner.one_step(stop, sc.state_names, solver=SOLVER_CODES["dop853"],
                                                    rel_tol=1e-13, abs_tol=1e-15, max_step=stop))
            notes: list[str] = []
            base = name in BASE_WHEEL
            if base:
                mismatch = peers.check_minimal(sc.fns["ode"], wheel_params(sc), sc.p, sc.u)
                if mismatch > 1e-12:
                    raise RuntimeError(f"{name}: the minimal form differs from the FMU's RHS by {mismatch:.1e}")
            if base and HAVE_HEYOKA:
                sc.reference = peers.reference(sc.x0, wheel_params(sc), stop)
                notes.append(f"Reference: heyoka in long double (tol 1e-19); the FMU's DOP853 at rel_tol 1e-13 "
                             f"differs from it by {np.max(np.abs(ref_fmu - sc.reference)):.1e}; minimal form = FMU "
                             f"RHS to {mismatch:.0e} (relative) at random states.")
            else:
                sc.reference = ref_fmu
                notes.append("Reference: the FMU's DOP853 at rel_tol 1e-13.")
            points = timed_rounds(sc, args, plain, repeat, base)
            if base and "heyoka" in args.peers and not HAVE_HEYOKA:
                notes.append("heyoka is not installed (pip install -e '.[bench]'): its rows are missing.")
            if name in ("paper", "long") and "multipliers" in args.peers:
                mult_points, mult_notes = run_multipliers(sc, Path(tmp), repeat)
                points += mult_points
                notes.append("Constraint violation of the multiplier form at the end (the reduced form has "
                             "none by construction): " + "; ".join(mult_notes))
            if "cvodes" in args.peers:
                points += run_cvodes(sc, repeat) + run_cvodes(sc, repeat, "adams")
            if stop <= 20.0:
                if "scipy" in args.peers:
                    for method in ("DOP853", "Radau", "LSODA"):
                        points += run_scipy(sc, method, 1)
                if "fmpy" in args.peers:
                    points += run_fmpy_me(sc, 1)
            if "dop853" in args.solvers and not args.quick:
                notes.append(step_counts(sc))
            plot(name, points, Path(args.png_dir or out) / f"work_precision_{name}.png")
            (out / f"work_precision_{name}.json").write_text(json.dumps([vars(p) for p in points], indent=0) + "\n")
            text_table = table(f"{name} ({stop:g} s)", points)
            if base and HAVE_HEYOKA and "heyoka" in args.peers:
                text_table += "\n\n" + limit_section(f"{name} ({stop:g} s)", sc, points, Path(tmp) / f"{name}_rhs")
            print(text_table, flush=True)
            for note in notes:
                print(note)
            figure_path = os.path.relpath(Path(args.png_dir or out) / f"work_precision_{name}.png", out)
            report += [text_table, "", f"![{name}]({figure_path})", ""]
            drift = {p.method: p.energy_drift for p in sorted(points, key=lambda p: -p.setting)}
            report.append("Energy drift at the tightest setting: " +
                          ", ".join(f"{m} {d:.1e}" for m, d in drift.items()) + "\n")
            report += [n + "\n" for n in notes]
    (out / "work_precision.md").write_text("\n".join(report))
    print(f"wrote {out / 'work_precision.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
