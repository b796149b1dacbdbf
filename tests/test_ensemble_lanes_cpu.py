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
from gyrowheel.taylor.lanes import PORTABLE_LANES, cpu_features, cpu_lanes, slice_defines, slice_width

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
        with pytest.raises(ArgumentError, match="portable"):
            cpu_lanes(tmp_path, portable=bad)
    for bad in (0, -8, 8.0, True, "8"):
        with pytest.raises(ArgumentError, match="lanes"):
            slice_width(bad, tmp_path)


def test_ensemble_and_sweep_engine_take_the_cpu_count(example_build, tmp_path, monkeypatch):
    """Ensemble(fmu).lanes is the CPU's count (what the library was built with: it reports its
    GW_ENSEMBLE_LANES), lanes=W overrides it, and the sweep engine's batches run on the CPU's count;
    the FMU does not carry the probe."""
    import zipfile

    from gyrowheel.studies import ensemble_path, sweep
    fmu = example_build("paper_earth", taylor=True).fmu
    with zipfile.ZipFile(fmu) as zf:  # the probe is built from the installed runtime, not the FMU's
        assert "sources/gw_cpu_lanes.c" not in zf.namelist() and "sources/gw_ensemble.c" in zf.namelist()
    want = cpu_lanes(tmp_path)
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
