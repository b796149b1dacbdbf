"""What a sweep costs on Dask, measured against a plain in-process loop in the same run.

    python benchmarks/sweep_scaling.py [--points 2000] [--repeats 3] [--png results/bench/sweep_cost.png]

Prints, for points of about 1 ms (the paper's earth wheel, 20 s, dopri5, output every 1 s):
  1. Dask overhead per point: a LocalCluster of 1 worker process against the same points in a
     plain loop over one FMU instance in this process (target <= 10%);
  2. throughput from 1 to 2 workers (target >= 1.8x on 2 cores);
  3. the scaling model's constants: points/s per worker, the scheduler's cost per task (tasks
     of one near-empty point), the cluster's start-up, the overhead against the batch size;
  4. how the cost of one point grows with the horizon and the tolerance, and of a map with the
     number of points (in-process), drawn to --png.
Each figure is the best of --repeats runs (other load on the machine only slows a run down).
Cluster start-up is measured separately and excluded from the per-point figures.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

from gyrowheel.studies import plan_sweep  # noqa: E402
from gyrowheel.studies.execute import run_dask, run_loop  # noqa: E402
from gyrowheel.studies.output import TableWriter  # noqa: E402
from gyrowheel.studies.target import FmuTarget  # noqa: E402

ONE_MS = dict(stop_time=20.0, output_interval=1.0)


def plan(target, n: int, **kw):
    k = max(1, int(round(n ** 0.5)))
    grid = {"beta_deg": f"70:89:{k}", "gamma_dot": f"4:12:{-(-n // k)}"}
    p = plan_sweep(target, grid=grid, metrics=["survived", "fall_time", "max_lean"], **{**ONE_MS, **kw})
    p.inputs, p.values = p.inputs.iloc[:n], p.values[:n]
    return p


def best(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def loop_seconds(p, repeats: int) -> float:
    return best(lambda: run_loop(p, TableWriter(None, p.inputs)), repeats)


def dask_seconds(p, client, repeats: int, batch_size=None) -> float:
    return best(lambda: run_dask(p, TableWriter(None, p.inputs), client=client, batch_size=batch_size), repeats)


def cpu_seconds(fn, client=None) -> float:
    """CPU time of fn() in this process (client, and a LocalCluster's scheduler) plus its workers.

    Unlike wall time, it hardly changes when other programs load the cores, so the overhead
    measured in CPU seconds per point is the figure to trust on a busy machine.
    """
    def workers() -> float:
        return sum(client.run(time.process_time).values()) if client is not None else 0.0
    w0, t0 = workers(), time.process_time()
    fn()
    return time.process_time() - t0 + workers() - w0


def cluster(n: int):
    """The LocalCluster `gyrowheel sweep --workers n` starts (same settings), kept for several runs."""
    import dask
    from distributed import Client, LocalCluster

    from gyrowheel.studies.execute import LOCAL_CONFIG
    t0 = time.perf_counter()
    with dask.config.set(LOCAL_CONFIG):
        c = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                         dashboard_address=":0")
    client = Client(c)
    client.wait_for_workers(n)
    return c, client, time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--png", default="results/bench/sweep_cost.png",
                    help="the figure (docs/img/sweep_cost.png is this figure)")
    ap.add_argument("--fmu", help="a built paper_earth FMU (default: build it)")
    args = ap.parse_args()
    import tempfile

    from gyrowheel.fmu_build import build_fmu, load_scene
    with tempfile.TemporaryDirectory() as tmp:
        fmu = args.fmu or build_fmu(load_scene(ROOT / "examples/scenes/paper_earth.toml"), Path(tmp) / "e.fmu").fmu
        target = FmuTarget(fmu)
        p = plan(target, args.points)
        n = len(p.values)
        run_loop(p, TableWriter(None, p.inputs))  # warm up (extraction, dlopen, caches)
        c1, client1, start1 = cluster(1)
        c2, client2, start2 = cluster(2)
        try:
            dask_seconds(p, client1, 1)  # warm the workers
            dask_seconds(p, client2, 1)
            t_loop = t_d1 = t_d2 = float("inf")
            for _ in range(args.repeats):  # interleaved, so that a burst of other load hits all three alike
                t_loop = min(t_loop, loop_seconds(p, 1))
                t_d1 = min(t_d1, dask_seconds(p, client1, 1))
                t_d2 = min(t_d2, dask_seconds(p, client2, 1))
            cpu_loop = min(cpu_seconds(lambda: run_loop(p, TableWriter(None, p.inputs)))
                           for _ in range(args.repeats))
            cpu_d1 = min(cpu_seconds(lambda: run_dask(p, TableWriter(None, p.inputs), client=client1), client1)
                         for _ in range(args.repeats))
            cpu_d2 = min(cpu_seconds(lambda: run_dask(p, TableWriter(None, p.inputs), client=client2), client2)
                         for _ in range(args.repeats))
            tiny = plan(target, 200, stop_time=1e-3, output_interval=1e-3)
            t_tiny_loop = loop_seconds(tiny, args.repeats)
            t_tiny_tasks = dask_seconds(tiny, client1, args.repeats, batch_size=1)
            half = plan(target, 500)
            t_half = loop_seconds(half, args.repeats)
            batches = {b: dask_seconds(half, client1, args.repeats, batch_size=b) / t_half - 1
                       for b in (1, 5, 25, 125)}
        finally:
            for c in (client1, client2, c1, c2):
                c.close()
        per_task = (t_tiny_tasks - t_tiny_loop) / len(tiny.values)
        import os
        print(f"load average now {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores (above the cores: wall "
              "times are shared with other programs; trust the CPU figures)")
        print(f"points: {n}, each {1e3 * t_loop / n:.3f} ms in a plain loop ({n / t_loop:.0f} points/s), "
              f"{1e3 * cpu_loop / n:.3f} ms CPU")
        print(f"1. Dask overhead per point (LocalCluster, 1 worker, auto batches) vs the plain loop: "
              f"wall {100 * (t_d1 / t_loop - 1):+.1f}% ({t_d1:.3f} s vs {t_loop:.3f} s), CPU "
              f"{100 * (cpu_d1 / cpu_loop - 1):+.1f}% ({cpu_d1:.3f} s vs {cpu_loop:.3f} s, client + scheduler + "
              f"worker); with 2 workers CPU {100 * (cpu_d2 / cpu_loop - 1):+.1f}% (target <= 10%)")
        print(f"2. throughput 1 -> 2 workers: {t_d1 / t_d2:.2f}x  ({n / t_d1:.0f} -> {n / t_d2:.0f} points/s; "
              f"target >= 1.8x on 2 free cores; on a busy machine the wall ratio is bounded by what the "
              f"others leave)")
        print(f"3. scaling model: {n / t_d1:.0f} points/s per worker for 1 ms points; scheduler cost "
              f"{1e3 * per_task:.2f} ms per task; cluster start-up {start1:.1f} s (1 worker), {start2:.1f} s (2)")
        print("   batch size -> Dask overhead over the loop (500 points, 1 worker): "
              + ", ".join(f"{b}: {100 * o:+.0f}%" for b, o in batches.items()))

        rows = []
        for stop in (5.0, 10.0, 20.0, 40.0, 80.0):
            q = plan(target, 100, stop_time=stop, output_interval=1.0)
            rows.append(("horizon [s]", stop, 1e3 * loop_seconds(q, args.repeats) / 100))
        for tol in (1e-4, 1e-6, 1e-8, 1e-10, 1e-12):
            q = plan(target, 100, rel_tol=tol, abs_tol=tol * 1e-2)
            rows.append(("rel_tol", tol, 1e3 * loop_seconds(q, args.repeats) / 100))
        for count in (250, 500, 1000, 2000):
            q = plan(target, count)
            rows.append(("points", count, loop_seconds(q, args.repeats)))
        print("4. cost growth (plain loop, ms per point; for 'points' s per map):")
        for kind, x, y in rows:
            print(f"   {kind:<12} {x:>10g}  {y:10.3f}")
        Path(args.png).parent.mkdir(parents=True, exist_ok=True)
        draw(rows, Path(args.png), n / t_d1)
        print(f"wrote {args.png}")
    return 0


def draw(rows, png: Path, rate: float) -> None:
    """Write the cost figure from rows (kind, x, y): ms per point against the horizon and the
    tolerance, s per map against its points; rate: points/s per worker, for the title."""
    import matplotlib.pyplot as plt
    fig = figure(rows, rate)
    fig.savefig(png, dpi=110)
    plt.close(fig)


def figure(rows, rate: float):
    """The matplotlib Figure draw writes.  The axes span less than two decades, where a log axis
    labelled only at powers of ten shows one number: every axis is labelled at 1, 2 and 5 times
    each power of ten, in plain numbers."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8), constrained_layout=True)
    for ax, kind, xlabel, ylabel in zip(axes, ("horizon [s]", "rel_tol", "points"),
                                        ("horizon [s]", "rel_tol (abs_tol = rel_tol / 100)", "points in the map"),
                                        ("ms per point", "ms per point", "s per map (one core)")):
        xs = [x for k, x, _ in rows if k == kind]
        ys = [y for k, _, y in rows if k == kind]
        ax.loglog(xs, ys, "o-")
        ax.set(xlabel=xlabel, ylabel=ylabel)
        for axis in ([ax.yaxis] if kind == "rel_tol" else [ax.xaxis, ax.yaxis]):
            axis.set_major_locator(matplotlib.ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
            axis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
            axis.set_minor_locator(matplotlib.ticker.LogLocator(base=10, subs=tuple(range(1, 10))))
            axis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_title("linear in the horizon")
    axes[1].set_title("dopri5: about tol^(-1/5) per point")
    axes[2].set_title(f"linear in points ({rate:.0f} points/s per worker)")
    fig.suptitle("Cost of a sweep point: paper wheel, dopri5, output every 1 s (measured, in-process)")
    return fig


if __name__ == "__main__":
    sys.exit(main())
