"""Solver taylor and the ensemble path against heyoka, measured in one run.

For each scenario (paper 20 s, long 1000 s, near_flat 5 s; the scenes of work_precision.py)
both integrate the SAME equations: heyoka gets the model's CasADi expression graph translated
operation by operation (parameters as numbers, which heyoka folds), gyrowheel its generated
Taylor kernel.  Error = max abs error of the 8 states at the end against heyoka in long double
at tol 1e-19 (a reference neither method under test produced).
  gyrowheel/taylor   one fmi2DoStep through fmpy (best over abs_tol = rel_tol * {1e-2, 1})
  gyrowheel/dop853   the same, for context
  heyoka             taylor_adaptive.propagate_until (setup = JIT compilation, printed apart)
  batch N            heyoka taylor_adaptive_batch of N vs gyrowheel's Ensemble of N, per trajectory
Prints the cheapest time to reach each target error and the ratio gyrowheel / heyoka (< 1:
gyrowheel faster), plus order and step counts.  Timings on a loaded machine are noisy: the
ratios come from one run and must be re-measured on a quiet machine.

    python benchmarks/taylor_vs_heyoka.py [--scenarios paper long near_flat] [--quick]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from fmi_slave import FmuRunner  # noqa: E402
from work_precision import SCENARIOS  # noqa: E402
from work_precision import best_time as best  # noqa: E402  (thread CPU time, as fmi_slave's)

from gyrowheel.fmu_build import build_fmu, parse_scene  # noqa: E402
from gyrowheel.fmu_build.codegen import optimised  # noqa: E402
from gyrowheel.taylor.ensemble import Ensemble  # noqa: E402
from gyrowheel.taylor.graph import OP_NAMES  # noqa: E402

TARGETS = (1e-4, 1e-7, 1e-10, 1e-12)
TOLS = [10.0 ** -k for k in range(3, 15)]  # rel_tol's range ends at 10 eps = 2.2e-15


def to_heyoka(f, xs, p, fp=float):
    """The ode's SX algorithm as heyoka expressions (same graph, parameters as numbers; an entry
    of p that is a heyoka expression, e.g. heyoka.par[k], is used as it is: a runtime parameter).

    Raises ValueError, before heyoka is imported, for an input other than t, x and p (inputs u,
    a hoisted ode's constants c): heyoka would otherwise integrate a different system.
    """
    for j in range(f.n_in()):
        if j not in (0, 1, 3) and f.nnz_in(j) > 0:
            raise ValueError(f"to_heyoka: input {f.name_in(j)!r} of {f.name()} is neither t, x nor p "
                             "(pass the whole right-hand side: gyrowheel.fmu_build.codegen.taylor_ode)")
    import heyoka as hy
    un = {"neg": lambda a: -a, "twice": lambda a: 2.0 * a, "sq": lambda a: a * a, "sqrt": hy.sqrt,
          "sin": hy.sin, "cos": hy.cos, "tanh": hy.tanh, "exp": hy.exp, "log": hy.log,
          "inv": lambda a: 1.0 / a}
    bi = {"add": lambda a, b: a + b, "sub": lambda a, b: a - b, "mul": lambda a, b: a * b,
          "div": lambda a, b: a / b, "pow": lambda a, b: a ** b, "constpow": lambda a, b: a ** b}
    work, out = {}, [None] * f.numel_out(0)
    for k in range(f.n_instructions()):
        op, i, o = OP_NAMES[f.instruction_id(k)], f.instruction_input(k), f.instruction_output(k)
        if op == "input":
            if i[0] == 3:
                v = p[i[1]]
                work[o[0]] = v if isinstance(v, hy.expression) else hy.expression(fp(v))
            else:
                work[o[0]] = xs[i[1]] if i[0] == 1 else hy.time
        elif op == "const":
            work[o[0]] = hy.expression(fp(f.instruction_constant(k)))
        elif op == "output":
            out[o[1]] = work[i[0]]
        elif op in un:
            work[o[0]] = un[op](work[i[0]])
        else:
            work[o[0]] = bi[op](work[i[0]], work[i[1]])
    return out


class SameGraph:
    """One scenario's FMU and heyoka on the FMU's own graph (to_heyoka), with the reference.

    f: the ode (optimised SX Function); xs: heyoka's state variables; p: parameter values;
    s0: start values; x0: initial state (nx,); out(x): the 8 state outputs (x, y, alpha, beta,
    gamma and the rates) at the stop time; ref: out of heyoka in long double at tol 1e-19,
    the reference every method's error is measured against.
    """

    def __init__(self, built, stop: float):
        import heyoka as hy
        fns = built.spec.functions()
        self.p = [q.start for q in built.spec.parameters]
        self.s0 = [q.start for q in built.spec.starts]
        self.x0 = np.array(fns["init"](self.s0, self.p)).ravel()
        self.f = optimised(fns["ode"])
        self.xs = hy.make_vars(*[f"x{i}" for i in range(self.x0.size)])
        self.names = [q.name for q, _ in built.spec.outputs][:8]
        rows = [[q.name for q, _ in built.spec.outputs].index(n) for n in self.names]
        self.out = lambda x: np.array(fns["out"](stop, x, [], self.p)).ravel()[rows]  # noqa: E731
        ld = np.longdouble
        ta_ref = hy.taylor_adaptive(list(zip(self.xs, to_heyoka(self.f, self.xs, self.p, ld))),
                                    self.x0.astype(ld), tol=ld(1e-19), fp_type=ld)
        ta_ref.propagate_until(ld(stop))
        self.ref = self.out(np.array(ta_ref.state, dtype=float))

    def heyoka(self, tol: float):
        """heyoka.taylor_adaptive on the same graph at tolerance tol (JIT-compiled here)."""
        import heyoka as hy
        return hy.taylor_adaptive(list(zip(self.xs, to_heyoka(self.f, self.xs, self.p))), self.x0, tol=tol)

    def time_heyoka(self, tol: float, stop: float, repeat: int):
        """heyoka from x0 to stop at tol: (CPU seconds, best of repeat; error against ref;
        the integrator; propagate_until's result).  JIT compilation is not timed."""
        ta = self.heyoka(tol)

        def prop():
            ta.time, ta.state[:] = 0.0, self.x0
            return ta.propagate_until(stop)
        sec, res = best(prop, repeat)
        return sec, float(np.max(np.abs(self.out(ta.state) - self.ref))), ta, res


def cheapest(points, target):
    ok = [s for s, e in points if e <= target]
    return min(ok) if ok else None


def rows_against_heyoka(pts: dict, targets) -> list[str]:
    """Markdown rows: each method's cheapest time to reach each target error (ms, ratio to the
    "heyoka" entry of pts) and its error floor; pts maps a method to (seconds, error) points."""
    lines = []
    for method, points in pts.items():
        cells = []
        for t in targets:
            s, peer = cheapest(points, t), cheapest(pts["heyoka"], t)
            cells.append("-" if s is None else f"{s * 1e3:.3g} ms" + (f" ({s / peer:.2f}x)" if peer else ""))
        lines.append(f"| {method} | " + " | ".join(cells) + f" | {min(e for _, e in points):.1e} |")
    return lines


def run(name: str, work: Path, repeat: int, batch: int) -> list[str]:
    import heyoka as hy
    text, stop = SCENARIOS[name]
    built = build_fmu(parse_scene(f'[model]\nname = "tl_{name}"\n' + text, f"{name}.toml"),
                      work / f"{name}.fmu", build_dir=work / name, taylor=True)
    g = SameGraph(built, stop)
    f, xs, p, s0, x0, names, out, ref = g.f, g.xs, g.p, g.s0, g.x0, g.names, g.out, g.ref
    lines = [f"### {name} ({stop:g} s)", ""]

    runner = FmuRunner(built.fmu)
    pts = {"gyrowheel/taylor": [], "gyrowheel/dop853": [], "heyoka": [], f"heyoka batch {batch}": [],
           f"gyrowheel ensemble {batch}": []}
    info = []
    for tol in TOLS:
        for solver, label in ((6, "gyrowheel/taylor"), (5, "gyrowheel/dop853")):
            for atol in ((tol * 1e-2, tol) if solver == 6 else (tol * 1e-2,)):
                secs, v = float("inf"), None
                try:
                    for _ in range(repeat):
                        v = runner.one_step(stop, names, solver=solver, rel_tol=tol, abs_tol=atol,
                                            max_step=stop)
                        secs = min(secs, runner.last_seconds)
                except Exception as exc:  # noqa: BLE001  (a setting a solver cannot do)
                    print(f"  {label} {tol:g}: {exc}", file=sys.stderr)
                    continue
                pts[label].append((secs, float(np.max(np.abs(np.array(v) - ref)))))
        t0 = time.perf_counter()
        g.heyoka(tol)
        setup = time.perf_counter() - t0  # wall time of the JIT compilation (not compared)
        sec, err, ta, res = g.time_heyoka(tol, stop, repeat)
        pts["heyoka"].append((sec, err))
        info.append(f"tol {tol:.0e}: heyoka order {ta.order}, {res[3]} steps, setup {setup:.2f} s")
        tb = hy.taylor_adaptive_batch(list(zip(xs, to_heyoka(f, xs, p))), np.tile(x0[:, None], (1, batch)), tol=tol)

        def propb():
            tb.set_time(0.0)
            tb.state[:] = x0[:, None]
            tb.propagate_until(stop)
        sec, _ = best(propb, repeat)
        err = max(float(np.max(np.abs(out(tb.state[:, j]) - ref))) for j in range(batch))
        pts[f"heyoka batch {batch}"].append((sec / batch, err))
    ens = Ensemble(built.fmu, lanes=4, cache=work / "ens")
    for tol in TOLS:
        for atol in (tol * 1e-2, tol):
            sec, r = best(lambda: ens.run(stop, starts=np.tile(s0, (batch, 1)), rel_tol=tol, abs_tol=atol), repeat)
            err = float(np.max(np.abs(np.array([out(x) for x in r.x_final]) - ref)))
            pts[f"gyrowheel ensemble {batch}"].append((sec / batch, err))
            if atol == tol * 1e-2:
                info.append(f"tol {tol:.0e}: gyrowheel taylor {int(r.steps[0])} steps")
    lines.append("| method | " + " | ".join(f"err <= {t:g}" for t in TARGETS) + " |")
    lines.append("|---|" + "---|" * len(TARGETS))
    for method, points in pts.items():
        cells = []
        for t in TARGETS:
            s = cheapest(points, t)
            peer = cheapest(pts["heyoka batch %d" % batch if ("batch" in method or "ensemble" in method)
                                else "heyoka"], t)
            cells.append("-" if s is None else f"{s * 1e3:.3g} ms" + (f" ({s / peer:.2f}x)" if peer else ""))
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    lines += ["", "In brackets: time / heyoka's (single, or batch for batch and ensemble rows).",
              "floor: gyrowheel/taylor %.1e, heyoka %.1e" % (min(e for _, e in pts["gyrowheel/taylor"]),
                                                            min(e for _, e in pts["heyoka"])), ""]
    lines += info
    runner.free()
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", nargs="*", default=["paper", "long", "near_flat"],
                        choices=["paper", "long", "near_flat"])
    parser.add_argument("--quick", action="store_true", help="no repetitions")
    parser.add_argument("--batch", type=int, default=4)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="gw-taylor-bench-") as tmp:
        for name in args.scenarios:
            print("\n".join(run(name, Path(tmp), 1 if args.quick else 3, args.batch)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
