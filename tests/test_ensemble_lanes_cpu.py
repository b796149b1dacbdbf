"""The ensemble's lane count chosen from the CPU at run time (c_src/gw_cpu_lanes.c,
gyrowheel.taylor.lanes): the probe against the kernel's own account of the CPU (/proc/cpuinfo),
its compile-time default where the compiler cannot ask, and the count reaching Ensemble(fmu)
and the sweep engine.  That a trajectory's bits do not depend on the count:
tests/test_ensemble.py (4, 8 and other widths)."""
from __future__ import annotations

import ctypes
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from gyrowheel.errors import ArgumentError
from gyrowheel.fmu_build.runtime import RUNTIME_DIR
from gyrowheel.taylor.ensemble import Ensemble
from gyrowheel.taylor import lanes as lanes_module
from gyrowheel.taylor.lanes import (PORTABLE_LANES, WIDE_MARGIN, cpu_features, cpu_lanes, ensemble_lanes,
                                    kernel_call_ratio, kernel_call_seconds, slice_defines, slice_width)

STRICT = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-O2", "-shared", "-fPIC"]
PROBE = RUNTIME_DIR / "gw_cpu_lanes.c"


def _cpuinfo_flags() -> set[str]:
    """The CPU's feature flags as the Linux kernel reports them (first processor)."""
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("flags"):
            return set(line.split(":", 1)[1].split())
    raise AssertionError("/proc/cpuinfo has no flags line")


@pytest.mark.skipif(not sys.platform.startswith("linux") or not Path("/proc/cpuinfo").is_file(),
                    reason="the kernel's account of the CPU is read from /proc/cpuinfo (Linux)")
def test_cpu_lanes_follow_the_cpu_features(tmp_path):
    """8 lanes with AVX-512F, 4 with AVX2, else the portable count, against the flags the
    kernel found (a source the probe does not read: it asks the compiler's runtime); the
    kernel's slices are 8 lanes wide only with AVX-512F and a multiple of 8 lanes."""
    flags = _cpuinfo_flags()
    want = 8 if "avx512f" in flags else 4 if "avx2" in flags else PORTABLE_LANES
    assert cpu_lanes(tmp_path) == want
    wide = 8 if "avx512f" in flags else 4
    assert [slice_width(w, tmp_path) for w in (1, 2, 3, 4, 6, 8, 12, 16)] == [1, 2, 1, 4, 2, wide, 4, wide]
    assert slice_defines(16, tmp_path) == ({"GW_ENSEMBLE_AVX512": 1} if wide == 8 else {})
    assert slice_defines(4, tmp_path) == {}
    assert cpu_features(tmp_path) == ("avx512f" if "avx512f" in flags else "avx2" if "avx2" in flags
                                      else "portable")


@pytest.mark.parametrize("cc", [c for c in ("gcc", "clang") if shutil.which(c)])
def test_probe_is_strict_c99_and_falls_back_to_its_compile_time_default(cc, tmp_path):
    """Warning-clean C99 under gcc and clang; compiled where the builtin cannot be asked (no x86
    macro defined: another architecture) it answers GW_CPU_LANES_PORTABLE and no feature; alone
    (without GW_CPU_LANES_LIB) it defines no symbol, as every runtime file."""
    asked = tmp_path / "asked.so"
    subprocess.run([cc, *STRICT, "-DGW_CPU_LANES_LIB", str(PROBE), "-o", str(asked)], check=True)
    lib = ctypes.CDLL(str(asked))
    assert lib.gw_cpu_lanes() == cpu_lanes(tmp_path / "cache")
    other = tmp_path / "other.so"
    subprocess.run([cc, *STRICT, "-DGW_CPU_LANES_LIB", "-DGW_CPU_LANES_PORTABLE=3", "-U__x86_64__", "-U__i386__",
                    str(PROBE), "-o", str(other)], check=True)
    lib = ctypes.CDLL(str(other))
    assert (lib.gw_cpu_lanes(), lib.gw_cpu_lanes_isa()) == (3, 0)
    obj = tmp_path / "alone.o"
    subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-c", str(PROBE), "-o", str(obj)],
                   check=True)
    assert subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout.strip() == ""


def test_bad_portable_count_is_refused_naming_it(tmp_path):
    for bad in (0, -2, 2.5, True, "4"):
        with pytest.raises(ArgumentError, match="portable") as info:
            cpu_lanes(tmp_path, portable=bad)
        assert info.value.argument == "portable"
    for bad in (0, -8, 8.0, True, "8"):
        with pytest.raises(ArgumentError, match="lanes"):
            slice_width(bad, tmp_path)


def test_ensemble_and_sweep_engine_take_the_machines_count(example_build, tmp_path, monkeypatch):
    """Ensemble(fmu).lanes is the machine's count, ensemble_lanes (what the library was built
    with: it reports its GW_ENSEMBLE_LANES), lanes=W overrides it, and the sweep engine's batches
    run on that count; the FMU does not carry the probe."""
    import zipfile

    from gyrowheel.studies import ensemble_path, sweep
    fmu = example_build("paper_earth", taylor=True).fmu
    with zipfile.ZipFile(fmu) as zf:  # the probe is built from the installed runtime, not the FMU's
        assert "sources/gw_cpu_lanes.c" not in zf.namelist() and "sources/gw_ensemble.c" in zf.namelist()
    want = ensemble_lanes(fmu, tmp_path)
    assert want == cpu_lanes(tmp_path) or (cpu_lanes(tmp_path), want) == (8, 4)
    assert Ensemble(fmu, cache=tmp_path).lanes == want
    other = 4 if want != 4 else 8
    assert Ensemble(fmu, lanes=other, cache=tmp_path).lanes == other
    seen = []
    run = Ensemble.run

    def spy(self, *args, **kwargs):
        seen.append(self.lanes)
        return run(self, *args, **kwargs)
    monkeypatch.setattr(Ensemble, "run", spy)
    monkeypatch.setattr(ensemble_path, "_ENSEMBLES", {})
    table = sweep(fmu, points=[dict(gamma_dot=g) for g in (5.0, 6.0, 7.0)], metrics=["survived"], stop_time=0.2,
                  output_interval=0.1, solver="taylor", workers=0)
    assert (table["status"] == "ok").all()
    assert seen and set(seen) == {want}


def test_ensemble_lanes_keep_8_only_where_their_kernel_measures_faster(example_build, tmp_path, monkeypatch):
    """With AVX-512F (cpu_lanes 8) the default is 8 lanes where the median ratio of one 8-lane
    kernel call to two 4-lane calls is at most WIDE_MARGIN, else 4; measured once per process,
    model and defines (another model or other defines: measured again, so the order of the calls
    does not matter); without AVX-512F the CPU's count, nothing timed.  Every call checks its
    arguments as Ensemble does, measured before or not.  (The libraries are stand-ins here: what
    is timed is tested below.)"""
    import zipfile

    import gyrowheel.taylor.ensemble as ensemble_mod
    from gyrowheel.errors import ArgumentTypeError, FmuError
    fmu = example_build("paper_earth", taylor=True).fmu
    other = tmp_path / "other.fmu"  # another model's bytes: the same FMU with one more file
    with zipfile.ZipFile(fmu) as zin, zipfile.ZipFile(other, "w") as zout:
        for item in zin.infolist():
            zout.writestr(item, zin.read(item))
        zout.writestr("documentation/extra.txt", "another model")
    timed, built = [], []

    class StandIn:
        def __init__(self, path, lanes=None, cache=None, defines=None):
            built.append(lanes)
            self.lanes = lanes

    def ratio(wide, narrow):
        timed.append((wide.lanes, narrow.lanes))
        return answer
    with monkeypatch.context() as m:
        m.setattr(ensemble_mod, "Ensemble", StandIn)
        m.setattr(lanes_module, "kernel_call_ratio", ratio)
        m.setattr(lanes_module, "_MEASURED", {})
        m.setattr(lanes_module, "cpu_lanes", lambda cache=None, portable=PORTABLE_LANES: 4)
        assert ensemble_lanes(fmu, tmp_path) == 4 and timed == [] and built == [4]
        m.setattr(lanes_module, "_MEASURED", {})
        m.setattr(lanes_module, "cpu_lanes", lambda cache=None, portable=PORTABLE_LANES: 8)
        answer = WIDE_MARGIN  # at the margin: 8
        assert ensemble_lanes(fmu, tmp_path) == 8 and timed == [(8, 4)]
        answer = 5.0  # measured already for this model in this process: not again
        assert ensemble_lanes(fmu, tmp_path) == 8 and len(timed) == 1
        assert ensemble_lanes(other, tmp_path) == 4 and len(timed) == 2  # another model: its own
        answer = WIDE_MARGIN * 1.001  # just above: 4, for other defines
        assert ensemble_lanes(fmu, tmp_path, {"GW_TAYLOR_EXTRA_ORDER": 4}) == 4 and len(timed) == 3
        assert ensemble_lanes(fmu, tmp_path) == 8 and len(timed) == 3
    monkeypatch.setattr(lanes_module, "cpu_lanes", lambda cache=None, portable=PORTABLE_LANES: 8)
    junk = tmp_path / "junk.fmu"
    junk.write_bytes(b"not a zip")
    for bad, error in ((tmp_path / "no_such.fmu", FmuError), (junk, FmuError), (123, ArgumentTypeError)):
        with pytest.raises(error) as info:
            ensemble_lanes(bad, tmp_path)
        assert info.value.argument == "fmu"
    with pytest.raises(ArgumentError, match="defines"):
        ensemble_lanes(fmu, tmp_path, {"GW_ENSEMBLE_LANES": 8})


def test_kernel_calls_time_the_lane_counts_and_refuse_bad_arguments(example_build, tmp_path):
    """kernel_call_seconds: one kernel call of each library, positive and finite, more lanes no
    cheaper per call than fewer by more than rounding of the clock; the C entry refuses rel_tol
    <= 0 and calls < 0 (-1) and runs 0 calls."""
    import numpy as np
    fmu = example_build("paper_earth", taylor=True).fmu
    ens = [Ensemble(fmu, lanes=w, cache=tmp_path) for w in (8, 4, 1)]
    seconds = kernel_call_seconds(ens)
    assert all(np.isfinite(s) and s > 0.0 for s in seconds)
    assert seconds[0] > 0.5 * seconds[2]  # 8 lanes cost at least about one lane
    rounds = kernel_call_seconds(ens[:2], per_round=True)
    assert len(rounds) == lanes_module.PROBE_ROUNDS and all(len(r) == 2 and min(r) > 0.0 for r in rounds)
    assert 0.0 < kernel_call_ratio(ens[0], ens[1]) < np.inf
    e = ens[1]
    fn = getattr(e._lib, f"{e.identifier}_ensemble_kernel_calls")
    d = ctypes.POINTER(ctypes.c_double)
    fn.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_long, d, d, d]
    ctx = ctypes.c_void_p(e._new_context())
    x = (ctypes.c_double * e.nx)(*e.run(1e-9).x_final[0])
    u, p = (ctypes.c_double * 1)(), (ctypes.c_double * e.np)(*e.default_parameters)
    try:
        assert [fn(ctx, tol, n, x, u, p) for tol, n in ((1e-8, 0), (1e-8, 3), (0.0, 3), (float("nan"), 3),
                                                         (1e-8, -1))] == [0, 0, -1, -1, -1]
    finally:
        getattr(e._lib, f"{e.identifier}_ensemble_free")(ctx)
    # the context's next run is untouched by the calls: the same bits as a fresh library's
    again = e.run(2.0, starts={"gamma_dot": [5.0, 6.0]})
    fresh = Ensemble(fmu, lanes=4, cache=tmp_path / "fresh").run(2.0, starts={"gamma_dot": [5.0, 6.0]})
    assert np.array_equal(again.x_final, fresh.x_final)


def test_fmu_without_kernel_calls_keeps_the_cpu_count(example_build, tmp_path, monkeypatch):
    """An FMU whose runtime has no gw_ensemble_kernel_calls (built by an earlier gyrowheel) still
    makes its ensemble library; its lanes cannot be timed, so the CPU's count stands."""
    import zipfile
    src = example_build("paper_earth", taylor=True).fmu
    old = tmp_path / "old.fmu"
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(old, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item)
            for name, first, last in (("gw_ensemble.h", "#define GW_ENSEMBLE_KERNEL_CALLS", ");\n"),
                                      ("gw_ensemble.c", "GW_API gw_status gw_ensemble_kernel_calls(", "\n}\n")):
                if item.filename == f"sources/{name}":  # the declaration and the definition cut out
                    text = data.decode()
                    start = text.index(first)
                    data = (text[:start] + text[text.index(last, start) + len(last):]).encode()
            zout.writestr(item, data)
    monkeypatch.setattr(lanes_module, "_MEASURED", {})
    monkeypatch.setattr(lanes_module, "cpu_lanes", lambda cache=None, portable=PORTABLE_LANES: 8)
    assert kernel_call_seconds([Ensemble(old, lanes=4, cache=tmp_path)]) is None
    assert ensemble_lanes(old, tmp_path) == 8 and list(lanes_module._MEASURED.values()) == [8]
    assert ensemble_lanes(old, tmp_path) == 8  # kept: not timed again
