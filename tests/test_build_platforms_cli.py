"""Choosing the platforms an FMU carries binaries for: `gyrowheel build --platforms`, the scene's
[build] platforms and gyrowheel.build(platforms=...), and what each says when it cannot
(docs/scenes.md, docs/fmi.md "Platforms"): an unknown platform in one line listing the valid
ones, zig missing as the pip command of gyrowheel[platforms], a failed cross build naming the
platform and the compiler's first error with no FMU written."""
from __future__ import annotations

import sys
import types
from pathlib import Path

import pytest

import gyrowheel
from gyrowheel.cli import main
from gyrowheel.errors import ArgumentError, ArgumentTypeError, MissingExtraError
from gyrowheel.fmu_build import builder
from gyrowheel.fmu_build.compiler import CompileError
from gyrowheel.fmu_build.platforms import ALL, PLATFORMS, host_platform
from gyrowheel.fmu_build.scene import Scene, SceneError, check_scene, parse_scene, scene_toml
from gyrowheel.model.system import System

ROOT = Path(__file__).resolve().parent.parent
PAPER = ROOT / "examples" / "scenes" / "paper_earth.toml"
VALID = "valid: all, host, " + ", ".join(PLATFORMS)
SMALL = '[model]\nname = "small"\n\n[effects.gravity]\n'  # the smallest scene: a wheel under gravity


def _cli(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_an_unknown_platform_is_refused_in_one_line_listing_the_valid_ones(tmp_path, capsys):
    """Refused before anything is built or written: exit 2 on the command line, ArgumentError
    naming `platforms` in the API, a SceneError naming [build] platforms in a scene."""
    out = tmp_path / "w.fmu"
    code, stdout, err = _cli(capsys, "build", PAPER, "-o", out, "--platforms", "x86_64-linux,arm64-mac")
    assert (code, stdout) == (2, "")
    assert err == f"gyrowheel: error: --platforms: unknown platform 'arm64-mac'; {VALID}\n"
    for value in ("", "linux64", ["x86_64-linux", "win64"]):
        with pytest.raises(ArgumentError) as exc:
            gyrowheel.build(PAPER, out, platforms=value)
        assert exc.value.argument == "platforms" and str(exc.value).endswith(VALID), str(exc.value)
        assert "\n" not in str(exc.value)
    with pytest.raises(ArgumentTypeError) as exc:
        gyrowheel.build(PAPER, out, platforms=64)
    assert exc.value.argument == "platforms" and str(exc.value).startswith("platforms: expected platform names")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("value, problem", [
    ('"win64"', f"unknown platform 'win64'; {VALID}"),
    ('["x86_64-linux", "darwin"]', f"unknown platform 'darwin'; {VALID}"),
    ('"x86_64-linux,aarch64"', f"unknown platform 'aarch64'; {VALID}"),
    ('["all", ""]', f"an empty platform name in ['all', '']; {VALID}"),
    ("[]", 'must be "all", "host" or a list of platform names, got []'),
    ("3", 'must be "all", "host" or a list of platform names, got 3'),
])
def test_the_scene_key_is_checked_like_every_other(value, problem):
    with pytest.raises(SceneError) as exc:
        parse_scene(SMALL + f"\n[build]\nplatforms = {value}\n", "s.toml")
    assert str(exc.value) == f"s.toml: [build] platforms: {problem}"
    with pytest.raises(SceneError, match=r"^s\.toml: \[build\] target: unknown key; valid: arrays, fmi, platforms, taylor$"):
        parse_scene(SMALL + '\n[build]\ntarget = "all"\n', "s.toml")
    with pytest.raises(SceneError, match=r"^scene 'wheel': \[build\] platforms: unknown platform 'win64'"):
        check_scene(Scene(platforms="win64"))


def test_the_scene_key_reads_and_writes_back():
    scene = parse_scene(SMALL + '\n[build]\nplatforms = ["aarch64-linux", "x86_64-windows"]\n', "s.toml")
    assert scene.platforms == ["aarch64-linux", "x86_64-windows"]
    assert parse_scene(SMALL, "s.toml").platforms is None  # no [build]: the host only
    assert parse_scene(SMALL + '\n[build]\nplatforms = "all"\n', "s.toml").platforms == "all"
    assert parse_scene(SMALL + '\n[build]\nplatforms = "host,aarch64-linux"\n', "s.toml").platforms == \
        "host,aarch64-linux"
    again = parse_scene(scene_toml(check_scene(scene)), "s.toml")
    assert again.platforms == scene.platforms and "[build]" not in scene_toml(check_scene(Scene()))


@pytest.fixture
def asked(monkeypatch):
    """The platforms build_fmu hands to build_spec_fmu, the model and the build left out."""
    seen = []

    def spec_fmu(spec, output, *args, platforms=None, **kwargs):
        seen.append(platforms)
        return builder.BuildResult(fmu=Path(output), spec=spec, sources=None, identifier="small")
    monkeypatch.setattr(builder, "_spec", lambda scene: types.SimpleNamespace(effects=["gravity"]))
    monkeypatch.setattr(builder, "build_spec_fmu", spec_fmu)
    return seen


def test_the_flag_overrides_the_scene_key(tmp_path, capsys, asked):
    """No key and no flag: the host only, as an FMU was always built; the key when there is no
    flag; the flag over the key; `all` the five of ALL."""
    plain, keyed = tmp_path / "plain.toml", tmp_path / "keyed.toml"
    plain.write_text(SMALL)
    keyed.write_text(SMALL + '\n[build]\nplatforms = ["x86_64-windows", "aarch64-linux"]\n')
    host = host_platform().name
    for argv in ([plain], [keyed], [keyed, "--platforms", "host"], [plain, "--platforms", "all"],
                 [plain, "--platforms", "aarch64-darwin,x86_64-darwin,all"]):
        code, _, err = _cli(capsys, "build", *argv, "-o", tmp_path / "s.fmu")
        assert code == 0, err
    gyrowheel.build(keyed, tmp_path / "s.fmu", platforms=["x86-windows"])
    assert asked == [(host,), ("aarch64-linux", "x86_64-windows"), (host,), ALL, ALL, ("x86-windows",)]


def test_without_zig_the_pip_command_of_the_extra(tmp_path, capsys, monkeypatch):
    """ziglang hidden (sys.modules entry None: `import ziglang` fails): the flag, the scene key
    and the API each name gyrowheel[platforms]; the host alone needs no zig."""
    monkeypatch.setitem(sys.modules, "ziglang", None)
    pip = "needs the optional part 'platforms': pip install \"gyrowheel[platforms]\""
    keyed = tmp_path / "keyed.toml"
    keyed.write_text(SMALL + '\n[build]\nplatforms = "all"\n')
    code, stdout, err = _cli(capsys, "build", PAPER, "-o", tmp_path / "w.fmu", "--platforms", "all")
    assert (code, stdout, err) == (2, "", f"gyrowheel: error: `gyrowheel build --platforms` {pip}\n")
    code, stdout, err = _cli(capsys, "build", keyed, "-o", tmp_path / "w.fmu")
    assert (code, stdout, err) == (2, "", f"gyrowheel: error: `gyrowheel build ([build] platforms)` {pip}\n")
    with pytest.raises(MissingExtraError) as exc:
        gyrowheel.build(PAPER, tmp_path / "w.fmu", platforms=["x86_64-linux", "aarch64-linux"])
    assert str(exc.value) == f"`gyrowheel.build(platforms=...)` {pip}" and exc.value.extra == "platforms"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keyed.toml"]  # refused before anything was built
    if host_platform().name in PLATFORMS:
        assert builder._wanted_platforms("host") == (host_platform().name,)


@pytest.fixture
def no_aarch64(monkeypatch):
    """The FMU's source made one that does not compile for aarch64 (an #error there only)."""
    real = builder.write_binaries

    def write_binaries(source, *args, **kwargs):
        source.write_text(source.read_text() + '\n#if defined(__aarch64__)\n#error "no aarch64 build here"\n#endif\n')
        return real(source, *args, **kwargs)
    monkeypatch.setattr(builder, "write_binaries", write_binaries)


def _small_spec():
    s = System("decay", "a decaying state")
    x = s.state("x", 1.0, "1", "exp(-t)")
    s.der(x, -x)
    return s.spec()


def test_a_failed_cross_build_names_the_platform_and_leaves_no_fmu(tmp_path, capsys, no_aarch64):
    """The command: exit 1, the platform and the compiler's first error on the first line; the
    FMU already at the output left as it was, nothing else written. The API: CompileError, no
    FMU and no partial file. (Two builds, about 10 s: the wheel's code generation and compiles.)"""
    out = tmp_path / "paper.fmu"
    out.write_bytes(b"the FMU of an earlier build")
    code, stdout, err = _cli(capsys, "build", PAPER, "-o", out, "--platforms", "x86_64-linux,aarch64-linux")
    first = err.splitlines()[0]
    assert code == 1 and stdout == "", err
    assert first.startswith("gyrowheel: error: compiling the FMU failed: cross build for aarch64-linux failed "
                            "(zig cc -target aarch64-linux-gnu.2.17): "), first
    assert 'error: "no aarch64 build here"' in first, first
    assert out.read_bytes() == b"the FMU of an earlier build"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["paper.fmu"]
    fresh = tmp_path / "decay.fmu"
    with pytest.raises(CompileError, match=r"^cross build for aarch64-linux failed .*error: \"no aarch64 build here\""):
        builder.build_spec_fmu(_small_spec(), fresh, platforms="x86_64-linux,aarch64-linux")
    assert not fresh.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["paper.fmu"]


def test_the_build_line_names_the_platforms(tmp_path, capsys):
    """`gyrowheel build` says which platforms the FMU carries (a scene's [build] platforms
    chooses them silently otherwise); the BuildResult holds them."""
    code, out, err = _cli(capsys, "build", PAPER, "-o", tmp_path / "e.fmu")
    assert (code, err) == (0, "")
    assert out == f"built {tmp_path / 'e.fmu'} (model paper_earth, effects: gravity; platforms: {host_platform().name})\n"
    assert gyrowheel.build(PAPER, tmp_path / "f.fmu").platforms == (host_platform().name,)


def test_an_empty_list_names_no_platform(tmp_path):
    with pytest.raises(ArgumentError, match=r"^platforms: no platform named in \[\]; valid: all, host, "):
        gyrowheel.build(PAPER, tmp_path / "e.fmu", platforms=[])


def test_an_unwritable_zig_cache_is_refused_not_waited_on(tmp_path, monkeypatch):
    """zig 0.17 spins without a word when its cache cannot be written: the build refuses first,
    naming the directory and ZIG_GLOBAL_CACHE_DIR, and writes nothing."""
    monkeypatch.setenv("ZIG_GLOBAL_CACHE_DIR", "/proc/no-such-cache")
    with pytest.raises(CompileError, match=r"^zig's cache directory /proc/no-such-cache .*cannot be written: "
                                           r"set ZIG_GLOBAL_CACHE_DIR to a writable directory$"):
        gyrowheel.build(PAPER, tmp_path / "e.fmu", platforms="aarch64-linux")
    assert list(tmp_path.iterdir()) == []


def test_a_compiler_ended_by_a_signal_is_named(tmp_path, monkeypatch):
    """A compiler killed (no output, a negative return code) is reported as such, not as
    '(no output)'."""
    import subprocess

    from gyrowheel.fmu_build import platforms

    monkeypatch.setattr(platforms.subprocess, "run",
                        lambda cmd, **kw: subprocess.CompletedProcess(cmd, -9, "", ""))
    source = tmp_path / "gw_fmu.c"
    source.write_text("")
    with pytest.raises(CompileError) as exc:
        platforms.cross_compile(PLATFORMS["aarch64-linux"], source, [tmp_path], tmp_path / "m.so", [])
    assert str(exc.value).splitlines()[0] == ("cross build for aarch64-linux failed (zig cc -target "
                                              "aarch64-linux-gnu.2.17): the compiler was ended by signal 9")


def test_an_interrupted_build_starts_no_queued_target(tmp_path, monkeypatch):
    """Ctrl-C while the cross builds run: the targets still queued never start (each would make
    a scratch directory while the process ends), the running ones are waited for, and the
    KeyboardInterrupt reaches the caller."""
    import signal
    import threading

    from gyrowheel.fmu_build import platforms

    started, release = [], threading.Event()
    main_thread = threading.main_thread().ident

    def compile_one(target, *args):
        started.append(target.name)
        if len(started) == 2:  # both workers busy, three targets queued: the terminal's SIGINT
            signal.pthread_kill(main_thread, signal.SIGINT)
        release.wait(5)

    monkeypatch.setattr(platforms, "cross_compile", compile_one)
    monkeypatch.setattr(platforms.os, "cpu_count", lambda: 2)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.5, release.set)  # the running compilers end (as zig does on SIGINT)
    try:
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            platforms.cross_compile_all([PLATFORMS[n] for n in ALL], tmp_path / "s.c", [],
                                        [tmp_path / n for n in ALL], [])
    finally:
        signal.signal(signal.SIGINT, previous)
        timer.cancel()
        release.set()
    assert started == list(ALL[:2])
