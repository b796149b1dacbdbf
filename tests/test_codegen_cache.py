"""The cache of the generated C (gyrowheel.fmu_build.codegen_cache): an FMU built from a hit has
the bytes of one built without the cache; a change of the functions, of CasADi or of gyrowheel's
generator misses; a damaged entry is generated again; processes generating the same functions at
once generate once; unset, nothing is cached."""
from __future__ import annotations

import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import casadi as ca
import pytest

from gyrowheel.fmu_build import build_cache, build_fmu, codegen, codegen_cache, load_scene

SCENES = Path(__file__).resolve().parent.parent / "examples" / "scenes"


@pytest.fixture
def cache(own_build_cache):
    """A cache of this test's (compiles too), and the generator's runs counted: cache.generated."""
    own_build_cache.generated = own_build_cache.calls(codegen, "_generate")
    own_build_cache.entries = lambda: list(own_build_cache.path.glob(f"*{codegen_cache.SUFFIX}"))
    return own_build_cache


def _functions(scale: float = 2.0, name: str = "gw_ode") -> dict[str, ca.Function]:
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p")
    xdot = ca.vertcat(x[1], -p * ca.sin(x[0]) + scale * ca.cos(x[0]) * ca.sin(x[0]))
    return {"ode": ca.Function(name, [x, p], [xdot], ["x", "p"], ["xdot"])}


def _generate(directory: Path, functions=None) -> tuple[str, dict[str, ca.Function]]:
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "gw_funcs.c"
    functions = functions or _functions()
    fns = codegen_cache.cached_generation(functions, path, lambda: codegen._generate(functions, path))
    return path.read_text(), fns


def _fmu_files(fmu: Path) -> dict[str, bytes]:
    """Every file of the FMU, the build's time (generationDateAndTime) left out."""
    with zipfile.ZipFile(fmu) as zf:
        return {n: re.sub(rb'generationDateAndTime="[^"]*"', b"", zf.read(n)) for n in zf.namelist()}


@pytest.mark.parametrize("scene, fmi, taylor", [("paper_earth", 3, True), ("slope_hold", 2, None)])
def test_an_fmu_built_from_a_hit_has_the_bytes_of_one_built_without_the_cache(cache, tmp_path, monkeypatch,
                                                                              scene, fmi, taylor):
    """paper_earth with the Taylor kernel (written from the functions the entry holds) and the
    Initialization Mode partials of FMI 3; slope_hold, an FMI 2 FMU with hoisted ode_pre and
    update events (gw_upd).  Every file of the FMU: sources, modelDescription.xml (its guid hashes the
    generated C; the build's time left out), the binary."""
    def build(where: str) -> dict[str, bytes]:
        out = tmp_path / where
        out.mkdir()
        build_fmu(load_scene(SCENES / f"{scene}.toml"), out / f"{scene}.fmu", build_dir=out / "build",
                  taylor=taylor, fmi=fmi)
        return _fmu_files(out / f"{scene}.fmu")
    with monkeypatch.context() as off:
        off.delenv(build_cache.ENV)
        without = build("off")
    assert len(cache.generated) == 1 and not cache.path.exists()
    missed = build("miss")
    assert len(cache.generated) == 2 and len(cache.entries()) == 1
    hit = build("hit")
    assert len(cache.generated) == 2, "a hit generates nothing"
    assert "sources/gw_funcs.c" in without and "sources/model_desc.c" in without
    assert missed.keys() == without.keys() == hit.keys()
    for name in without:
        assert missed[name] == without[name], name
        assert hit[name] == without[name], name


def test_a_hit_returns_the_functions_generated(cache, tmp_path):
    text, fns = _generate(tmp_path / "a")
    again, cached = _generate(tmp_path / "b")
    assert len(cache.generated) == 1 and again == text and "gw_ode" in text
    assert list(cached) == ["ode"] and cached["ode"].name() == "gw_ode"
    x, p = [0.3, -1.2], 9.81
    assert float(cached["ode"](x, p)[1]) == float(fns["ode"](x, p)[1]) == pytest.approx(
        -9.81 * 0.29552020666133955 + 2.0 * 0.955336489125606 * 0.29552020666133955, rel=1e-15)


@pytest.mark.parametrize("change", ["expression", "function name", "casadi", "generator"])
def test_any_change_of_what_is_generated_misses(cache, tmp_path, monkeypatch, change):
    _generate(tmp_path / "a")
    functions = None
    if change == "expression":
        functions = _functions(scale=3.0)
    elif change == "function name":
        functions = _functions(name="gw_ode2")
    elif change == "casadi":
        monkeypatch.setattr(codegen_cache, "casadi_identity", lambda: b"3.9.0\0other")
    else:  # an edit of make_internal's module: a copy with one more byte
        edited = tmp_path / "casadi_c.py"
        edited.write_bytes(codegen_cache.GENERATORS[1].read_bytes() + b"\n")
        monkeypatch.setattr(codegen_cache, "GENERATORS", (codegen_cache.GENERATORS[0], edited))
    _generate(tmp_path / "b", functions)
    assert len(cache.generated) == 2 and len(cache.entries()) == 2


@pytest.mark.parametrize("damage", ["flipped", "cut", "empty", "no digest"])
def test_a_damaged_entry_is_generated_again_and_replaced(cache, tmp_path, damage):
    text, _ = _generate(tmp_path / "a")
    [entry] = cache.entries()
    data = entry.read_bytes()
    head, _, body = data.partition(b"\n")
    entry.write_bytes({"flipped": head + b"\n" + body[:-1] + bytes([body[-1] ^ 1]),
                       "cut": data[: len(data) // 2], "empty": b"", "no digest": body}[damage])
    again, _ = _generate(tmp_path / "b")
    assert len(cache.generated) == 2 and again == text
    assert entry.read_bytes() == data  # rewritten whole


def test_unset_nothing_is_cached(cache, tmp_path, monkeypatch):
    monkeypatch.delenv(build_cache.ENV)
    text, _ = _generate(tmp_path / "a")
    again, _ = _generate(tmp_path / "b")
    assert again == text and len(cache.generated) == 2 and not cache.path.exists()


WRITER = """
import sys, time
from pathlib import Path
sys.path.insert(0, {tests!r})
import test_codegen_cache as t
from gyrowheel.fmu_build import codegen, codegen_cache
out, log = Path(sys.argv[1]), Path(sys.argv[2])
functions = t._functions()
path = out / "gw_funcs.c"
out.mkdir(parents=True)
def generate():
    with open(log, "a") as f:
        f.write("generated\\n")
    time.sleep(1.0)  # the other process asks meanwhile
    return codegen._generate(functions, path)
codegen_cache.cached_generation(functions, path, generate)
"""


def test_processes_generating_at_once_generate_once(tmp_path):
    script = tmp_path / "writer.py"
    script.write_text(WRITER.format(tests=str(Path(__file__).resolve().parent)))
    env = {**os.environ, build_cache.ENV: str(tmp_path / "cache")}
    log = tmp_path / "log"
    procs = [subprocess.Popen([sys.executable, str(script), str(tmp_path / f"w{i}"), str(log)], env=env,
                              stderr=subprocess.PIPE, text=True) for i in range(2)]
    for proc in procs:
        assert proc.wait(timeout=120) == 0, proc.stderr.read()
    assert log.read_text() == "generated\n"
    texts = {(tmp_path / f"w{i}" / "gw_funcs.c").read_text() for i in range(2)}
    assert len(texts) == 1 and "gw_ode" in texts.pop()
    assert len(list((tmp_path / "cache").glob(f"*{codegen_cache.SUFFIX}"))) == 1
    assert not list((tmp_path / "cache").glob("*.part"))
