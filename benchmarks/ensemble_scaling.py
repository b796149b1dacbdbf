"""The ensemble path's time per trajectory against heyoka's batch mode, measured in one run.

Scenario paper (examples/scenes/paper_earth.toml, 20 s; --scenario long, near_flat:
benchmarks/work_precision.py).  N trajectories (N = 8, 16, 64) spread over the start values
beta0 70-85 deg and gamma_dot0 5-8 rad/s (trajectory i of N: beta0 = 70 + 15 (i + 1/2) / N deg,
gamma_dot0 = 5 + 3 frac((i + 1/2) phi) rad/s, phi the golden ratio, so that the N pairs fill the
rectangle), and a variant "M, R +-20 %" with also the mass and the radius per trajectory at
(1 + 0.2 u) times the scene's, u in [-1, 1] stratified the same way (frac((i + 1/2) sqrt 2),
frac((i + 1/2) sqrt 3)).
  gyrowheel  gyrowheel.taylor.ensemble.Ensemble(lanes=W).run on the N trajectories, W = the CPU's
             count (gyrowheel.taylor.lanes.cpu_lanes) and the other of 4 and 8, "(default)" the
             count Ensemble(fmu) takes on this machine (ensemble_lanes: on AVX-512F 8 or 4 as
             their kernels measure): the whole call (marshalling, the lanes' initialisation,
             integration), abs_tol = rel_tol x {1e-2, 1}
  heyoka     taylor_adaptive_batch of heyoka.recommended_simd_size() (8 on AVX-512) on the FMU's own
             expression graph (taylor_vs_heyoka.to_heyoka; M and R as runtime parameters,
             heyoka.par, in the variant), the N trajectories in consecutive batches as a user
             loops over them: set time, state (and parameters), propagate_until, read the state;
             its JIT compilation is not timed
Error: the largest absolute error of the final states over the N trajectories, against heyoka in
80-bit long double at tolerance 1e-19 on the same graph, each trajectory with its own start and
parameters.  For each target error (1e-4, 1e-7, 1e-10, 1e-12) and N the cheapest setting of a
grid of tolerances (work_precision.tolerance_grid: --per-decade per decade, 4 by default, the same
for both) that reaches it counts, per method.  Every time is thread CPU time,
best of --repeat, all settings of all methods interleaved in each repetition; ratios compare
per-trajectory times in this one run.  The table: time per trajectory of each method and
heyoka / gyrowheel's default width (above 1: the ensemble faster; heyoka / the fastest width
where --lanes leaves the default out).
Also the fixed cost of one run: N = 1 to t_end = 1 ms (a handful of steps), and N = 4 to
1e-9 s at rel_tol 1e-4 (what a run pays besides its steps).
--against REF (a git revision, e.g. main, or a checkout directory; either layout of the project:
benchmarks/ref_tree.py) also times REF's ensemble (the same scene built by REF's whole tree: its
generator, c_src/ and its Ensemble; 4 lanes), interleaved: before and after a change in one run.

    python benchmarks/ensemble_scaling.py [--scenario paper] [--n 8 16 64] [--lanes 8 4]
        [--variants nominal mass_radius] [--targets 1e-4 1e-10] [--repeat 3] [--against main]
        [--defines GW_NO_CLONES=1]
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from ref_tree import RefTree  # noqa: E402
from taylor_vs_heyoka import SameGraph, to_heyoka  # noqa: E402
from work_precision import PER_DECADE, SCENARIOS, best_time, per_decade_option, tolerance_grid  # noqa: E402

from gyrowheel.fmu_build import build_fmu, parse_scene  # noqa: E402
from gyrowheel.taylor.ensemble import Ensemble  # noqa: E402
from gyrowheel.taylor.lanes import cpu_lanes, ensemble_lanes  # noqa: E402

VARIANTS = {"nominal": "beta0, gamma_dot0 spread", "mass_radius": "beta0, gamma_dot0 spread, M, R +-20 %"}
SPREAD = ("M", "R")  # the parameters of the variant mass_radius


def best(fn, repeat: int) -> float:
    """CPU seconds of the calling thread, best of repeat (work_precision.best_time)."""
    return best_time(fn, repeat)[0]


def best_of_many(fn, k: int) -> float:
    """CPU seconds of the calling thread per call, k calls in a row (a call of a few us is
    below the clock's resolution)."""
    t0 = time.thread_time()
    for _ in range(k):
        fn()
    return (time.thread_time() - t0) / k


def spread(n: int, s0, start_names, p0, param_names, vary: bool) -> tuple[np.ndarray, np.ndarray]:
    """(starts (n, ns), parameters (n, np)) of the n trajectories (the module's docstring)."""
    i = np.arange(n) + 0.5
    starts, params = np.tile(np.asarray(s0, float), (n, 1)), np.tile(np.asarray(p0, float), (n, 1))
    starts[:, start_names.index("beta")] = np.radians(70.0 + 15.0 * i / n)
    starts[:, start_names.index("gamma_dot")] = 5.0 + 3.0 * np.modf(i * (1 + math.sqrt(5)) / 2)[0]
    if vary:
        for name, irrational in zip(SPREAD, (math.sqrt(2), math.sqrt(3))):
            u = 2.0 * np.modf(i * irrational)[0] - 1.0
            params[:, param_names.index(name)] *= 1.0 + 0.2 * u
    return starts, params


class HeyokaBatch:
    """heyoka's batch mode on the FMU's graph, `simd` trajectories per batch, the parameters SPREAD
    as heyoka.par (so one compilation serves every trajectory), compiled per tolerance."""

    def __init__(self, g: SameGraph, param_names, simd: int):
        import heyoka as hy
        self.g, self.simd = g, simd
        self.k = [param_names.index(n) for n in SPREAD]
        p = list(g.p)
        for j, k in enumerate(self.k):
            p[k] = hy.par[j]
        self.eqs = list(zip(g.xs, to_heyoka(g.f, g.xs, p)))
        self.compiled: dict[float, object] = {}

    def integrator(self, tol: float):
        import heyoka as hy
        if tol not in self.compiled:
            x0 = np.tile(self.g.x0[:, None], (1, self.simd))
            pars = np.tile(np.array([self.g.p[k] for k in self.k])[:, None], (1, self.simd))
            self.compiled[tol] = hy.taylor_adaptive_batch(self.eqs, x0, tol=tol, pars=pars)
        return self.compiled[tol]

    def runner(self, tol: float, x0s: np.ndarray, params: np.ndarray, stop: float):
        """A call that integrates every trajectory (x0s (nx, N), params (N, np); N a multiple of
        simd) and returns the final states (N, nx)."""
        tb, w = self.integrator(tol), self.simd
        pars = params[:, self.k].T.copy()
        n = x0s.shape[1]
        out = np.empty((n, x0s.shape[0]))

        def run():
            for c in range(0, n, w):
                tb.set_time(0.0)
                tb.state[:] = x0s[:, c:c + w]
                tb.pars[:] = pars[:, c:c + w]
                tb.propagate_until(stop)
                out[c:c + w] = tb.state.T
            return out
        return run


def references(g: SameGraph, param_names, x0s: np.ndarray, params: np.ndarray, stop: float) -> np.ndarray:
    """Final states (N, nx) by heyoka in long double at tol 1e-19 on the same graph."""
    import heyoka as hy
    ld = np.longdouble
    k = [param_names.index(n) for n in SPREAD]
    p = list(g.p)
    for j, kk in enumerate(k):
        p[kk] = hy.par[j]
    ta = hy.taylor_adaptive(list(zip(g.xs, to_heyoka(g.f, g.xs, p, ld))), g.x0.astype(ld), tol=ld(1e-19),
                            fp_type=ld, pars=np.array([g.p[kk] for kk in k], dtype=ld))
    out = np.empty((x0s.shape[1], x0s.shape[0]))
    for j in range(x0s.shape[1]):
        ta.time = ld(0.0)
        ta.state[:] = x0s[:, j].astype(ld)
        ta.pars[:] = params[j, k].astype(ld)
        ta.propagate_until(ld(stop))
        out[j] = np.asarray(ta.state, dtype=float)
    return out


def ensemble_at(ref: str, scene: str, work: Path, lanes: int = 4):
    """The Ensemble of version ref (a git revision or a checkout directory) on the same scene: its
    whole tree, its generator building the FMU (in a subprocess: the generated C and the runtime
    change together, e.g. the event indicators' hoisted part), its Ensemble (loaded into this
    process) compiling and running it."""
    tree = RefTree(ref, work)
    out = Path(tempfile.mkdtemp(prefix="ref-fmu-", dir=work)) / "ref.fmu"
    tree.python(f"import sys; from pathlib import Path; from {tree.module('gyrowheel.fmu_build')} import build_fmu, "
                "parse_scene; build_fmu(parse_scene(sys.argv[1], 'scene.toml'), Path(sys.argv[2]), "
                "build_dir=Path(sys.argv[3]), taylor=True)", scene, str(out), str(out.parent / "build"))
    return tree.load("gyrowheel.taylor.ensemble").Ensemble(out, lanes=lanes, cache=work / "ens")


def measure(methods: dict, repeat: int) -> dict:
    """{(method, setting): (seconds, final states)}: every setting of every method once per
    repetition, interleaved, the best time kept."""
    out = {key: (float("inf"), None) for key in methods}
    for _ in range(repeat):
        for key, run in methods.items():
            t0 = time.thread_time()
            x = run()
            sec = time.thread_time() - t0
            out[key] = (min(sec, out[key][0]), np.array(x, copy=True))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="*", default=[8, 16, 64])
    ap.add_argument("--lanes", type=int, nargs="*", default=None,
                    help="ensemble widths to time (default: the CPU's count and the other of 4 and 8)")
    ap.add_argument("--variants", nargs="*", default=list(VARIANTS), choices=list(VARIANTS))
    ap.add_argument("--targets", type=float, nargs="*", default=[1e-4, 1e-7, 1e-10, 1e-12])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--per-decade", type=per_decade_option, default=PER_DECADE,
                    help=f"tolerances per decade of the grid (default {PER_DECADE})")
    ap.add_argument("--scenario", default="paper", choices=["paper", "long", "near_flat"])
    ap.add_argument("--against", default=None, help="a git revision whose ensemble is timed too")
    ap.add_argument("--defines", nargs="*", default=[], metavar="NAME=VALUE",
                    help="C macros of gyrowheel's ensemble builds, e.g. GW_NO_CLONES=1: the portable code "
                         "a CPU without AVX2 runs")
    args = ap.parse_args()
    tols = tolerance_grid(args.per_decade)
    defines = {}
    for item in args.defines:
        name, sep, value = item.partition("=")
        if not sep:
            ap.error(f"--defines: {item!r} is not NAME=VALUE")
        defines[name] = int(value) if value.lstrip("-").isdigit() else value
    import heyoka as hy

    simd = hy.recommended_simd_size()
    if any(n % simd for n in args.n):
        ap.error(f"--n: every N must be a multiple of heyoka's batch size {simd}")
    cpu = cpu_lanes()
    lanes = args.lanes or [cpu, 4 if cpu != 4 else 8]
    text, stop = SCENARIOS[args.scenario]
    with tempfile.TemporaryDirectory(prefix="gw-ens-scaling-") as tmp:
        work = Path(tmp)
        scene = f'[model]\nname = "ens_{args.scenario}"\n' + text
        built = build_fmu(parse_scene(scene, "scene.toml"), work / "scene.fmu", build_dir=work / "b", taylor=True)
        g = SameGraph(built, stop)
        fns = built.spec.functions()
        start_names = [q.name for q in built.spec.starts]
        param_names = [q.name for q in built.spec.parameters]
        default = ensemble_lanes(built.fmu, work / "ens", defines or None)  # what Ensemble(fmu) takes
        ens = {f"gyrowheel W={w}" + (" (default)" if w == default else ""):
               Ensemble(built.fmu, lanes=w, cache=work / "ens", defines=defines or None) for w in lanes}
        # the ratio: heyoka over Ensemble(fmu)'s width, or over the fastest width timed without it
        ours_cols = [c for c in ens if c.endswith("(default)")] or list(ens)
        if args.against:
            ens[f"{args.against} W=4"] = ensemble_at(args.against, scene, work)
        hb = HeyokaBatch(g, param_names, simd)
        heyoka_name = f"heyoka batch {simd}"
        cols = list(ens) + [heyoka_name]
        print(f"### ensemble scaling, {args.scenario} scenario ({stop:g} s), time per trajectory (ms)\n")
        print(f"CPU lanes (gyrowheel.taylor.lanes.cpu_lanes): {cpu}; Ensemble(fmu)'s lanes on this machine "
              f"(ensemble_lanes): {default}; heyoka.recommended_simd_size(): {simd}"
              + (f"; gyrowheel built with {defines}" if defines else "") + "\n")
        ratio_name = "heyoka / gyrowheel default" if ours_cols != list(ens) else "heyoka / gyrowheel best"
        print("| trajectories | target | N | " + " | ".join(cols) + f" | {ratio_name} |")
        print("|---|---|---|" + "---|" * (len(cols) + 1))
        summary = {}
        for variant in args.variants:
            for n in args.n:
                starts, params = spread(n, g.s0, start_names, g.p, param_names, variant == "mass_radius")
                x0s = np.array([np.array(fns["init"](starts[j], params[j])).ravel() for j in range(n)]).T
                ref = references(g, param_names, x0s, params, stop)
                pdict = {name: params[:, k] for k, name in enumerate(param_names) if name in SPREAD}
                methods = {}
                for name, e in ens.items():
                    for tol in tols:
                        for af in (1e-2, 1.0):
                            methods[name, tol, af] = (lambda e=e, tol=tol, af=af: e.run(
                                stop, starts=starts, parameters=pdict, rel_tol=tol, abs_tol=tol * af).x_final)
                for tol in tols:
                    methods[heyoka_name, tol, 0.0] = hb.runner(tol, x0s, params, stop)
                timed = measure(methods, args.repeat)
                for target in args.targets:
                    cheapest = {}
                    for (name, tol, af), (sec, x) in timed.items():
                        if float(np.max(np.abs(x - ref))) <= target and sec < cheapest.get(name, (np.inf,))[0]:
                            cheapest[name] = (sec, tol)
                    ours = [cheapest[c][0] for c in ours_cols if c in cheapest]
                    cells = " | ".join(f"{cheapest[c][0] / n * 1e3:.4f} (tol {cheapest[c][1]:.0e})" if c in cheapest
                                       else "-" for c in cols)
                    ratio = (cheapest[heyoka_name][0] / min(ours)) if ours and heyoka_name in cheapest else None
                    summary[variant, target, n] = ratio
                    print(f"| {VARIANTS[variant]} | {target:g} | {n} | {cells} | "
                          f"{'-' if ratio is None else f'{ratio:.2f}'} |", flush=True)
        print(f"\n{ratio_name}, per trajectory (above 1: the ensemble faster):\n")
        print("| trajectories | N | " + " | ".join(f"{t:g}" for t in args.targets) + " |")
        print("|---|---|" + "---|" * len(args.targets))
        for variant in args.variants:
            for n in args.n:
                cells = " | ".join("-" if summary[variant, t, n] is None else f"{summary[variant, t, n]:.2f}"
                                   for t in args.targets)
                print(f"| {VARIANTS[variant]} | {n} | {cells} |")
        print("\nfixed cost of one run (N = 1, t_end = 1 ms, rel_tol 1e-10; N = 4, t_end = 1e-9 s, rel_tol "
              "1e-4: Python, marshalling, the lanes' initialisation, one step):")
        starts4, _ = spread(4, g.s0, start_names, g.p, param_names, False)
        fixed = {w: (lambda w=w: ens[w].run(1e-3, rel_tol=1e-10)) for w in ens}
        short = {w: (lambda w=w: ens[w].run(1e-9, starts=starts4, rel_tol=1e-4, abs_tol=1e-6)) for w in ens}
        t1, t4 = dict.fromkeys(ens, float("inf")), dict.fromkeys(ens, float("inf"))
        for _ in range(args.repeat * 4):  # interleaved, best of
            for w in ens:
                t1[w] = min(t1[w], best(fixed[w], 1))
                t4[w] = min(t4[w], best_of_many(short[w], 200))
        for w in ens:
            print(f"  {w}: {t1[w] * 1e3:.3f} ms; N = 4 to 1e-9 s: {t4[w] * 1e6:.1f} us")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
