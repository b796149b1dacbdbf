"""A built FMU's sources/ as an importer builds them (docs/runtime.md), for the FMI 2.0 FMU
and the FMI 3.0 FMU of a scene (parametrized by fmi: FMI 2 lists its source in
modelDescription.xml <SourceFiles>, FMI 3 in sources/buildDescription.xml).

  test_every_source_file_is_warning_clean   each .c of sources/ alone and the unity file, with
                                            -std=c99 -Wall -Wextra -Wpedantic -Werror, gcc and
                                            clang (clang skipped only where it is not installed;
                                            `make test` and CI install it)
  test_plain_cc_build_exports_only_the_fmi_functions   `cc -shared -fPIC` with no visibility
                                            flag, of the listed source and of every .c file:
                                            nm -D lists exactly the functions of the version's
                                            header; nothing writable
  test_each_compiler_exports_only_the_fmi_functions   the listed source built by gcc and by
                                            clang, of an FMU without and one with the Taylor
                                            kernel: nm -D lists exactly those functions (no
                                            `<name>.resolver`)
  test_two_fmus_with_rtld_global            paper_earth and euler_disk built that way, loaded with
                                            RTLD_GLOBAL into one process: both instantiate and
                                            reproduce their own FMU's results
  test_fmpy_build_platform_binary_strict    fmpy's CMake build (only the listed source files)
                                            with all warnings as errors, then simulated: the
                                            results of the FMU as built
  test_optimisation_levels_compute_the_same_bits   GYROWHEEL_OPTIMISE -O1 (the test suite's
                                            builds) against the product's -O2: every solver's run
                                            is the same bits; a level that is none is refused
  test_make_internal_*                      gyrowheel.fmu_build.casadi_c on CasADi-shaped input
"""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu

from c_programs import FMI_HEADERS, writable_symbols
from gyrowheel.fmu_build.casadi_c import CodegenFormatError, make_internal

STRICT_C99 = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
STATES = ["x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot", "gamma_dot"]


FMI_VERSIONS = (2, 3)
UNITY = {2: "gw_fmu.c", 3: "gw_fmu3.c"}  # the one source file each version's FMU lists
BINARIES = {2: "linux64", 3: "x86_64-linux"}  # this machine's folder (FMI 2.0.4 section 2.3; FMI 3.0 tuple)


def fmi_function_names(fmi: int = 2) -> set[str]:
    """The functions fmi<fmi>Functions.h declares (FMI<N>_Export fmi<N>XTYPE fmi<N>X;)."""
    import re
    names = set(re.findall(rf"FMI{fmi}_Export\s+fmi{fmi}\w+TYPE\s+(fmi{fmi}\w+)\s*;",
                           (FMI_HEADERS / f"fmi{fmi}Functions.h").read_text()))
    assert len(names) == {2: 44, 3: 75}[fmi]
    return names


@pytest.fixture(scope="module")
def disk_fmu(example_build) -> Path:
    return example_build("euler_disk").fmu


def _unzip(fmu: Path, where: Path) -> Path:
    extract(str(fmu), str(where))
    return where


def _plain_cc(sources: list[Path], include: Path, out: Path) -> Path:
    cmd = ["cc", "-shared", "-fPIC", "-O1", f"-I{include}", *map(str, sources), "-o", str(out), "-lm"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, f"{' '.join(cmd)}\n{r.stderr}"
    return out


def _exports(lib: Path) -> set[str]:
    nm = subprocess.run(["nm", "-D", "--defined-only", str(lib)], capture_output=True, text=True, check=True)
    return {line.split()[-1] for line in nm.stdout.splitlines() if line.strip()}


@pytest.mark.parametrize("fmi", FMI_VERSIONS)
@pytest.mark.parametrize("cc", ["gcc", "clang"])
def test_every_source_file_is_warning_clean(cc, fmi, example_build, tmp_path):
    if shutil.which(cc) is None:
        pytest.skip(f"{cc} is not installed (make test installs it: Debian package {cc})")
    src = _unzip(example_build("paper_earth", fmi=fmi).fmu, tmp_path / "fmu") / "sources"
    files = sorted(src.glob("*.c"))
    assert len(files) >= 20 and (src / "gw_funcs.c") in files and (src / UNITY[fmi]) in files
    for path in files:
        r = subprocess.run([cc, *STRICT_C99, "-c", f"-I{src}", str(path), "-o", str(tmp_path / "x.o")],
                           capture_output=True, text=True)
        assert r.returncode == 0, f"{cc} {path.name}:\n{r.stderr}"
    # the library itself, optimised as importers do (more warnings appear with optimisation)
    r = subprocess.run([cc, *STRICT_C99, "-O2", "-shared", "-fPIC", f"-I{src}", str(src / UNITY[fmi]),
                        "-o", str(tmp_path / "lib.so"), "-lm"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("fmi", FMI_VERSIONS)
@pytest.mark.parametrize("which", ["listed", "every_c_file"])
def test_plain_cc_build_exports_only_the_fmi_functions(which, fmi, example_build, tmp_path):
    """The listed source: modelDescription.xml's <SourceFiles> (FMI 2), sources/buildDescription.xml
    (FMI 3, read by fmpy); every .c file: the same library, the parts compiled alone are empty."""
    root = _unzip(example_build("paper_earth", fmi=fmi).fmu, tmp_path / "fmu")
    src = root / "sources"
    listed = read_model_description(str(root)).buildConfigurations[0].sourceFileSets[0].sourceFiles
    assert listed == [UNITY[fmi]]
    files = [src / n for n in listed] if which == "listed" else sorted(src.glob("*.c"))
    lib = _plain_cc(files, src, tmp_path / "paper_earth.so")
    assert _exports(lib) == fmi_function_names(fmi)
    obj = tmp_path / "unity.o"
    subprocess.run(["cc", "-c", "-O2", f"-I{src}", str(src / UNITY[fmi]), "-o", str(obj)], check=True)
    assert writable_symbols(obj) == []


@pytest.mark.parametrize("fmi", FMI_VERSIONS)
@pytest.mark.parametrize("cc", ["gcc", "clang"])
@pytest.mark.parametrize("kernel", [False, True], ids=["no_kernel", "kernel"])
def test_each_compiler_exports_only_the_fmi_functions(kernel, cc, fmi, example_build, tmp_path):
    if shutil.which(cc) is None:
        pytest.skip(f"{cc} is not installed (make test installs it: Debian package {cc})")
    src = _unzip(example_build("paper_earth", taylor=kernel, fmi=fmi).fmu, tmp_path / "fmu") / "sources"
    assert ("GW_TL_NX" in (src / "gw_taylor_model.h").read_text()) == kernel
    lib = tmp_path / "paper_earth.so"
    r = subprocess.run([cc, "-shared", "-fPIC", "-O2", f"-I{src}", str(src / UNITY[fmi]), "-o", str(lib), "-lm"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert _exports(lib) == fmi_function_names(fmi)


CHILD = textwrap.dedent("""
    import ctypes, json, sys
    from fmpy import simulate_fmu
    dirs, libs = sys.argv[1:3], sys.argv[3:5]
    for lib in libs:  # as an importer that loads every FMU with RTLD_GLOBAL
        ctypes.CDLL(lib, mode=ctypes.RTLD_GLOBAL)
    out = []
    for d in dirs:
        r = simulate_fmu(d, stop_time=0.5, output_interval=0.05, validate=False)
        out.append([float(r[n][-1]) for n in r.dtype.names])
    print(json.dumps(out))
""")


def test_two_fmus_with_rtld_global(earth_fmu, disk_fmu, tmp_path):
    dirs, libs, expected = [], [], []
    for fmu in (earth_fmu, disk_fmu):
        r = simulate_fmu(str(fmu), stop_time=0.5, output_interval=0.05)  # the FMU as built
        expected.append([float(r[n][-1]) for n in r.dtype.names])
        root = _unzip(fmu, tmp_path / fmu.stem)
        ident = read_model_description(str(root)).coSimulation.modelIdentifier
        lib = root / "binaries" / "linux64" / f"{ident}.so"
        _plain_cc([root / "sources" / "gw_fmu.c"], root / "sources", lib)  # replaces the binary
        dirs.append(str(root))
        libs.append(str(lib))
    assert expected[0] != expected[1]
    p = subprocess.run([sys.executable, "-c", CHILD, *dirs, *libs], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    got = json.loads(p.stdout.strip().splitlines()[-1])
    for g, e in zip(got, expected):
        np.testing.assert_allclose(g, e, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("fmi", FMI_VERSIONS)
def test_fmpy_build_platform_binary_strict(fmi, example_build, tmp_path):
    """fmpy's CMake build reads the listed sources (FMI 3: sources/buildDescription.xml) and
    writes this machine's folder (FMI 3: the platform tuple); the rebuilt FMU (of either
    version) simulates as the FMI 2 FMU as built."""
    if shutil.which("cmake") is None:
        pytest.skip("cmake is not installed (make test installs it: Debian package cmake)")
    from fmpy.build import build_platform_binary
    fmu = example_build("paper_earth", fmi=fmi).fmu
    root = _unzip(fmu, tmp_path / "fmu")
    lib = root / "binaries" / BINARIES[fmi] / "paper_earth.so"
    lib.unlink()
    (tmp_path / "build").mkdir()
    build_platform_binary(root, build_dir=tmp_path / "build", all_warnings=True,
                          cmake_options={"CMAKE_COMPILE_WARNING_AS_ERROR:BOOL": "ON"})
    assert lib.exists() and _exports(lib) == fmi_function_names(fmi)
    got = simulate_fmu(str(root), stop_time=1.0, output_interval=0.1)
    ref = simulate_fmu(str(example_build("paper_earth").fmu), stop_time=1.0, output_interval=0.1)
    for name in STATES:
        np.testing.assert_allclose(got[name], ref[name], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("scene, solvers", [
    ("paper_earth", ["taylor", "dop853", "dopri5", "rosenbrock", "rk4"]),
    ("paper_earth_friction", ["dopri5", "rosenbrock"]),  # its stiction events
])
def test_optimisation_levels_compute_the_same_bits(scene, solvers, example_build, tmp_path):
    """The suite builds at -O1 (conftest compiled_at); the product at -O2.  Without -ffast-math
    and with C99's contraction off, both levels compute the same IEEE operations in the same
    order; the Taylor kernel, which fuses multiply-adds, asks GCC for its FMA pass at any level
    (c_src/gw_taylor.c, GW_TAYLOR_OPT).  So every solver's run is bit for bit the same."""
    from conftest import SCENES, compiled_at
    from gyrowheel import simulate
    from gyrowheel.fmu_build import build_fmu, load_scene
    fast = example_build(scene).fmu
    with compiled_at("-O2"):
        product = build_fmu(load_scene(SCENES / f"{scene}.toml"), tmp_path / f"{scene}.fmu").fmu
    assert product.read_bytes() != Path(fast).read_bytes()
    for solver in solvers:
        a = simulate(product, start_values={"solver": solver}, stop_time=20.0)
        b = simulate(fast, start_values={"solver": solver}, stop_time=20.0)
        assert len(a) > 10
        for name in a.dtype.names:
            np.testing.assert_array_equal(a[name], b[name], err_msg=f"{solver}: {name}")


def test_an_unknown_optimisation_level_is_refused(tmp_path, monkeypatch):
    from gyrowheel.fmu_build.compiler import OPTIMISE_ENV, CompileError, optimisation_for
    monkeypatch.setenv(OPTIMISE_ENV, "-Ofast")  # not IEEE: refused, not passed on
    with pytest.raises(CompileError, match=r"GYROWHEEL_OPTIMISE='-Ofast': not an optimisation level; use one of -O0"):
        optimisation_for(tmp_path)
    proc = subprocess.run([sys.executable, "-m", "gyrowheel", "build", "examples/scenes/paper_moon.toml", "-o",
                           str(tmp_path / "m.fmu")], capture_output=True, text=True,
                          cwd=Path(__file__).parents[1])
    assert proc.returncode == 2 and "GYROWHEEL_OPTIMISE='-Ofast'" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr and "compiling" not in proc.stderr  # a setting, not a failed build
    # the C export's check compiles at the level of an FMU build of the same C: refused alike
    proc = subprocess.run([sys.executable, "-m", "gyrowheel", "export-c", "examples/scenes/paper_moon.toml", "-o",
                           str(tmp_path / "export")], capture_output=True, text=True, cwd=Path(__file__).parents[1])
    assert proc.returncode == 2 and "GYROWHEEL_OPTIMISE='-Ofast'" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr and "compiling" not in proc.stderr


# ---- gyrowheel.fmu_build.casadi_c -------------------------------------------------------------------------

GENERATED = """\
#define casadi_f0 CASADI_PREFIX(f0)
#define casadi_s0 CASADI_PREFIX(s0)
#define casadi_s1 CASADI_PREFIX(s1)
#define casadi_sq CASADI_PREFIX(sq)

casadi_real casadi_sq(casadi_real x) { return x*x;}

void m_casadi_version(int* major, int* minor, int* patch) {
  *major = 3;
}

static const casadi_int casadi_s0[3] = {1, 1, 1};
static const casadi_int casadi_s1[3] = {2, 1, 1};

static int casadi_f0(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem) {
  casadi_real a0;
  a0=arg[0]? arg[0][0] : 0;
  if (res[0]!=0) res[0][0]=casadi_sq(a0);
  return 0;
}

int gw_ode(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem){
  return casadi_f0(arg, res, iw, w, mem);
}

void gw_ode_release(int mem) {
}

const casadi_int* gw_ode_sparsity_in(casadi_int i) {
  switch (i) {
    case 0: return casadi_s0;
    default: return 0;
  }
}

int gw_ode_work(casadi_int *sz_arg, casadi_int* sz_res, casadi_int *sz_iw, casadi_int *sz_w) {
  if (sz_arg) *sz_arg = 1;
  return 0;
}
"""


def test_make_internal_keeps_what_the_runtime_calls_static():
    out = make_internal(GENERATED, {"gw_ode", "gw_ode_work"})
    assert out.startswith("#ifndef GW_UNITY_BUILD") and out.rstrip().endswith("#endif /* GW_UNITY_BUILD */")
    assert "static int gw_ode(" in out and "static int gw_ode_work(" in out
    assert "static casadi_real casadi_sq(" in out
    assert "  (void)iw; (void)w; (void)mem;" in out  # the body ignores them
    for gone in ("gw_ode_release", "gw_ode_sparsity_in", "m_casadi_version", "casadi_s0[3]", "casadi_s1[3]"):
        assert gone not in out, gone


def test_make_internal_refuses_what_it_does_not_know():
    with pytest.raises(CodegenFormatError, match="lacks the functions"):
        make_internal(GENERATED, {"gw_ode", "gw_ode_work", "gw_out"})
    with pytest.raises(CodegenFormatError, match="non-static object"):
        make_internal(GENERATED + "\ncasadi_int gw_counter = 0;\n", {"gw_ode", "gw_ode_work"})


def test_large_generated_sources_are_compiled_at_O1(tmp_path, monkeypatch):
    """-O2 on CasADi's multi-megabyte straight-line functions costs minutes (docs/runtime.md);
    the level follows the largest file the unity build includes."""
    from gyrowheel.fmu_build.compiler import (LARGE_SOURCE_BYTES, OPTIMISE, OPTIMISE_ENV, OPTIMISE_LARGE,
                                              optimisation_for)
    monkeypatch.delenv(OPTIMISE_ENV)  # the product's rule, not the test suite's -O1
    (tmp_path / "gw_fmu.c").write_text("/* unity */\n")
    (tmp_path / "gw_funcs.c").write_text("x" * 1000)
    assert optimisation_for(tmp_path) == OPTIMISE and "-O2" in OPTIMISE
    (tmp_path / "gw_funcs.c").write_text("x" * (LARGE_SOURCE_BYTES + 1))
    assert optimisation_for(tmp_path) == OPTIMISE_LARGE and "-O1" in OPTIMISE_LARGE
