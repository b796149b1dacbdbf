"""The ensemble's lane count for this CPU (trajectories advanced together by one Taylor kernel).

`cpu_lanes()` asks c_src/gw_cpu_lanes.c, compiled once into a tiny shared library beside the
ensemble libraries' cache (keyed by its source, flags and compiler) and loaded once per process:

    AVX-512F  -> 8   (one 8-double vector per slice of the kernel: slice_width)
    AVX2      -> 4   (one 4-double vector per slice)
    otherwise -> PORTABLE_LANES (2: the portable build, SSE2 pairs, measured fastest there)

`slice_width(lanes)` is the width of the kernel's slices in an ensemble of `lanes` lanes on this
CPU: 8 where the CPU has AVX-512F and lanes is a multiple of 8 (the library is then built with
GW_ENSEMBLE_AVX512, `slice_defines`), else 4, 2 or 1, the largest that divides lanes.

The features come from the compiler's __builtin_cpu_supports (GCC, clang); another compiler or
architecture answers PORTABLE_LANES at compile time.  `Ensemble(fmu)` and the sweep engine
(gyrowheel.studies) take this count; `Ensemble(fmu, lanes=W)` overrides it.  A trajectory's
result does not depend on the count (tests/test_ensemble.py), only the time does.

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

__all__ = ["cpu_lanes", "cpu_features", "slice_width", "slice_defines", "PORTABLE_LANES"]

PORTABLE_LANES = 2  # GW_CPU_LANES_PORTABLE: neither AVX-512F nor AVX2, or no way to ask
PROBE_SOURCE = "gw_cpu_lanes.c"
_FEATURES = {2: "avx512f", 1: "avx2", 0: "portable"}
_LOADED: dict[tuple, ctypes.CDLL] = {}
_LOCK = threading.Lock()


def _probe(cache: Path | None, portable: int) -> ctypes.CDLL:
    """The probe library (compiled on first use into cache, default the ensemble cache)."""
    if isinstance(portable, bool) or not isinstance(portable, int) or portable < 1:
        raise ArgumentError(f"portable must be an integer >= 1 (lanes without AVX2), got {portable!r}")
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
