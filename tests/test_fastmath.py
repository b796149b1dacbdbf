"""gw_sin / gw_cos / gw_sincos (c_src/gw_sincos.h), the sin and cos of the generated code.

  test_ulp_error_against_long_double   tests/c/test_fastmath.c under gcc and clang with the
      strict flags and the FMU's optimisation: at most 1 ulp from glibc's long double sinl/cosl
      over 1.2e7 arguments (uniform in [-1e5, 1e5], every multiple of pi/2 below 2^20 and its
      neighbours, [-pi, pi], tiny magnitudes, the bound); NaN, infinities, -0, libm beyond it
      (and gw_sincos2, two arguments in SSE2 lanes, bit-equal to gw_sincos), also built with
      -DGW_FASTMATH_NO_SIMD (the portable path of gw_sincos2)
  test_generated_code_merges_sincos    the paper wheel's gw_ode computes sin and cos of alpha
      and beta with one gw_sincos2, no libm sin or cos
  test_merge_respects_reassignment     gyrowheel.fmu_build.casadi_c pairs sin(a) with cos(a) only while
      a keeps its value
  test_pair_respects_uses              two gw_sincos become one gw_sincos2 only if the first's
      output is not used or its argument changed before the second
  test_pair_keeps_the_second_argument_written_first   ... nor when the second's argument is
      the first's output (sin(cos x) beside sin x)
  test_rewritten_bodies_evaluate_as_casadi   CasADi functions with nested trig, if_else and
      reused work variables, rewritten, compiled strictly (gcc, clang) and run: CasADi's values
  test_error_under_a_parent_projects_flags   tests/c/fastmath_unit.c compiled with IEEE flags
      (1 ulp) and with -ffast-math -fno-finite-math-only (4 ulp: GW_FM_KEEP holds the reduction),
      measured by tests/c/test_fastmath_flags.c compiled with IEEE semantics
  test_log_exp_error_and_lanes   gw_fm_log / gw_fm_exp (the ensemble's Taylor step size ln and exp) against
      glibc's long double logl / expl over the step size's ranges and beyond (tests/c/
      test_fastexp.c, 1e7 points): below 0.9 ulp with the FMU's flags (measured 0.84 / 0.76),
      specials, and gw_fm_log4 / gw_fm_exp4 bit-equal to them lane by lane (gcc, clang; SSE2,
      AVX2, x86-64-v3); below 3 ulp under -ffast-math -fno-finite-math-only (measured 2.2)
"""
from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from c_programs import C_SRC, STRICT, TESTS_C
from gyrowheel.fmu_build.casadi_c import _merge_sincos, _pair_sincos

COMPILERS = [c for c in ("gcc", "clang") if shutil.which(c)]


@pytest.mark.parametrize("cc,extra", [(cc, []) for cc in COMPILERS] + [("gcc", ["-DGW_FASTMATH_NO_SIMD"])])
def test_ulp_error_against_long_double(cc, extra, tmp_path):
    exe = tmp_path / "test_fastmath"
    cmd = [cc, *STRICT, *extra, "-O2", "-fno-math-errno", f"-I{C_SRC}", str(TESTS_C / "test_fastmath.c"), "-lm",
           "-o", str(exe)]
    subprocess.run(cmd, check=True)
    r = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert re.search(r"test_fastmath: \d+ checks, 0 failures", r.stderr), r.stderr
    sets = re.findall(r"^(\w+)\s+(\d+) points: max ulp gw_sin ([\d.]+) .* gw_cos ([\d.]+) ", r.stdout, re.M)
    assert [s[0] for s in sets] == ["uniform", "halfpi", "small", "bound"], r.stdout
    assert sum(int(s[1]) for s in sets) >= 10_000_000
    assert max(max(float(s[2]), float(s[3])) for s in sets) <= 1.0, r.stdout
    assert "gw_sincos2 against gw_sincos: 0 pairs not bit-equal" in r.stdout, r.stdout


def test_generated_code_merges_sincos(example_build):
    built = example_build("paper_earth")  # the run's one default build of the scene, its sources kept
    text = (built.sources / "gw_funcs.c").read_text()
    assert '#include "gw_sincos.h"' in text
    # the vendored msun / fdlibm code travels with Sun's notice, which its terms require kept
    notice = ("Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.",
              "Permission to use, copy, modify, and distribute this software is freely granted,",
              "provided that this notice is preserved.")
    header = (built.sources / "gw_sincos.h").read_text()
    assert all(line in header for line in notice)
    ode = text[text.index("/* gw_ode:"):]
    ode = ode[:ode.index("\n}\n")]
    assert len(re.findall(r"\bgw_sincos2\(", ode)) == 1 and "gw_sincos(" not in ode, ode
    assert not re.search(r"(?<![\w.])(sin|cos)\(", ode), ode


def test_merge_respects_reassignment():
    lines = ["  a1=cos(a0);", "  a0=(a0*a1);", "  a2=sin(a0);", "  a3=cos(a2);", "  a4=sin(a2);",
             "  a5=sin(a6);", "  a6=cos(a6);"]
    _merge_sincos(lines, 0, len(lines) - 1)
    assert lines[0] == "  a1=cos(a0);"  # a0 changes before its sin
    assert lines[2] == "  a2=sin(a0);"
    assert lines[3] == "  casadi_real gw_s0, gw_c0; gw_sincos(a2, &gw_s0, &gw_c0); a3=gw_c0;"
    assert lines[4] == "  a4=gw_s0;"
    assert lines[5] == "  casadi_real gw_s1, gw_c1; gw_sincos(a6, &gw_s1, &gw_c1); a5=gw_s1;"
    assert lines[6] == "  a6=gw_c1;"


def test_pair_respects_uses():
    one = "  casadi_real gw_s0, gw_c0; gw_sincos(a0, &gw_s0, &gw_c0); a1=gw_c0;"
    two = "  casadi_real gw_s1, gw_c1; gw_sincos(a2, &gw_s1, &gw_c1); a3=gw_s1;"
    lines = [one, "  a2=arg[1][3];", two]
    _pair_sincos(lines, 0, 2)
    assert lines == ["", "  a2=arg[1][3];", "  casadi_real gw_s0, gw_c0, gw_s1, gw_c1; gw_sincos2(a0, a2, &gw_s0, "
                     "&gw_c0, &gw_s1, &gw_c1); a1=gw_c0; a3=gw_s1;"]
    # the first's output read, its other result read, its argument written, a block
    for middle in ("  a4=(a1*a2);", "  a4=gw_s0;", "  a0=arg[1][2];", "  }"):
        lines = [one, middle, two]
        _pair_sincos(lines, 0, 2)
        assert lines == [one, middle, two]


def test_include_with_sincos_only():
    from gyrowheel.fmu_build.casadi_c import make_internal
    text = ("#include <math.h>\n\nstatic int casadi_f0(const casadi_real** arg, casadi_real** res, casadi_int* iw, "
            "casadi_real* w, int mem) {\n  casadi_real a0, a1, a2;\n  a0=arg[0][0];\n  a1=cos(a0);\n  a2=sin(a0);\n"
            "  if (res[0]!=0) res[0][0]=(a1*a2);\n  return 0;\n}\n")
    out = make_internal(text, set())
    assert "gw_sincos(a0, &gw_s0, &gw_c0)" in out and '#include "gw_sincos.h"' in out, out


def test_pair_keeps_the_second_argument_written_first():
    """sin(cos x) and cos(cos x) beside sin x: the second gw_sincos reads the first's output,
    which a gw_sincos2 at the second line would read before assigning it."""
    one = "  casadi_real gw_s0, gw_c0; gw_sincos(a0, &gw_s0, &gw_c0); a1=gw_c0;"
    two = "  casadi_real gw_s1, gw_c1; gw_sincos(a1, &gw_s1, &gw_c1); a2=gw_s1;"
    lines = [one, two]
    _pair_sincos(lines, 0, 1)
    assert lines == [one, two]


def _trig_functions():
    """CasADi functions of x (2,) whose generated bodies exercise the sin/cos rewriting: nested
    trig, the same variable reused, if_else branches, reassigned work variables."""
    import casadi as ca
    x = ca.SX.sym("x", 2)
    c = ca.cos(x[0])
    s1 = ca.sin(x[1])
    return x, {
        "nested": ca.vertcat(ca.sin(c) * ca.cos(c), ca.sin(x[0]) * x[1]),
        "nested_sin": ca.vertcat(ca.cos(s1) - ca.sin(s1) * ca.cos(x[1]), ca.sin(ca.sin(s1)) + ca.cos(ca.sin(s1))),
        "chain": ca.vertcat(ca.sin(ca.sin(ca.sin(x[0]))), ca.cos(ca.cos(ca.cos(x[1]))) * ca.sin(x[1])),
        "if_else": ca.vertcat(ca.if_else(x[1] > 0, ca.sin(x[0]), ca.cos(x[0])), ca.sin(x[1]) * ca.cos(x[1])),
        "products": ca.vertcat(ca.sin(x[0]) * ca.cos(x[1]) + ca.cos(x[0]) * ca.sin(x[1]),
                               ca.sin(x[0] + x[1]) * ca.cos(x[0] - x[1]) + ca.cos(x[0] * x[1])),
    }


@pytest.mark.parametrize("cc", COMPILERS)
def test_rewritten_bodies_evaluate_as_casadi(cc, tmp_path):
    """make_internal's gw_sincos / gw_sincos2 rewriting keeps every generated body's value: each
    function compiled strictly (uninitialised reads are errors) and evaluated at several points
    agrees with CasADi's own evaluation to a few ulps."""
    import casadi as ca
    import numpy as np
    from gyrowheel.fmu_build.casadi_c import make_internal
    points = [(0.7, 1.3), (-2.1, -0.4), (3.0, 1e-3), (1e3, -7.5)]
    x, functions = _trig_functions()
    for name, expr in functions.items():
        f = ca.Function("f", [x], [expr])
        cg = ca.CodeGenerator("g.c", {"with_header": False, "with_export": False})
        cg.add(f)
        src = tmp_path / f"{name}.c"
        src.write_text("#define GW_UNITY_BUILD\n" + make_internal(cg.dump(), {"f"}) + r'''
#include <stdio.h>
#include <stdlib.h>
int main(int argc, char **argv) {
    double x[2], r[2]; const double *arg[1]; double *res[1]; casadi_real w[256]; casadi_int iw[16];
    (void)argc;
    x[0] = strtod(argv[1], 0); x[1] = strtod(argv[2], 0); arg[0] = x; res[0] = r;
    f(arg, res, iw, w, 0);
    printf("%.17g %.17g\n", r[0], r[1]);
    return 0;
}
''')
        exe = tmp_path / name
        subprocess.run([cc, *STRICT, "-O2", f"-I{C_SRC}", str(src), "-lm", "-o", str(exe)], check=True)
        for p in points:
            out = subprocess.run([str(exe), repr(p[0]), repr(p[1])], capture_output=True, text=True, check=True)
            got = np.array([float(v) for v in out.stdout.split()])
            want = np.array(f(p)).ravel()
            np.testing.assert_allclose(got, want, rtol=1e-14, atol=1e-15, err_msg=f"{name} at {p}")


FLAG_SETS = {
    "ieee": ["-O2"],
    "fast-math": ["-O2", "-ffast-math", "-fno-finite-math-only"],
    "fast-math-O3-v3": ["-O3", "-ffast-math", "-fno-finite-math-only", "-march=x86-64-v3"],
    "fast-math-no-simd": ["-O2", "-ffast-math", "-fno-finite-math-only", "-DGW_FASTMATH_NO_SIMD"],
}


@pytest.mark.parametrize("cc", COMPILERS)
@pytest.mark.parametrize("flags", list(FLAG_SETS), ids=list(FLAG_SETS))
def test_error_under_a_parent_projects_flags(cc, flags, tmp_path):
    """gw_sincos / gw_sincos2 compiled with a parent project's -ffast-math (the C export allows
    it with -fno-finite-math-only) keep the reduction's extra bits: at most 4 ulp (IEEE flags: 1)
    over [-1e5, 1e5], [-3.5, 3.5] and next to multiples of pi/2.  Without GW_FM_KEEP the
    reassociated reduction is 1e6 ulp off near pi and 1e12 ulp near multiples of pi around 5e4."""
    if "x86-64-v3" in " ".join(FLAG_SETS[flags]):
        import platform
        if platform.machine() not in ("x86_64", "AMD64"):
            pytest.skip("x86-64 only")
    unit = tmp_path / "unit.o"
    subprocess.run([cc, *STRICT, *FLAG_SETS[flags], f"-I{C_SRC}", "-c", str(TESTS_C / "fastmath_unit.c"),
                    "-o", str(unit)], check=True)
    exe = tmp_path / "flags"
    subprocess.run(["gcc", *STRICT, "-O2", str(TESTS_C / "test_fastmath_flags.c"), str(unit), "-lm", "-o", str(exe)],
                   check=True)
    out = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300, check=True).stdout
    bound = 1.0 if flags == "ieee" else 4.0
    rows = re.findall(r"^(\w+) max ulp ([\d.]+) ([\d.]+)$", out, re.M)
    assert [r[0] for r in rows] == ["uniform", "small", "halfpi"], out
    for name, es, ec in rows:
        assert float(es) <= bound and float(ec) <= bound, out
    assert "nan 1 1" in out and "inf 1 1" in out, out
    if flags == "ieee":
        assert "negzero 1 1" in out, out


LOG_EXP_FLAGS = {
    "ieee": ["-O2"],
    "avx2": ["-O2", "-mavx2"],
    "x86-64-v3": ["-O2", "-march=x86-64-v3"],
    "fast-math": ["-O2", "-ffast-math", "-fno-finite-math-only"],
    "fast-math-O3-v3": ["-O3", "-ffast-math", "-fno-finite-math-only", "-march=x86-64-v3"],
}


@pytest.mark.parametrize("cc", COMPILERS)
@pytest.mark.parametrize("flags", list(LOG_EXP_FLAGS), ids=list(LOG_EXP_FLAGS))
def test_log_exp_error_and_lanes(cc, flags, tmp_path):
    """gw_fm_log / gw_fm_exp (c_src/gw_fm_logexp.h), the ensemble's step size ln and exp (its
    one-lane code and its 4-lane pass), in ulps against long double over 1e7 points: the norms' range
    [1e-300, 1e300], [0.5, 2], subnormals, ln h in [-60, 10], every finite exp; the 4-lane forms
    bit-equal lane by lane with the FMU's flags (the ensemble's bit-identity with its one-lane
    path rests on it).  Compiled as a separate unit (tests/c/fastexp_unit.c) with the flags
    under test, measured from a harness compiled with IEEE semantics."""
    if any("x86-64-v3" in f or "avx2" in f for f in LOG_EXP_FLAGS[flags]):
        import platform
        if platform.machine() not in ("x86_64", "AMD64"):
            pytest.skip("x86-64 only")
    fast = "-ffast-math" in LOG_EXP_FLAGS[flags]
    unit = tmp_path / "unit.o"
    subprocess.run([cc, *STRICT, *LOG_EXP_FLAGS[flags], f"-I{C_SRC}", "-c", str(TESTS_C / "fastexp_unit.c"),
                    "-o", str(unit)], check=True)
    exe = tmp_path / "fastexp"
    bound = "3.0" if fast else "0.9"
    subprocess.run(["gcc", *STRICT, "-O2", "-DGW_FASTEXP_UNIT", f"-DGW_FASTEXP_ULP_BOUND={bound}",
                    f"-DGW_FASTEXP_LANES_EXACT={0 if fast else 1}", f"-I{C_SRC}", str(TESTS_C / "test_fastexp.c"),
                    str(unit), "-lm", "-o", str(exe)], check=True)
    r = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert re.search(r"test_fastexp: \d+ checks, 0 failures", r.stderr), r.stderr
    rows = re.findall(r"^(\w+)\s+(\d+) points: max ulp ([\d.]+) ", r.stdout, re.M)
    assert [row[0] for row in rows] == ["norms", "unit", "subnorm", "step", "wide"], r.stdout
    assert sum(int(row[1]) for row in rows) >= 10_000_000
    assert max(float(row[2]) for row in rows) < float(bound), r.stdout
    if not fast:
        assert "against gw_fm_log / gw_fm_exp: 0 lanes not bit-equal" in r.stdout, r.stdout


def test_log_exp_inline_lanes(tmp_path):
    """The same program with gw_fm_log4 / gw_fm_exp4 inlined into the harness (as in the ensemble's
    passes): every lane bit-equal to the scalar form, below 0.9 ulp."""
    exe = tmp_path / "fastexp_inline"
    subprocess.run(["gcc", *STRICT, "-O2", f"-I{C_SRC}", str(TESTS_C / "test_fastexp.c"), "-lm", "-o", str(exe)],
                   check=True)
    r = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and "0 lanes not bit-equal" in r.stdout, r.stdout + r.stderr
