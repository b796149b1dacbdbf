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
def cache(own_build_cache):
    """A cache of this test's, and the compiler's runs counted: cache.compiles."""
    own_build_cache.compiles = own_build_cache.calls(compiler, "_run")
    return own_build_cache


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


@pytest.mark.skipif(shutil.which("clang") is None, reason="clang is not installed")
def test_clang_builds_are_cached_too(cache, tmp_path, monkeypatch):
    # the key's preprocessor call leaves out the linker's arguments, which clang -Werror refuses
    monkeypatch.setenv("CC", "clang")
    first = _build(tmp_path / "a", "first.so")
    assert _build(tmp_path / "b", "again.so") == first
    assert len(cache.compiles) == 1 and len(list(cache.path.glob(f"*{build_cache.SUFFIX}"))) == 1


def test_a_cache_path_that_is_no_directory_is_refused_naming_the_variable(tmp_path, monkeypatch):
    """Through the API and the command line (exit 2, one line), before anything is built."""
    import subprocess
    import sys
    from gyrowheel.errors import ArgumentError
    afile = tmp_path / "afile"
    afile.write_text("")
    monkeypatch.setenv(build_cache.ENV, str(afile))
    with pytest.raises(ArgumentError, match=rf"^GYROWHEEL_BUILD_CACHE='{afile}': not a directory"):
        _build(tmp_path / "a", "lib.so")
    monkeypatch.setenv(build_cache.ENV, str(afile / "below"))  # its parent is a file: cannot be made
    with pytest.raises(ArgumentError, match=r"^GYROWHEEL_BUILD_CACHE='.*below': the cache's directory cannot be made"):
        _build(tmp_path / "a", "lib.so")
    monkeypatch.setenv(build_cache.ENV, str(afile))
    proc = subprocess.run([sys.executable, "-m", "gyrowheel", "build", "examples/scenes/paper_moon.toml", "-o",
                           str(tmp_path / "m.fmu")], capture_output=True, text=True, cwd=Path(__file__).parents[1])
    assert proc.returncode == 2 and proc.stderr == (f"gyrowheel: error: GYROWHEEL_BUILD_CACHE='{afile}': not a "
                                                    "directory; name a directory for the build cache, or unset it "
                                                    "to build without one\n"), proc.stderr
    assert not (tmp_path / "m.fmu").exists()


def test_a_cache_that_cannot_be_written_is_read_and_a_miss_built_with_a_warning(cache, tmp_path, monkeypatch):
    first = _build(tmp_path / "a", "first.so")  # stored while the cache could be written
    writes = build_cache._write_atomic

    def read_only(path, data):
        if path.parent == cache.path:
            raise PermissionError(13, "Permission denied", str(path))
        writes(path, data)
    monkeypatch.setattr(build_cache, "_write_atomic", read_only)
    assert _build(tmp_path / "b", "hit.so") == first and len(cache.compiles) == 1  # still read
    with pytest.warns(build_cache.BuildCacheWarning, match=r"cannot store this build in the cache \(Permission "
                                                           r"denied\); it was built and is used without it"):
        other = _build(tmp_path / "c", "miss.so", answer=7)
    assert len(cache.compiles) == 2 and other != first
    assert len(list(cache.path.glob(f"*{build_cache.SUFFIX}"))) == 1


def test_a_lock_that_cannot_be_opened_reads_without_it(cache, tmp_path):
    cache.path.mkdir()
    data, hit = build_cache.cached_entry(cache.path, "k", ".e", lambda: b"x")
    (cache.path / "k.lock").unlink()
    (cache.path / "k.lock").mkdir()  # open() of a directory fails for writing and for reading
    assert build_cache.cached_entry(cache.path, "k", ".e", lambda: b"y") == (b"x", True)
    assert (data, hit) == (b"x", False)


def test_the_command_line_says_in_one_line_when_a_build_is_not_kept(tmp_path):
    """Entries that can be neither read nor replaced (here: directories in their place): the FMU is
    built and correct, and each build the cache could not keep is one `gyrowheel: warning:` line."""
    import os
    import subprocess
    import sys
    cache = tmp_path / "cache"
    env = {**os.environ, build_cache.ENV: str(cache)}
    cmd = [sys.executable, "-m", "gyrowheel", "build", "examples/scenes/paper_moon.toml", "-o"]
    root = Path(__file__).parents[1]
    first = subprocess.run([*cmd, str(tmp_path / "a.fmu")], capture_output=True, text=True, env=env, cwd=root)
    assert first.returncode == 0 and first.stderr == "", first.stderr
    entries = sorted(cache.glob("*.entry"))
    assert len(entries) == 2  # the generated C and the library
    for entry in entries:
        entry.unlink()
        entry.mkdir()
    again = subprocess.run([*cmd, str(tmp_path / "b.fmu")], capture_output=True, text=True, env=env, cwd=root)
    lines = again.stderr.splitlines()
    assert again.returncode == 0 and len(lines) == 2, again.stderr
    assert all(line.startswith(f"gyrowheel: warning: GYROWHEEL_BUILD_CACHE='{cache}': cannot store this build")
               for line in lines), again.stderr
    import zipfile
    with zipfile.ZipFile(tmp_path / "a.fmu") as a, zipfile.ZipFile(tmp_path / "b.fmu") as b:
        so = [n for n in a.namelist() if n.endswith(".so")]
        assert so and all(a.read(n) == b.read(n) for n in so)
