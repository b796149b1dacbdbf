"""The ensemble's lane count for this machine (trajectories advanced together by one Taylor kernel).

`cpu_lanes()` asks c_src/gw_cpu_lanes.c, compiled once into a tiny shared library beside the
ensemble libraries' cache (keyed by its source, flags and compiler) and loaded once per process:

    AVX-512F  -> 8   (one 8-double vector per slice of the kernel: slice_width)
    AVX2      -> 4   (one 4-double vector per slice)
    otherwise -> PORTABLE_LANES (2: the portable build, SSE2 pairs, measured fastest there)

`slice_width(lanes)` is the width of the kernel's slices in an ensemble of `lanes` lanes on this
CPU: 8 where the CPU has AVX-512F and lanes is a multiple of 8 (the library is then built with
GW_ENSEMBLE_AVX512, `slice_defines`), else 4, 2 or 1, the largest that divides lanes.

`ensemble_lanes(fmu)` is the count `Ensemble(fmu)` and the sweep engine take: cpu_lanes(), except
where that is 8 (AVX-512F), which holds only where it measures faster.  An AVX-512 register does
not make 8 lanes cheaper everywhere: on one 2-core virtual machine an 8-lane kernel call cost
1.35-1.42 one-lane calls, on another of the same CPU model (AMD EPYC, family 25) 2.5-2.8, about
two 4-lane calls or more.  So there the model's kernel is timed once per process and model at 8 lanes
(8-double slices) and at 4 (gw_ensemble_kernel_calls), and 8 lanes are kept if the median over
rounds of an 8-lane call's time over two 4-lane calls' is at most WIDE_MARGIN (0.7): a batch of 8
also waits longer for its slowest lane, the more so with events (at N = 8 the ensemble's time
ratio of 8 to 4 lanes was 1.3-1.7 times the kernel's for the paper wheel, at N = 16 and 64
1.0-1.4 times; for a bouncing wheel, drop_bounce, a kernel ratio of 0.75-0.83 went with 8 lanes
1.5-1.6x the time of 4 at N = 8 and 16, level at 64).  The cost, on first use: both libraries
compiled (each cached as Ensemble's: the paper wheel 3 s and 4 s, a contact model minutes), then
per process and model about 45 ms (loading both, 11 rounds of the kernel).

The features come from the compiler's __builtin_cpu_supports (GCC, clang); another compiler or
architecture answers PORTABLE_LANES at compile time.  `Ensemble(fmu)` and the sweep engine
(gyrowheel.studies) take this count, on AVX-512F the measured one (`ensemble_lanes`);
`Ensemble(fmu, lanes=W)` overrides it.  A trajectory's result does not depend on the count
(tests/test_ensemble.py), only the time does.

Errors: CompileError (gyrowheel.fmu_build.compiler) if no C compiler can build the probe;
ArgumentError for a `portable` value that is not an integer >= 1.  Measurements:
docs/performance.md, "The ensemble's lane count".
"""
from __future__ import annotations

import ctypes
import hashlib
import os
import threading
from pathlib import Path

from gyrowheel.errors import ArgumentError
from gyrowheel.fmu_build.compiler import compile_shared, compiler
from gyrowheel.fmu_build.runtime import RUNTIME_DIR

__all__ = ["cpu_lanes", "cpu_features", "ensemble_lanes", "kernel_call_ratio", "kernel_call_seconds",
           "slice_width", "slice_defines", "PORTABLE_LANES", "WIDE_MARGIN"]

PORTABLE_LANES = 2  # GW_CPU_LANES_PORTABLE: neither AVX-512F nor AVX2, or no way to ask
PROBE_SOURCE = "gw_cpu_lanes.c"
_FEATURES = {2: "avx512f", 1: "avx2", 0: "portable"}
_LOADED: dict[tuple, ctypes.CDLL] = {}
_LOCK = threading.Lock()
WIDE, NARROW = 8, 4  # the lane counts ensemble_lanes compares on AVX-512F
WIDE_MARGIN = 0.7  # 8 lanes kept where their kernel call costs at most this x two 4-lane calls
PROBE_REL_TOL = 1e-8  # the kernel's order timed: gw_taylor_order(1e-8), mid-range
PROBE_ROUNDS, PROBE_SECONDS = 11, 2e-4  # rounds of about this long per lane count
_MEASURED: dict[tuple, int] = {}  # ensemble_lanes' answers in this process, by model and defines
_MEASURE_LOCK = threading.Lock()


def _probe(cache: Path | None, portable: int) -> ctypes.CDLL:
    """The probe library (compiled on first use into cache, default the ensemble cache)."""
    if isinstance(portable, bool) or not isinstance(portable, int) or portable < 1:
        raise ArgumentError(f"portable must be an integer >= 1 (lanes without AVX2), got {portable!r}",
                            argument="portable")
    from gyrowheel.taylor.ensemble import _cache_dir
    source = RUNTIME_DIR / PROBE_SOURCE
    flags = ["-DGW_CPU_LANES_LIB", f"-DGW_CPU_LANES_PORTABLE={portable}"]
    digest = hashlib.sha256(source.read_bytes() + " ".join([compiler(), *flags]).encode()).hexdigest()[:20]
    lib = (Path(cache) if cache else _cache_dir()) / f"cpu-lanes-{digest}" / "libcpulanes.so"
    key = (str(lib),)
    with _LOCK:
        if key not in _LOADED:
            if not lib.exists():
                part = lib.with_suffix(f".{os.getpid()}.{threading.get_ident()}.part")
                compile_shared(source, [RUNTIME_DIR], part, extra_flags=flags)
                part.replace(lib)
            probe = ctypes.CDLL(str(lib))
            probe.gw_cpu_lanes.restype = probe.gw_cpu_lanes_isa.restype = ctypes.c_int
            _LOADED[key] = probe
        return _LOADED[key]


def cpu_lanes(cache: str | os.PathLike | None = None, portable: int = PORTABLE_LANES) -> int:
    """The lane count for this CPU: 8 with AVX-512F, 4 with AVX2, else `portable` (an integer
    >= 1).  cache: where the probe library is kept (default the ensemble cache)."""
    return int(_probe(Path(cache) if cache else None, portable).gw_cpu_lanes())


def cpu_features(cache: str | os.PathLike | None = None) -> str:
    """What the probe found: "avx512f", "avx2" or "portable" (the reason for cpu_lanes' answer)."""
    return _FEATURES[int(_probe(Path(cache) if cache else None, PORTABLE_LANES).gw_cpu_lanes_isa())]


def slice_width(lanes: int, cache: str | os.PathLike | None = None) -> int:
    """Lanes per vector slice of the kernel (c_src/gw_taylor_ops.h, GW_TL_VW) in an ensemble of
    `lanes` lanes (an integer >= 1) built for this CPU: 8 with AVX-512F and lanes a multiple of 8,
    else the largest of 4, 2, 1 dividing lanes.  ArgumentError for a bad lanes."""
    from gyrowheel.taylor.ensemble import _check_lanes
    _check_lanes(lanes)
    if lanes % 8 == 0 and cpu_features(cache) == "avx512f":
        return 8
    return next(w for w in (4, 2, 1) if lanes % w == 0)


def slice_defines(lanes: int, cache: str | os.PathLike | None = None) -> dict[str, int]:
    """The C macros of an ensemble library of `lanes` lanes for this CPU's slice width:
    {"GW_ENSEMBLE_AVX512": 1} where slice_width is 8 (c_src/gw_ensemble.c: the 8-double slices
    of its x86-64-v4 clone), else {}."""
    return {"GW_ENSEMBLE_AVX512": 1} if slice_width(lanes, cache) == 8 else {}


def ensemble_lanes(fmu, cache: str | os.PathLike | None = None, defines: dict | None = None, *,
                   check: bool = True) -> int:
    """The lane count of Ensemble(fmu) (lanes=None) and of the sweep engine's batches on this
    machine: cpu_lanes(cache), except that where that is 8 (AVX-512F) it is 8 only if one call of
    the 8-lane kernel (8-double slices) of fmu's model costs at most WIDE_MARGIN (0.7) times two
    calls of the 4-lane kernel (the median over rounds of kernel_call_ratio), else 4.  Measured
    once per process, model (the FMU's content) and `defines`; the Ensemble libraries of both
    counts are compiled and cached as Ensemble's.  An FMU whose runtime cannot time its kernel
    (built by an earlier gyrowheel) keeps cpu_lanes().
    fmu, cache, defines: as Ensemble's.  Raises what Ensemble(fmu, lanes=8, ...) raises
    (FmuError, EnsembleError, CompileError; ArgumentError naming a bad define, ArgumentTypeError
    for an fmu that is no path), on every call.  check=False (Ensemble's own call, which builds
    the library next and names its faults): nothing is built where nothing is measured."""
    from gyrowheel.taylor.ensemble import Ensemble, _checked_defines, _fmu_path
    checked, path = _checked_defines(defines), _fmu_path(fmu)
    cpu, key = cpu_lanes(cache), None
    if cpu == WIDE:
        try:
            key = (hashlib.sha256(path.read_bytes()).hexdigest(), tuple(sorted(checked.items())))
        except OSError:  # no such file, a directory, ...: Ensemble names the fault
            pass
    if key is None:
        if check:
            Ensemble(path, lanes=cpu, cache=cache, defines=checked)  # its faults named here too
        return cpu
    with _MEASURE_LOCK:
        if key not in _MEASURED:
            wide, narrow = (Ensemble(path, lanes=w, cache=cache, defines=checked) for w in (WIDE, NARROW))
            ratio = kernel_call_ratio(wide, narrow)
            _MEASURED[key] = cpu if ratio is None else WIDE if ratio <= WIDE_MARGIN else NARROW
        return _MEASURED[key]


def kernel_call_ratio(wide, narrow) -> float | None:
    """The median over PROBE_ROUNDS rounds of (one kernel call of Ensemble `wide`) / (two of
    Ensemble `narrow`), timed back to back in each round, in alternating order (kernel_call_seconds
    per round): a period of a slower machine (0.1 s to seconds on a virtual machine) or one slow
    batch moves a round, not the median.  None where an FMU's runtime has no kernel_calls."""
    import statistics
    rounds = kernel_call_seconds([wide, narrow], per_round=True)
    if rounds is None:
        return None
    return statistics.median(w / (2.0 * n) for w, n in rounds)


def kernel_call_seconds(ensembles: list, per_round: bool = False):
    """Thread CPU seconds of one batch-kernel call of each Ensemble in `ensembles` (their
    libraries' kernel_calls: every lane at the FMU's initial state, the order of rel_tol
    PROBE_REL_TOL; a call of about PROBE_SECONDS each), over PROBE_ROUNDS rounds that time each
    in turn (forward, then backward), so that all are timed at the same moments (a virtual
    machine's speed changes for 0.1 s to seconds at a time): the best of the rounds, one per
    Ensemble, or with per_round every round's seconds.  None where an FMU's runtime has no
    kernel_calls (built by an earlier gyrowheel)."""
    import time
    d = ctypes.POINTER(ctypes.c_double)
    calls, timers = [], []
    for ens in ensembles:
        fn = getattr(ens._lib, f"{ens.identifier}_ensemble_kernel_calls")
        fn.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_long, d, d, d]
        fn.restype = ctypes.c_int
        free = getattr(ens._lib, f"{ens.identifier}_ensemble_free")
        free.argtypes = [ctypes.c_void_p]
        ctx = ctypes.c_void_p(ens._new_context())
        if not ctx.value:
            raise MemoryError("ensemble context: out of memory")
        p = (ctypes.c_double * max(ens.np, 1))(*ens.default_parameters)
        x = _initial_state(ens, ctx, p)
        u = (ctypes.c_double * max(ens.nu, 1))()
        timers.append((fn, ctx, x, u, p, free))

    def timed(k: int, n: int) -> float:
        fn, ctx, x, u, p, _ = timers[k]
        t0 = time.thread_time()
        rc = fn(ctx, PROBE_REL_TOL, n, x, u, p)
        if rc == -2:
            raise LookupError
        if rc != 0:
            raise RuntimeError("kernel_calls refused its arguments")
        return time.thread_time() - t0
    try:
        for k in range(len(timers)):  # calls per round: about PROBE_SECONDS
            try:
                calls.append(max(1, int(PROBE_SECONDS / max(timed(k, 20) / 20, 1e-9))))
            except LookupError:
                return None
        rounds = []
        for r in range(PROBE_ROUNDS):
            order = range(len(timers)) if r % 2 == 0 else range(len(timers) - 1, -1, -1)
            seconds = [0.0] * len(timers)
            for k in order:
                seconds[k] = timed(k, calls[k]) / calls[k]
            rounds.append(seconds)
        return rounds if per_round else [min(r[k] for r in rounds) for k in range(len(timers))]
    finally:
        for fn, ctx, *_, free in timers:
            free(ctx)


def _initial_state(ens, ctx, p):
    """The FMU's state 1 ns after its start at its default start values and parameters p, by the
    library's own run on context ctx (not Ensemble.run: a measurement is no run of the caller's).
    Where the defaults are refused the values are whatever the run left: they are only timed."""
    c_int, c_double, c_long = ctypes.c_int, ctypes.c_double, ctypes.c_long
    run = getattr(ens._lib, f"{ens.identifier}_ensemble_run")
    run.restype = c_int
    s = (c_double * max(ens.ns, 1))(*ens.default_starts)
    x = (c_double * max(ens.nx, 1))()
    out = [(c_double * max(n, 1))() for n in (1, ens.ny)]  # t_final, y_final
    status, steps, flags = (c_int * 1)(), (ctypes.c_ulong * 1)(), (c_int * max(ens.ne, 1))()
    run(ctx, c_long(1), p, s, (c_double * 2)(0.0, 1e-9), (c_double * 3)(1e-8, 1e-10, 1e-9), status, out[0], x,
        out[1], steps, None, c_int(0), None, None, None, flags)
    return x
