"""The ensemble path's time per trajectory against heyoka's batch mode, measured in one run.

Scenario paper (earth, 20 s; --scenario long, near_flat: benchmarks/work_precision.py).  For each target error (max abs error of the 8 states at 20 s
against heyoka in long double at tol 1e-19) the cheapest tolerance reaching it is found first,
on one trajectory, for each method separately (a grid of half decades; gyrowheel: abs_tol =
rel_tol * {1e-2, 1}); then N trajectories (gamma_dot spread over 6 +- 1 %, so that the lanes
take different steps) are timed at each method's 3 cheapest settings reaching the target (the
same for both methods: one trajectory's timing is noisy, and the cheapest at N = 1 need not be the
cheapest at N), the best of them counted:
  gyrowheel  gyrowheel.taylor.ensemble.Ensemble(lanes=W).run, W = 1, 4, 8 (the whole call: marshalling,
             instances' initialisation, integration)
  heyoka     taylor_adaptive_batch of N (N = 1: taylor_adaptive), propagate_until, state reset
             included; its JIT compilation is not counted
Every time is thread CPU time, best of --repeat, the methods interleaved; ratios compare
per-trajectory times in this one run (absolute times on a loaded machine are not to be quoted).
Also the fixed cost of one run: N = 1 to t_end = 1 ms (a handful of steps), and N = 4 to
1e-9 s at rel_tol 1e-4 (what a run of the 1e-4 rows pays besides its steps).
--against REF (a git revision, e.g. main, or a checkout directory; either layout of the project:
benchmarks/ref_tree.py) also times REF's ensemble (the same scene built by REF's whole tree: its
generator, c_src/ and its Ensemble; 4 lanes, at gyrowheel's tolerances), interleaved: before and
after a change in the same run.

    python benchmarks/ensemble_scaling.py [--scenario paper] [--n 1 4 16 64] [--lanes 1 4 8]
        [--targets 1e-4 1e-10] [--against main]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from ref_tree import RefTree  # noqa: E402
from taylor_vs_heyoka import SameGraph, to_heyoka  # noqa: E402
from work_precision import SCENARIOS, best_time  # noqa: E402

from gyrowheel.fmu_build import build_fmu, parse_scene  # noqa: E402
from gyrowheel.taylor.ensemble import Ensemble  # noqa: E402

TOLS = [10.0 ** -(k / 2) for k in range(6, 30)]  # 1e-3 .. 10^-14.5
# the calibration's timing is one trajectory, best of CALIBRATION_REPEAT; its CANDIDATES cheapest settings
# reaching a target are then timed at every N (a noisy calibration no longer decides the setting)
CALIBRATION_REPEAT, CANDIDATES = 5, 3


def best(fn, repeat: int) -> float:
    """CPU seconds of the calling thread, best of repeat (work_precision.best_time)."""
    return best_time(fn, repeat)[0]


def best_of_many(fn, k: int) -> float:
    """CPU seconds of the calling thread per call, k calls in a row (a call of a few us is
    below the clock's resolution)."""
    import time
    t0 = time.thread_time()
    for _ in range(k):
        fn()
    return (time.thread_time() - t0) / k


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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="*", default=[1, 4, 16, 64])
    ap.add_argument("--lanes", type=int, nargs="*", default=[1, 4, 8])
    ap.add_argument("--targets", type=float, nargs="*", default=[1e-4, 1e-7, 1e-10, 1e-12])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--scenario", default="paper", choices=["paper", "long", "near_flat"])
    ap.add_argument("--against", default=None, help="a git revision whose ensemble is timed too")
    args = ap.parse_args()
    import heyoka as hy

    text, stop = SCENARIOS[args.scenario]
    with tempfile.TemporaryDirectory(prefix="gw-ens-scaling-") as tmp:
        work = Path(tmp)
        scene = f'[model]\nname = "ens_{args.scenario}"\n' + text
        built = build_fmu(parse_scene(scene, "scene.toml"), work / "scene.fmu", build_dir=work / "b", taylor=True)
        g = SameGraph(built, stop)  # heyoka on the FMU's graph and the long-double reference
        fns, p, x0, s0 = built.spec.functions(), g.p, g.x0, np.array(g.s0)
        eqs = list(zip(g.xs, to_heyoka(g.f, g.xs, p)))
        ens = {w: Ensemble(built.fmu, lanes=w, cache=work / "ens") for w in args.lanes}
        cols = [f"gyrowheel W={w}" for w in args.lanes]
        if args.against:
            ens[args.against] = ensemble_at(args.against, scene, work)
            cols.append(f"{args.against} W=4")
        i_spin = [q.name for q in built.spec.starts].index("gamma_dot")

        # calibration: the cheapest tolerance per target, one trajectory each
        gw_pts, hy_pts = [], []
        e1 = ens[args.lanes[0]]
        for tol in TOLS:
            for af in (1e-2, 1.0):
                r = e1.run(stop, rel_tol=tol, abs_tol=tol * af)
                sec = best(lambda: e1.run(stop, rel_tol=tol, abs_tol=tol * af), CALIBRATION_REPEAT)
                gw_pts.append((sec, float(np.max(np.abs(g.out(r.x_final[0]) - g.ref))), tol, af))
            sec, err, _, _ = g.time_heyoka(tol, stop, CALIBRATION_REPEAT)
            hy_pts.append((sec, err, tol))

        def pick(points, target):
            """The CANDIDATES cheapest settings reaching target on one trajectory, cheapest first."""
            return sorted(q for q in points if q[1] <= target)[:CANDIDATES]

        print(f"### ensemble scaling, {args.scenario} scenario ({stop:g} s), time per trajectory (ms)\n")
        print("| target | N | " + " | ".join(cols) + " | heyoka batch N | best W / heyoka |"
              + (f" {args.against} / heyoka |" if args.against else ""))
        print("|---|---|" + "---|" * (len(cols) + 2 + bool(args.against)))
        for target in args.targets:
            gs, hs = pick(gw_pts, target), pick(hy_pts, target)
            if not gs or not hs:
                print(f"| {target:g} | - | not reached (gyrowheel {bool(gs)}, heyoka {bool(hs)}) |")
                continue
            for n in args.n:
                spin = s0[i_spin] * (1.0 + 0.01 * np.linspace(-1.0, 1.0, n) if n > 1 else np.ones(1))
                starts = np.tile(s0, (n, 1))
                starts[:, i_spin] = spin
                x0s = np.array([np.array(fns["init"](row, p)).ravel() for row in starts]).T
                hy_runs = {}
                for h in hs:
                    if n == 1:
                        tb = hy.taylor_adaptive(eqs, x0, tol=h[2])

                        def hy_run(tb=tb):
                            tb.time, tb.state[:] = 0.0, x0
                            tb.propagate_until(stop)
                    else:
                        tb = hy.taylor_adaptive_batch(eqs, x0s.copy(), tol=h[2])

                        def hy_run(tb=tb):
                            tb.set_time(0.0)
                            tb.state[:] = x0s
                            tb.propagate_until(stop)
                    hy_runs[h[2]] = hy_run
                # each method at each of its candidate settings, all interleaved; its best counts
                times = {(w, q[2], q[3]): float("inf") for w in ens for q in gs}
                t_hys = {tol: float("inf") for tol in hy_runs}
                for _ in range(args.repeat):
                    for (w, tol, af) in times:
                        times[w, tol, af] = min(times[w, tol, af], best(
                            lambda: ens[w].run(stop, starts=starts, rel_tol=tol, abs_tol=tol * af), 1))
                    for tol, run in hy_runs.items():
                        t_hys[tol] = min(t_hys[tol], best(run, 1))
                t_hy, h_tol = min((t, tol) for tol, t in t_hys.items())
                per_w = {w: min((t, tol) for (v, tol, _), t in times.items() if v == w) for w in ens}
                bw, g_tol = min(per_w[w] for w in args.lanes)
                cells = " | ".join(f"{per_w[w][0] / n * 1e3:.4f}" for w in ens)
                print(f"| {target:g} (gw tol {g_tol:.1e}, heyoka {h_tol:.1e}) | {n} | {cells} | "
                      f"{t_hy / n * 1e3:.4f} | {bw / t_hy:.2f}x |"
                      + (f" {per_w[args.against][0] / t_hy:.2f}x |" if args.against else ""), flush=True)
        print("\nfixed cost of one run (N = 1, t_end = 1 ms, rel_tol 1e-10; N = 4 as at 1e-4 above, "
              "t_end = 1e-9 s: Python, marshalling, the lanes' initialisation, one step):")
        starts4 = np.tile(s0, (4, 1))
        starts4[:, i_spin] = s0[i_spin] * (1.0 + 0.01 * np.linspace(-1.0, 1.0, 4))
        fixed = {w: (lambda w=w: ens[w].run(1e-3, rel_tol=1e-10)) for w in ens}
        short = {w: (lambda w=w: ens[w].run(1e-9, starts=starts4, rel_tol=1e-4, abs_tol=1e-6))
                 for w in ens}
        t1, t4 = dict.fromkeys(ens, float("inf")), dict.fromkeys(ens, float("inf"))
        for _ in range(args.repeat * 4):  # interleaved, best of
            for w in ens:
                t1[w] = min(t1[w], best(fixed[w], 1))
                t4[w] = min(t4[w], best_of_many(short[w], 200))
        for w in ens:
            name = f"W = {w}" if w in args.lanes else f"{w} (W = 4)"
            print(f"  {name}: {t1[w] * 1e3:.3f} ms; N = 4 to 1e-9 s: {t4[w] * 1e6:.1f} us")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
