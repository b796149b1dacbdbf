"""GW_TL(sincos) (c_src/gw_taylor_ops.h): the W-lane Taylor kernel's order 0 takes sin and cos of
a slice of lanes at once (GW_TL_V0); each lane must be gw_sincos's value (tests/c/
test_tl_sincos.c: uniform slices, and slices with one lane near a multiple of pi/2, beyond 2^20,
NaN, infinite, +-0 or tiny, which fall back to gw_sincos lane by lane).

  test_slices_equal_gw_sincos   W = 2, 4, 8 under the strict flags (no contraction): bit-equal;
      with the ensemble library's flags (-O3 -ffp-contract=fast, x86-64-v3 / v4 where the
      machine runs it): within 1 ulp (measured 0: both paths contract alike)
"""
from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from c_programs import C_SRC, STRICT, TESTS_C

COMPILERS = [c for c in ("gcc", "clang") if shutil.which(c)]


def _cpu_has(flag: str) -> bool:
    try:
        with open("/proc/cpuinfo") as f:
            return any(flag in line.split() for line in f if line.startswith("flags"))
    except OSError:
        return False


CASES = [(cc, w, ["-O2", "-fno-math-errno", "-DSTRICT_EQUAL=1"]) for cc in COMPILERS for w in (2, 4, 8)]
CASES += [("gcc", w, ["-O3", "-ffp-contract=fast", f"-march={arch}"])
          for w in (4, 8) for arch, flag in (("x86-64-v3", "avx2"), ("x86-64-v4", "avx512f"))
          if _cpu_has(flag)]


@pytest.mark.parametrize("cc,lanes,flags", CASES)
def test_slices_equal_gw_sincos(cc, lanes, flags, tmp_path):
    exe = tmp_path / "test_tl_sincos"
    subprocess.run([cc, *STRICT, *flags, f"-DGW_TL_W={lanes}", f"-I{C_SRC}", f"-I{TESTS_C}",
                    str(TESTS_C / "test_tl_sincos.c"), "-lm", "-o", str(exe)], check=True)
    r = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    assert re.search(r"test_tl_sincos: \d+ checks, 0 failures", r.stderr), r.stderr
    n = int(re.search(r"(\d+) values", r.stdout)[1])
    assert n >= 1_000_000 * lanes // 2, r.stdout
