"""compile_shared's build cache (gyrowheel.fmu_build.build_cache): a hit gives the library the
compiler built, byte for byte, without running the compiler; a change of source (or of a header
it includes), of a flag or of the compiler misses; a damaged entry is not used; unset, nothing
is cached."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from gyrowheel.fmu_build import build_cache, compiler
from gyrowheel.fmu_build.compiler import CompileError, compile_shared

SOURCE = '#include "answer.h"\nint gw_answer(void) { return ANSWER; }\n'


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A cache of this test's, and the compiler's runs counted: cache.compiles."""
    directory = tmp_path / "cache"
    monkeypatch.setenv(build_cache.ENV, str(directory))
    run = compiler._run
    calls: list[list[str]] = []

    def counted(cmd):
        calls.append(cmd)
        return run(cmd)
    monkeypatch.setattr(compiler, "_run", counted)

    class Cache:
        path = directory
        compiles = calls
    return Cache


def _sources(root: Path, answer: int = 42) -> Path:
    """root/src/lib.c including root/include/answer.h (ANSWER = answer): the unity file."""
    (root / "src").mkdir(parents=True, exist_ok=True)
    (root / "include").mkdir(exist_ok=True)
    (root / "include" / "answer.h").write_text(f"#define ANSWER {answer}\n")
    source = root / "src" / "lib.c"
    source.write_text(SOURCE)
    return source


def _build(root: Path, out: str, flags=None, answer: int = 42) -> bytes:
    source = _sources(root, answer)
    return compile_shared(source, [root / "include"], root / out, extra_flags=flags).read_bytes()


def test_a_hit_is_the_built_library_byte_for_byte_without_compiling(cache, tmp_path):
    first = _build(tmp_path / "a", "first.so")
    assert len(cache.compiles) == 1
    # the same files in another directory, another output name: the same build
    again = _build(tmp_path / "b", "again.so")
    assert len(cache.compiles) == 1 and again == first
    entries = list(cache.path.glob(f"*{build_cache.SUFFIX}"))
    assert len(entries) == 1 and entries[0].read_bytes().endswith(first)
    assert not list(cache.path.glob("*.part")) and not list((tmp_path / "b").glob("*.part"))


@pytest.mark.parametrize("change", ["header", "source", "flag", "define", "compiler"])
def test_any_change_of_what_is_built_misses(cache, tmp_path, monkeypatch, change):
    first = _build(tmp_path / "a", "lib.so")
    root, kwargs = tmp_path / "b", {}
    if change == "header":
        kwargs["answer"] = 43
    elif change == "flag":
        kwargs["flags"] = ["-fno-strict-aliasing"]  # changes no macro: the flag list itself is in the key
    elif change == "define":
        kwargs["flags"] = ["-DGW_UNUSED_SWITCH=1"]
    elif change == "compiler":  # the same gcc through another path: another compiler as far as we know
        wrapper = tmp_path / "bin" / "cc"
        wrapper.parent.mkdir()
        wrapper.write_text(f'#!/bin/sh\nexec {shutil.which(compiler.compiler())} "$@"\n')
        wrapper.chmod(0o755)
        monkeypatch.setenv("CC", str(wrapper))
    if change == "source":
        source = _sources(root)
        source.write_text(SOURCE + "int gw_other(void) { return 1; }\n")
        compile_shared(source, [root / "include"], root / "lib.so")
    else:
        _build(root, "lib.so", **kwargs)
    assert len(cache.compiles) == 2
    assert len(list(cache.path.glob(f"*{build_cache.SUFFIX}"))) == 2
    if change == "header":
        assert (root / "lib.so").read_bytes() != first


@pytest.mark.parametrize("damage", ["flipped", "cut", "empty", "no digest"])
def test_a_damaged_entry_is_not_used_and_is_replaced(cache, tmp_path, damage):
    first = _build(tmp_path / "a", "lib.so")
    [entry] = cache.path.glob(f"*{build_cache.SUFFIX}")
    data = entry.read_bytes()
    head, _, library = data.partition(b"\n")
    entry.write_bytes({"flipped": head + b"\n" + library[:-1] + bytes([library[-1] ^ 1]),
                       "cut": data[: len(data) // 2], "empty": b"", "no digest": library}[damage])
    again = _build(tmp_path / "b", "lib.so")
    assert len(cache.compiles) == 2 and again == first
    assert entry.read_bytes() == data  # rewritten whole


def test_a_compile_error_is_reported_and_nothing_is_stored(cache, tmp_path):
    source = _sources(tmp_path)
    source.write_text("int gw_broken(void) { return undeclared; }\n")
    with pytest.raises(CompileError, match="undeclared"):
        compile_shared(source, [tmp_path / "include"], tmp_path / "lib.so")
    source.write_text('#include "missing.h"\n')  # the preprocessor fails: the compiler's message
    with pytest.raises(CompileError, match="missing.h"):
        compile_shared(source, [tmp_path / "include"], tmp_path / "lib.so")
    assert not list(cache.path.glob(f"*{build_cache.SUFFIX}"))


def test_unset_nothing_is_cached(cache, tmp_path, monkeypatch):
    monkeypatch.delenv(build_cache.ENV)
    first = _build(tmp_path / "a", "lib.so")
    assert _build(tmp_path / "b", "lib.so") == first
    assert len(cache.compiles) == 2 and not cache.path.exists()


def test_line_markers_keep_file_names_not_directories():
    text = b'# 1 "/tmp/x/build/gw_fmu.c"\n# 12 "/usr/include/stdio.h" 1 3 4\nint a;\n# 3 "a \\"b\\"/c.h" 2\n'
    assert build_cache._strip_directories(text) == \
        b'# 1 "gw_fmu.c"\n# 12 "stdio.h" 1 3 4\nint a;\n# 3 "c.h" 2\n'
