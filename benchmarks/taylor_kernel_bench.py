"""The Taylor kernel alone (one jet call = the coefficients of one step), per lane count and order.

Builds a scene's FMU with the Taylor kernel, compiles its gw_taylor_model.h into small C
drivers the way the runtime does (W = 1: the FMU's c_src/gw_taylor.c with its flags, -std=c99
-O2 -fno-math-errno; W > 1 as in the ensemble library: -O3 -ffp-contract=fast, the kernel
target clones for x86-64-v4 and x86-64-v3 beside the portable default, as c_src/gw_ensemble.c,
with 8-double slices where the CPU has AVX-512F and W is a multiple of 8) and times jet at the
scene's initial state: thread CPU time of a batch of calls, best over interleaved rounds.  Prints us per call for W = 1, 4, 8, 16 at orders 6, 10, 13,
15 (rel_tol 1e-4, 1e-7, 1e-10, 1e-12) and the ratio of a W-lane call to a one-lane call (the
cost of W trajectories against one: 1 would be perfect vectorisation, W none at all).

With --baseline REF (a git ref or a checkout directory, either layout: benchmarks/ref_tree.py)
the kernel that REF's generator writes for the same ode (its taylor/kernel_c.py, or
fmu_build/taylor_c.py in the top-level layout), compiled with REF's c_src/gw_taylor_ops.h,
gw_taylor.c and runtime headers, is timed in the same rounds, and its states' series are
compared with this tree's (they differ by rounding only: the summation order).  Timings on a loaded machine
are noisy: compare ratios from one run; re-measure absolute times on a quiet machine.

With --narrow this tree's kernel is also timed in slices of at most 4 lanes (as on a CPU
without AVX-512F), in the same rounds.

    python benchmarks/taylor_kernel_bench.py [--scene examples/scenes/paper_earth.toml]
        [--baseline main] [--narrow] [--lanes 1 4 8 16] [--orders 6 10 13 15] [--rounds 15]
"""
from __future__ import annotations

import argparse
import ctypes
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from ref_tree import RefTree  # noqa: E402

from gyrowheel.fmu_build import build_fmu, load_scene  # noqa: E402
from gyrowheel.fmu_build.codegen import taylor_ode  # noqa: E402
from gyrowheel.taylor.lanes import slice_width  # noqa: E402

NARROW = "4-double slices"  # --narrow: this tree's kernel in slices of at most 4 lanes
from gyrowheel.fmu_build.compiler import OPTIMISE, STANDARD, compiler  # noqa: E402
from gyrowheel.fmu_build.runtime import RUNTIME_DIR  # noqa: E402
from gyrowheel.taylor.ensemble import FLAGS as ENSEMBLE_FLAGS  # noqa: E402

DRIVER = r"""#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stddef.h>
#include <time.h>
#if {lanes} == 1 /* the FMU's instance: gw_taylor.c itself (its target clone), as gw_tl1_ */
#define GW_UNITY_BUILD 1
#include "gw_taylor.c"
#define gw_tlb_cst gw_tl1_cst
#define gw_tlb_jet gw_tl1_jet
#else /* the ensemble's: as gw_ensemble.c */
#define GW_MAYBE_UNUSED __attribute__((unused))
#define GW_TL_W {lanes}
#define GW_TL(name) gw_tlb_##name
#if defined(__x86_64__) && !defined(__clang__)
#define GW_TL_STATIC static __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#if {slice} == 8 /* AVX-512F and a multiple of 8 lanes: 8-double slices (gyrowheel.taylor.lanes.slice_width) */
#define GW_TL_VW_MAX 8
#endif
#endif
#include "gw_taylor_model.h"
#endif
int bench_nvar(void);
int bench_ncst(void);
void bench_cst(const double *u, const double *p, double *c);
void bench_jet(int order, const double *t, const double *x, const double *c, double *w);
double bench_time(long calls, int order, const double *t, const double *x, const double *c, double *w);
int bench_nvar(void) {{ return GW_TL_NVAR; }}
int bench_ncst(void) {{ return GW_TL_NCST; }}
void bench_cst(const double *u, const double *p, double *c) {{ gw_tlb_cst(u, p, c); }}
void bench_jet(int order, const double *t, const double *x, const double *c, double *w) {{
    gw_tlb_jet(order, t, x, c, w);
}}
double bench_time(long calls, int order, const double *t, const double *x, const double *c, double *w) {{
    struct timespec a, b;
    long i;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
    for (i = 0; i < calls; i++) gw_tlb_jet(order, t, x, c, w);
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
    return ((double)(b.tv_sec - a.tv_sec) + 1e-9 * (double)(b.tv_nsec - a.tv_nsec)) / (double)calls;
}}
"""

_D = ctypes.POINTER(ctypes.c_double)


def _ptr(a: np.ndarray):
    return a.ctypes.data_as(_D)


def baseline_source(ref: RefTree, ode, model: str, out: Path) -> None:
    """gw_taylor_model.h of `ref`'s generator for `ode` (run in ref's tree, a subprocess: the ode
    passes as a file of casadi.Function.save), and ref's gw_taylor_ops.h and gw_taylor.c, into
    out."""
    out.mkdir(parents=True, exist_ok=True)
    ode_file = out / "ode.casadi"
    ode.save(str(ode_file))
    ref.python(f"import sys; import casadi as ca; from {ref.module('gyrowheel.taylor.graph')} import decompose; "
               f"from {ref.module('gyrowheel.taylor.kernel_c')} import taylor_source; "
               "text = taylor_source(decompose(ca.Function.load(sys.argv[1])), sys.argv[2]); "
               "open(sys.argv[3], 'w').write(text)", str(ode_file), model, str(out / "gw_taylor_model.h"))
    for name in ("gw_taylor_ops.h", "gw_taylor.c"):
        shutil.copy(ref.file(f"c_src/{name}"), out / name)


class Kernel:
    """One compiled instance: a kernel directory at a lane count."""

    def __init__(self, src: Path, lanes: int, work: Path, name: str, runtime: Path = RUNTIME_DIR,
                 slice_max: int | None = None):
        self.lanes = lanes
        c = work / f"{name}_w{lanes}.c"
        width = slice_width(lanes) if slice_max is None else min(slice_max, slice_width(lanes))
        c.write_text(DRIVER.format(lanes=lanes, slice=width))
        lib = work / f"{name}_w{lanes}.so"
        flags = [*STANDARD, *OPTIMISE] if lanes == 1 else ["-std=c99", *ENSEMBLE_FLAGS]
        subprocess.run([compiler(), *flags, "-shared", "-fPIC", f"-I{src}", f"-I{runtime}",
                        str(c), "-o", str(lib), "-lm"], check=True)
        self.lib = ctypes.CDLL(str(lib))
        self.lib.bench_time.restype = ctypes.c_double
        self.nvar, self.ncst = self.lib.bench_nvar(), self.lib.bench_ncst()

    def setup(self, x0: np.ndarray, u: np.ndarray, p: np.ndarray, order: int):
        W = self.lanes
        rng = np.random.default_rng(1)
        self.x = np.ascontiguousarray(np.repeat(x0[:, None], W, 1) * (1 + 1e-3 * rng.standard_normal((x0.size, W))))
        self.t = np.zeros(W)
        self.c = np.zeros(max(self.ncst, 1) * W)
        pl = np.ascontiguousarray(np.repeat(p[:, None], W, 1)) if p.size else np.zeros(W)
        ul = np.ascontiguousarray(np.repeat(u[:, None], W, 1)) if u.size else np.zeros(W)
        self.lib.bench_cst(_ptr(ul), _ptr(pl), _ptr(self.c))
        self.w = np.zeros(self.nvar * (order + 1) * W)
        self.order = order

    def states(self, nx: int) -> np.ndarray:
        """lane 0's state series, (nx, order + 1)"""
        self.lib.bench_jet(self.order, _ptr(self.t), _ptr(self.x), _ptr(self.c), _ptr(self.w))
        S = self.order + 1
        return self.w[: nx * S * self.lanes].reshape(nx, S, self.lanes)[:, :, 0]

    def time(self, calls: int) -> float:
        return self.lib.bench_time(calls, self.order, _ptr(self.t), _ptr(self.x), _ptr(self.c), _ptr(self.w))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default=str(HERE.parent / "examples/scenes/paper_earth.toml"))
    parser.add_argument("--baseline", help="git ref or checkout directory whose kernel generator to time alongside")
    parser.add_argument("--lanes", type=int, nargs="*", default=[1, 4, 8, 16])
    parser.add_argument("--orders", type=int, nargs="*", default=[6, 10, 13, 15])
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--narrow", action="store_true",
                        help="also time this tree with 4-double slices where the CPU would take 8")
    parser.add_argument("--seconds", type=float, default=0.004, help="per timed batch")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="gw-tkernel-") as tmp:
        work = Path(tmp)
        scene = load_scene(Path(args.scene))
        built = build_fmu(scene, work / "k.fmu", build_dir=work / "build", taylor=True)
        fns = built.spec.functions()
        p = np.array([q.start for q in built.spec.parameters], dtype=float)
        s0 = [q.start for q in built.spec.starts]
        x0 = np.array(fns["init"](s0, p)).ravel()
        u = np.array([q.start for q in built.spec.inputs], dtype=float)
        nx = x0.size
        variants = {"this tree": (built.sources, RUNTIME_DIR, None)}
        if args.narrow:
            variants[NARROW] = (built.sources, RUNTIME_DIR, 4)
        if args.baseline:
            ref = RefTree(args.baseline, work)
            base = work / "base"
            baseline_source(ref, taylor_ode(fns), scene.name, base)
            variants[args.baseline] = (base, ref.file("c_src"), None)
        kernels = {(v, W): Kernel(src, W, work, f"k{i}", runtime, width)
                   for i, (v, (src, runtime, width)) in enumerate(variants.items()) for W in args.lanes}
        print(f"{args.scene}: {nx} states; work series: "
              + ", ".join(f"{v} {kernels[(v, args.lanes[0])].nvar}" for v in variants))
        best = {}
        for order in args.orders:
            for k in kernels.values():
                k.setup(x0, u, p, order)
            if args.baseline:
                a, b = (kernels[(v, 1)].states(nx) for v in ("this tree", args.baseline))
                scale = np.maximum(np.abs(b).max(axis=1, keepdims=True), np.finfo(float).tiny)
                dev = np.max(np.abs(a - b) / scale)  # (a state whose series is all 0: absolute)
                print(f"order {order}: states' series of the two kernels differ by {dev:.1e} "
                      "(relative to each series' largest coefficient)")
            calls = {key: max(1, int(args.seconds / max(k.time(20), 1e-9))) for key, k in kernels.items()}
            for _ in range(args.rounds):
                for key, k in kernels.items():
                    best[(key, order)] = min(best.get((key, order), np.inf), k.time(calls[key]))
        for v in variants:
            print(f"\n### {v}: us per jet call (ratio to one lane; per trajectory)\n")
            print("| order | " + " | ".join(f"W = {W}" for W in args.lanes) + " |")
            print("|---|" + "---|" * len(args.lanes))
            for order in args.orders:
                one = best[((v, args.lanes[0]), order)]
                cells = []
                for W in args.lanes:
                    t = best[((v, W), order)]
                    cells.append(f"{t * 1e6:.3f}" + ("" if W == args.lanes[0] else
                                                     f" ({t / one:.2f}x; {t * 1e6 / W:.3f}/traj)"))
                print(f"| {order} | " + " | ".join(cells) + " |")
        for other in [v for v in variants if v != "this tree"]:
            print(f"\n### speed-up of this tree over {other} (time ratio, > 1: faster)\n")
            print("| order | " + " | ".join(f"W = {W}" for W in args.lanes) + " |")
            print("|---|" + "---|" * len(args.lanes))
            for order in args.orders:
                print(f"| {order} | " + " | ".join(
                    f"{best[((other, W), order)] / best[(('this tree', W), order)]:.2f}"
                    for W in args.lanes) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
