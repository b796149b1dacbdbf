"""Hard cases: where the wheel's equations get hard, and what the FMU does there.

Prints one table (case, solver, result, error, time) for eleven families of hard cases,
including the long runs the test suite leaves out (10^4 s of rolling,
1000 s of steady precession). docs/hard_cases.md shows a run and says which solver to use where.

    python examples/hard_cases.py
"""
from __future__ import annotations

import atexit
import math
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2LastSuccessfulTime

from gyrowheel.fmu_build import build_fmu, load_scene, parse_scene
from gyrowheel.model.build import BETA_MIN_DEFAULT
from gyrowheel.model.steady import critical_spin, precession_rates
from gyrowheel.studies.scipy_reference import solve_hybrid

HERE = Path(__file__).resolve().parent
STATES = ["x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot", "gamma_dot"]
SOLVER = {"euler": 1, "rk4": 2, "dopri5": 3, "rosenbrock": 4, "dop853": 5}
PAPER = dict(M=2.0, R=0.17, k_diam=0.25, k_axial=0.4, g=9.81)


class Fmu:
    """An FMU instantiated once and reset between runs."""

    def __init__(self, path: Path):
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.types = {v.name: v.type for v in self.md.modelVariables}
        unzipdir = extract(str(path), str(path.with_name(path.stem + "_unzipped")))  # removed with tmp
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=unzipdir,
                               modelIdentifier=self.md.coSimulation.modelIdentifier)
        self.slave.instantiate()
        self.fresh = True

    def start(self, **values):
        s = self.slave
        if not self.fresh:
            s.reset()
        self.fresh = False
        s.setupExperiment(startTime=0.0)
        for name, value in values.items():
            if self.types[name] in ("Integer", "Enumeration"):
                s.setInteger([self.vr[name]], [SOLVER[value] if isinstance(value, str) else int(value)])
            else:
                s.setReal([self.vr[name]], [float(value)])
        s.enterInitializationMode()
        s.exitInitializationMode()

    def get(self, *names):
        """The values of `names` as floats: Real outputs, and Integer or Enumeration ones (such as
        contact_mode: 0 rolling, 1 sliding) by their number."""
        s = self.slave
        return [float(s.getInteger([self.vr[n]])[0]) if self.types[n] in ("Integer", "Enumeration")
                else s.getReal([self.vr[n]])[0] for n in names]

    def run(self, stop, h, **values):
        """Steps of h to stop or the fall: (end time, fell, seconds)."""
        self.start(**values)
        t, t0 = 0.0, time.perf_counter()
        try:
            while t < stop - 1e-12:
                self.slave.doStep(t, min(h, stop - t))
                t = min(t + h, stop)
        except FMICallException:
            return self.slave.getRealStatus(fmi2LastSuccessfulTime), True, time.perf_counter() - t0
        return t, False, time.perf_counter() - t0


def reference_fall(spec, start, beta_min, stop=60.0, rtol=1e-13):
    """scipy DOP853 (rtol 1e-13 unless said) on the CasADi model, with its mode switches (the
    stiction laws' update events): the fall time (or None)."""
    f = spec.functions()
    p = np.array([beta_min if q.name == "beta_min" else q.start for q in spec.parameters])
    s = np.array([start.get(q.name, q.start) for q in spec.starts])
    x0 = np.array(f["init"](s, p)).ravel()
    return solve_hybrid(spec, x0, p, stop, stop=lambda t, x: math.sin(x[3]) - math.sin(beta_min),
                        rtol=rtol, atol=rtol * 1e-2)[0]


def main() -> int:
    rows: list[tuple[str, str, str, str, float]] = []

    def row(case, solver, result, error, seconds):
        rows.append((case, solver, result, error, seconds))
        print(f"{case:<34} {solver:<11} {result:<44} {error:<22} {seconds * 1e3:9.1f} ms", flush=True)

    tmp = Path(tempfile.mkdtemp(prefix="gyrowheel-hard-"))
    atexit.register(shutil.rmtree, tmp, True)  # the FMUs and their unpacked copies
    paper_built = build_fmu(load_scene(HERE / "scenes" / "paper_earth.toml"), tmp / "paper.fmu")
    paper = Fmu(paper_built.fmu)
    disk_built = build_fmu(load_scene(HERE / "scenes" / "euler_disk.toml"), tmp / "disk.fmu")
    disk = Fmu(disk_built.fmu)
    fly_text = (HERE / "scenes" / "gyrover_steering.toml").read_text().replace("flywheel_rate = 400.0",
                                                                                 "flywheel_rate = 1047.2")
    fly = Fmu(build_fmu(parse_scene(fly_text, "fast_flywheel.toml"), tmp / "fly.fmu").fmu)
    tight = dict(rel_tol=1e-12, abs_tol=1e-14, max_step=1.0)
    print(f"{'case':<34} {'solver':<11} {'result':<44} {'error':<22} {'time':>12}")

    # 1. near flat
    start = dict(beta=math.radians(2.0), gamma_dot=0.0)
    ref = reference_fall(paper_built.spec, start, BETA_MIN_DEFAULT)
    for solver in ("dopri5", "dop853"):
        t, fell, sec = paper.run(5.0, 0.05, solver=solver, **start, **tight)
        row("1 near flat 2 deg, no spin", solver, f"fell at t = {t:.9f} s", f"event {t - ref:+.1e} s", sec)
    b0 = math.radians(2.0)
    ad = math.sqrt(9.81 / (0.25 * 0.17 * math.sin(b0)))
    for solver in ("dopri5", "dop853"):
        t, fell, sec = paper.run(10.0, 0.1, solver=solver, beta=b0, alpha_dot=ad, gamma_dot=-math.cos(b0) * ad,
                                 **tight)
        dev = abs(paper.get("beta")[0] - b0)
        row("1 near flat 2 deg, precessing", solver, f"alpha_dot {ad:.0f} rad/s for 10 s, up", f"lean {dev:.1e} rad",
            sec)

    # 2. Euler's disk
    ref = reference_fall(disk_built.spec, {}, 0.05)
    for solver, tol in (("dopri5", 1e-12), ("dop853", 1e-12), ("rosenbrock", 1e-10)):
        t, fell, sec = disk.run(60.0, 1.0, solver=solver, rel_tol=tol, abs_tol=tol * 1e-2, max_step=1.0)
        row("2 Euler's disk to beta_min", solver, f"fell at t = {t:.9f} s (rel_tol {tol:g})",
            f"event {t - ref:+.1e} s", sec)
    # ... and on down to the default beta_min, where the accelerations carry ~2e-10 of round-off
    ref = reference_fall(disk_built.spec, {}, BETA_MIN_DEFAULT, rtol=1e-11)
    for solver in ("dopri5", "dop853"):
        t, fell, sec = disk.run(60.0, 1.0, solver=solver, rel_tol=1e-10, abs_tol=1e-12, max_step=1.0,
                                beta_min=BETA_MIN_DEFAULT)
        row("2 Euler's disk to 1e-3 rad", solver, f"fell at t = {t:.9f} s (rel_tol 1e-10)",
            f"event {t - ref:+.1e} s", sec)
    # the thin hoop (tests/test_fall_criterion.py): 52 dips to 0.0135 rad in 100 s, all defaults but the wheel
    hoop = dict(M=1.0, R=1.0, g=100.0, k_diam=0.5, k_axial=1.0, beta=math.pi / 2, beta_dot=0.01, gamma_dot=0.1)
    for solver, tol in (("dopri5", 1e-8), ("dop853", 1e-12)):
        paper.start(solver=solver, rel_tol=tol, abs_tol=tol * 1e-2, **hoop)
        e0, t, dips, lowest, previous, falling = paper.get("energy")[0], 0.0, 0, 1.0, 1.0, True
        t0 = time.perf_counter()
        while t < 100.0 - 1e-9:
            h = 2e-5 if previous < 0.1 else 1e-3
            paper.slave.doStep(t, h)
            t += h
            lean = math.asin(abs(math.sin(paper.get("beta")[0])))
            if falling and lean > previous and previous < 0.5:
                dips, lowest = dips + 1, min(lowest, previous)
            falling, previous = lean < previous, lean
        drift = abs(paper.get("energy")[0] / e0 - 1)
        row("2 hoop dipping near flat, 100 s", solver, f"{dips} dips, lowest {lowest:.6f} rad (rel_tol {tol:g})",
            f"energy {drift:.1e}", time.perf_counter() - t0)

    # 3. fast spin and fast flywheel
    for solver in ("dopri5", "dop853", "rosenbrock"):
        paper.start(solver=solver, beta=math.pi / 2 - 1e-3, gamma_dot=2000.0, rel_tol=1e-10, abs_tol=1e-12,
                    max_step=1.0)
        e0 = paper.get("energy")[0]
        t0 = time.perf_counter()
        paper.slave.doStep(0.0, 1.0)
        sec = time.perf_counter() - t0
        beta, e = paper.get("beta", "energy")
        row("3 fast spin 2000 rad/s, 1 s", solver, f"lean {abs(beta - math.pi / 2):.1e} rad from upright",
            f"energy {abs(e - e0) / e0:.1e}", sec)
    for solver in ("dopri5", "rosenbrock"):
        fly.start(solver=solver, rel_tol=1e-10, abs_tol=1e-12, beta=math.pi / 2, gamma_dot=10.0)
        e0 = fly.get("energy")[0]
        fly.slave.setReal([fly.vr["tilt_cmd"]], [0.2])
        t0 = time.perf_counter()
        fly.slave.doStep(0.0, 2.0)
        sec = time.perf_counter() - t0
        e, w, beta = fly.get("energy", "actuator_work", "beta")
        row("3 flywheel 10^4 rpm, tilt step", solver, f"lean {abs(beta - math.pi / 2):.3f} rad after 2 s",
            f"E - W balance {abs(e - e0 - w) / e0:.1e}", sec)

    # 4. long horizon: 10^4 s of conservative rolling (paper wheel on the moon)
    for solver, settings in (("dop853", dict(rel_tol=1e-10, abs_tol=1e-12)),
                             ("dopri5", dict(rel_tol=1e-10, abs_tol=1e-12)),
                             ("rosenbrock", dict(rel_tol=1e-8, abs_tol=1e-10)),
                             ("rk4", dict(max_step=2e-3))):
        # one 10^4 s step: rk4 at 2 ms takes 5e6 internal steps, beyond the default budget of 1e6
        paper.start(g=1.625, solver=solver, **{"max_step": 100.0, "max_internal_steps": 10**7, **settings})
        e0 = paper.get("energy")[0]
        t0 = time.perf_counter()
        paper.slave.doStep(0.0, 1e4)
        sec = time.perf_counter() - t0
        e = paper.get("energy")[0]
        label = ", ".join(f"{k} {v:g}" for k, v in settings.items())
        row("4 long horizon 10^4 s", solver, f"energy drift ({label})", f"{abs(e - e0) / e0:.1e} relative", sec)

    # 5. extreme scales: dynamic similarity in tau = t sqrt(g/R); M drops out
    base = None
    for R, M, g in ((0.17, 2.0, 9.81), (1e-3, 2.0, 9.81), (5.0, 2.0, 9.81), (0.17, 1e-3, 9.81), (0.17, 1e3, 9.81),
                    (0.17, 2.0, 1e-3), (0.17, 2.0, 100.0)):
        w = math.sqrt(g / R)
        tau = 10.0
        paper.start(solver="dop853", R=R, M=M, g=g, gamma_dot=6.0 * w / math.sqrt(9.81 / 0.17),
                    rel_tol=1e-11, abs_tol=1e-13, max_step=100.0)
        t0 = time.perf_counter()
        paper.slave.doStep(0.0, tau / w)
        sec = time.perf_counter() - t0
        beta, alpha = paper.get("beta", "alpha")
        if base is None:
            base = (beta, alpha)
        row("5 scales R, M, g", "dop853", f"R {R:g} m, M {M:g} kg, g {g:g}",
            f"similarity {max(abs(beta - base[0]), abs(alpha - base[1])):.1e} rad", sec)

    # 6. exactly upright, no spin; upright at the critical spin
    t, fell, sec = paper.run(60.0, 1.0, solver="dop853", beta=math.pi / 2, gamma_dot=0.0, **tight)
    row("6 exactly upright, no spin", "dop853", ("fell at t = %.2f s" % t) if fell else "stays upright for 60 s",
        "round-off grows e^(t/0.15 s)" if fell else "-", sec)
    wc = critical_spin(**PAPER)
    for factor in (0.8, 1.0, 1.25):
        paper.start(solver="dop853", beta=math.pi / 2 - 1e-3, gamma_dot=factor * wc, **tight)
        lean, t = 0.0, 0.0
        t0 = time.perf_counter()
        try:
            for _ in range(100):
                paper.slave.doStep(t, 0.1)
                t += 0.1
                lean = max(lean, abs(paper.get("beta")[0] - math.pi / 2))
        except FMICallException:
            lean = float("inf")
        row(f"6 upright, spin {factor:g} w_c", "dop853", f"max lean over 10 s: {lean:.2e} rad", "-",
            time.perf_counter() - t0)

    # 7. communication steps from 1e-7 s to 100 s; a step containing the fall
    for h in (1e-7, 1e-3, 100.0):
        paper.start(solver="dop853", g=1.625, rel_tol=1e-10, abs_tol=1e-12, max_step=100.0)
        t0 = time.perf_counter()
        n = 10 if h < 1 else 1
        t = 0.0
        for _ in range(n):
            paper.slave.doStep(t, h)
            t += h
        sec = time.perf_counter() - t0
        landed = paper.slave.getRealStatus(fmi2LastSuccessfulTime)
        row("7 communication step", "dop853", f"{n} x h = {h:g} s", f"landing {landed - t:+.0e} s", sec)
    ref = reference_fall(paper_built.spec, dict(gamma_dot=1.0, beta_min=0.1), 0.1)
    for h in (0.01, 1.0, 20.0):
        t, fell, sec = paper.run(20.0, h, solver="dop853", gamma_dot=1.0, beta_min=0.1, **tight)
        row("7 the fall inside one step", "dop853", f"h = {h:g} s: fell at t = {t:.9f} s", f"event {t - ref:+.1e} s",
            sec)

    # 8. reversibility
    for solver in ("dopri5", "dop853"):
        paper.start(solver=solver, rel_tol=1e-12, abs_tol=1e-14, max_step=1.0)
        x0 = paper.get(*STATES)
        paper.slave.doStep(0.0, 5.0)
        x1 = paper.get(*STATES)
        back = dict(zip(STATES[:5], x1[:5]))
        back.update({n: -v for n, v in zip(STATES[5:], x1[5:])})
        paper.start(solver=solver, rel_tol=1e-12, abs_tol=1e-14, max_step=1.0, **back)
        t0 = time.perf_counter()
        paper.slave.doStep(0.0, 5.0)
        x2 = paper.get(*STATES)
        err = max(abs(a - b) for a, b in zip(x2[:5], x0[:5]))
        row("8 forward 5 s, rates flipped, back", solver, "start recovered", f"{err:.1e} in q", time.perf_counter() - t0)

    # 9. steady precession held for 1000 s (eq. 52, beta 80 deg, rho 1 m)
    b, rho = math.radians(80.0), 1.0
    ad, gd = precession_rates(b, rho, **PAPER)
    for solver in ("dopri5", "dop853"):
        paper.start(solver=solver, beta=b, alpha_dot=ad, gamma_dot=gd,
                    rel_tol=1e-11, abs_tol=1e-13, max_step=100.0)
        t0 = time.perf_counter()
        paper.slave.doStep(0.0, 1000.0)
        sec = time.perf_counter() - t0
        drift = abs(paper.get("beta")[0] - b)
        row("9 steady precession 1000 s", solver, f"{abs(ad) * 1000 / (2 * math.pi):.0f} turns", f"lean drift {drift:.1e} rad",
            sec)

    # 10. inconsistent input: clear errors, no hang, no NaN
    for label, values in (("initial lean below beta_min", dict(beta=5e-4)), ("M = NaN", dict(M=float("nan"))),
                          ("R = inf", dict(R=float("inf"))), ("gamma_dot = 1e9 rad/s", dict(gamma_dot=1e9))):
        t0 = time.perf_counter()
        try:
            paper.start(solver="dopri5", **values)
            paper.slave.doStep(0.0, 1.0)
            result = "ran (unexpected)"
        except FMICallException as exc:
            result = f"fmi2Error in {exc.function}"
        except Exception as exc:  # fmpy refuses some values before the FMU sees them
            result = f"refused: {type(exc).__name__}"
        row("10 " + label, "dopri5", result, "-", time.perf_counter() - t0)
        paper.fresh = True
        paper.slave.freeInstance()
        paper = Fmu(paper_built.fmu)

    # 11. Euler's disk to its end: rolling, stick and slip (mu = mu_k = 0.3), flight where F_n reaches 0
    end = Fmu(build_fmu(load_scene(HERE / "scenes" / "euler_disk_end.toml"), tmp / "disk_end.fmu").fmu)
    # dopri5 at mu_k = mu: the stiff slip onset; 10 ms steps, each ended by the step budget at rel_tol 1e-9
    for solver, extra, h in (("rosenbrock", {}, 1e-3), ("dopri5", {}, 1e-2),
                             ("dopri5", {"rel_tol": 1e-12, "abs_tol": 1e-14}, 1e-2), ("dopri5", {"mu_k": 0.25}, 1e-3)):
        t, fell, sec, seen = disk_to_its_end(end, solver, h, **extra)
        label = "11 Euler's disk end, " + (f"mu_k {extra['mu_k']:g}" if "mu_k" in extra else
                                           f"rel_tol {extra.get('rel_tol', 1e-9):g}")
        how = "fell" if fell else "fmi2Error"
        row(label, solver, f"{how} at t = {t:.6f} s, slip {seen['slip']:.3f} s, {seen['changes']} changes",
            f"E {seen['balance']:.1e}, F_n >= {seen['Fn']:.2f} Mg", sec)

    # 13. the Painleve paradox: a drop that lands sliding at mu_k = 4 reaches D = 0 (F_n diverging)
    painleve_rows(row, tmp)

    print(f"\n{len(rows)} rows", file=sys.stderr)
    return 0


# examples/scenes/drop_bounce.toml thrown from 0.1 m, leaning and spinning, mu = 1.3 (family 13; the
# scene's other start values; tests/test_painleve.py THROWN)
PAINLEVE_DROP = dict(height=0.1, beta=1.17, beta_dot=-5.8, gamma_dot=29.0, alpha_dot=-5.0, mu=1.3)


def painleve_rows(row, tmp: Path) -> None:
    """Family 13: the throw PAINLEVE_DROP with mu_k = 1.15 (each solver) and 1, 1.5 s in 1 ms steps. The
    error column: D / W_nn - 0.05 at the end while sliding from the closed form for the wheel alone (docs/effects.md,
    "Sliding": 1 - mu_k e_lat sin(beta) cos(beta) / (k_diam + cos^2 beta)), 0 at a located stop."""
    drop = Fmu(build_fmu(load_scene(HERE / "scenes" / "drop_bounce.toml"), tmp / "drop.fmu").fmu)
    for solver, mu_k in (("dopri5", 1.15), ("dop853", 1.15), ("rosenbrock", 1.15), ("dopri5", 1.0)):
        t, stopped, sec = drop.run(1.5, 1e-3, solver=solver, mu_k=mu_k, **PAINLEVE_DROP)
        beta, s_long, s_lat = drop.get("beta", "slip_long", "slip_lat")
        flag = drop.slave.getBoolean([drop.vr["painleve_paradox"]])[0]
        c, slip = math.cos(beta), math.hypot(s_long, s_lat)
        share = 1 - mu_k * s_lat / slip * math.sin(beta) * c / (PAPER["k_diam"] + c * c) if slip else math.nan
        how = f"painleve at t = {t:.9f} s" if stopped and flag else f"ran to t = {t:g} s"
        error = f"D/W_nn - 0.05 {share - 0.05:+.1e}" if slip else "rolling at the end"
        row(f"13 Painleve drop, mu_k {mu_k:g}", solver, how, error, sec)


def disk_to_its_end(fmu: Fmu, solver: str, h: float, **values):
    """examples/scenes/euler_disk_end.toml in steps of h (s) to the fall or a refusal: (end time,
    fell at beta_min, seconds, {slip: first time sliding on the grid (s), changes: contact mode
    changes on the grid, balance: max |energy + dissipated_energy - start| / start energy, Fn: the
    least F_n / (M g)})."""
    fmu.start(solver=solver, **values)
    names = ("beta", "contact_mode", "F_n", "energy", "dissipated_energy")
    rows, t, t0 = [fmu.get(*names)], 0.0, time.perf_counter()
    try:
        while t < 12.0 - 1e-12:
            fmu.slave.doStep(t, h)
            t += h
            rows.append(fmu.get(*names))
    except FMICallException:
        t = fmu.slave.getRealStatus(fmi2LastSuccessfulTime)
    sec = time.perf_counter() - t0
    a = np.array(rows)
    mode, total = a[:, 1], a[:, 3] + a[:, 4]
    sliding = np.flatnonzero(mode > 0.5)
    return t, a[-1, 0] < 0.01, sec, {
        "slip": h * sliding[0] if len(sliding) else math.nan,
        "changes": int(np.sum(mode[1:] != mode[:-1])),
        "balance": float(np.max(np.abs(total - total[0])) / a[0, 3]),
        "Fn": float(np.min(a[:, 2]) / (0.45 * 9.81))}


if __name__ == "__main__":
    raise SystemExit(main())
