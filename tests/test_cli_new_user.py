"""What a new user tries first, as a table: the input, the exit status, one line on stderr, and
nothing touched (README: "errors are one line, never a traceback"; docs/architecture.md,
"Errors"; gyrowheel/output_files.py: an output is complete and right, or not touched).

Each row runs `python -m gyrowheel ...` as a user would, with TMPDIR set to a fresh directory
that must be empty afterwards (no unpacked FMU, no build directory left behind), and checks
that every file the row names is as it was (bytes and kind: a FIFO stays a FIFO, a link to
/dev/full stays a link) or still absent.
"""
from __future__ import annotations

import csv
import math
import os
import re
import stat
import subprocess
import sys
import zipfile
from dataclasses import dataclass
from pathlib import Path

import pytest

from conftest import ROOT, SCENES
from gyrowheel.fmu_build.scene import DESCRIPTION_MAX

EARTH = SCENES / "paper_earth.toml"


@dataclass
class Case:
    argv: tuple[str, ...]  # {name} is a file of the `files` fixture
    status: int
    line: str  # regex the one stderr line must match (after 'gyrowheel: error: ')
    untouched: tuple[str, ...] = ()  # files (of `files`) that must be as they were
    absent: tuple[str, ...] = ()  # files that must not be made


# The rows: every one of these printed a traceback, exited 1 naming a gyrowheel defect, wrote
# or replaced a file it should not have, ran out of memory, or said something untrue.
CASES = {
    # -- simulate given anything but a valid FMU ------------------------------------------------
    "scene-file": Case(("simulate", "{scene}"), 2, r"scene\.toml: a scene, not an FMU; build its FMU first",
                       absent=("scene.csv",)),
    "truncated-zip": Case(("simulate", "{truncated}"), 2, r"truncated\.fmu: not a readable FMU: not a zip archive"),
    "not-a-zip": Case(("simulate", "{nonzip}"), 2, r"nonzip\.fmu: not a readable FMU: not a zip archive"),
    "empty-file": Case(("simulate", "{empty}"), 2, r"empty\.fmu: not a readable FMU: not a zip archive"),
    "no-model-description": Case(("simulate", "{nomd}"), 2,
                                 r"nomd\.fmu: not a readable FMU: no modelDescription\.xml"),
    "bad-model-description": Case(("simulate", "{badmd}"), 2,
                                  r"badmd\.fmu: not a readable FMU: modelDescription\.xml is not XML"),
    # the binary's loader (dlopen) gives the reason; before: fmpy's traceback, the unpacked FMU left in TMPDIR
    "bad-binary": Case(("simulate", "{badbin}"), 2, r"badbin\.fmu: its binary binaries/linux64/paper_earth\.so "
                       r"cannot be loaded: .*(file too short|invalid ELF header)", absent=("badbin.csv",)),
    "missing-binary": Case(("simulate", "{nobin}"), 2, r"nobin\.fmu: no binary for linux64"),
    # a start value the FMU refuses at initialisation: bad input, its reason, exit 2, nothing left behind
    "fmu-refuses": Case(("simulate", "{fmu}", "--set", "M=-1", "-o", "{out_csv}"), 2,
                        r"--set: the FMU refused the start values: M \(mass\) must be > 0$", absent=("out.csv",)),
    # -- scenes the TOML reader cannot take ------------------------------------------------------
    "deep-toml-build": Case(("build", "{deep}", "-o", "{out_fmu}"), 2,
                            r"deep\.toml: arrays or inline tables nested too deep", absent=("out.fmu",)),
    "deep-toml-export": Case(("export-c", "{deep}", "-o", "{out_dir}"), 2,
                             r"deep\.toml: arrays or inline tables nested too deep", absent=("out_c",)),
    "long-description": Case(("build", "{long}", "-o", "{out_fmu}"), 2,
                             rf"long\.toml: \[model\] description: has {DESCRIPTION_MAX + 1} characters, more than "
                             rf"the {DESCRIPTION_MAX}", absent=("out.fmu",)),
    # one rule for the model name, at the scene reader: build and export-c say the same
    "omega-build": Case(("build", "{omega}", "-o", "{out_fmu}"), 2,
                        r"omega\.toml: \[model\] name: must be a C identifier \(ASCII letters, digits, _\), "
                        r"got 'Ωwheel'", absent=("out.fmu",)),
    "omega-export": Case(("export-c", "{omega}", "-o", "{out_dir}"), 2,
                         r"omega\.toml: \[model\] name: must be a C identifier \(ASCII letters, digits, _\), "
                         r"got 'Ωwheel'", absent=("out_c",)),
    # -- outputs: whole and right, or not touched ------------------------------------------------
    "plot-format": Case(("simulate", "{fmu}", "-o", "{out_csv}", "--plot", "{txt}"), 2,
                        r"--plot .*x\.txt: '\.txt' is not a figure format matplotlib writes; give a name ending in "
                        r"one of .*\.pdf.*\.png", absent=("out.csv", "x.txt")),
    "plot-device": Case(("simulate", "{fmu}", "-o", "{out_csv}", "--plot", "{full_png}"), 2,
                        r"--plot .*full\.png: exists and is not a regular file", untouched=("full_png",),
                        absent=("out.csv",)),
    "csv-device": Case(("simulate", "{fmu}", "-o", "{full_csv}"), 2,
                       r"-o .*full\.csv: exists and is not a regular file", untouched=("full_csv",)),
    "build-device": Case(("build", str(EARTH), "-o", "{full_fmu}"), 2,
                         r"-o .*full\.fmu: exists and is not a regular file", untouched=("full_fmu",)),
    "build-fifo": Case(("build", str(EARTH), "-o", "{fifo}"), 2,
                       r"-o .*fifo\.fmu: exists and is not a regular file", untouched=("fifo",)),
    "export-over-file": Case(("export-c", str(EARTH), "-o", "{scene}"), 2,
                             r"-o .*scene\.toml: exists and is not a directory", untouched=("scene",)),
    # -- a missing output directory: refused by every verb, never made (before: simulate, system
    # run, animate and build made it, even /nonexistent_dir at the root; sweep refused)
    "simulate-no-dir": Case(("simulate", "{fmu}", "--stop-time", "0.1", "-o", "nodir/x.csv"), 2,
                            r"-o nodir/x\.csv: directory nodir does not exist", absent=("nodir",)),
    "simulate-plot-no-dir": Case(("simulate", "{fmu}", "--stop-time", "0.1", "--plot", "nodir/x.png"), 2,
                                 r"--plot nodir/x\.png: directory nodir does not exist", absent=("nodir",)),
    "system-no-dir": Case(("system", "run", "{ssp}", "--step", "0.01", "--stop-time", "0.1", "-o", "nodir/x.csv"), 2,
                          r"-o nodir/x\.csv: directory nodir does not exist", absent=("nodir",)),
    "animate-no-dir": Case(("animate", "{run_csv}", "--fmu", "{fmu}", "-o", "nodir/a.html"), 2,
                           r"-o nodir/a\.html: directory nodir does not exist", absent=("nodir",)),
    "build-no-dir": Case(("build", str(EARTH), "-o", "nodir/e.fmu"), 2,
                         r"-o nodir/e\.fmu: directory nodir does not exist", absent=("nodir",)),
    "build-keep-no-parent": Case(("build", str(EARTH), "-o", "e.fmu", "--keep-build", "nodir/src"), 2,
                                 r"--keep-build nodir/src: cannot write: directory nodir does not exist",
                                 absent=("nodir", "e.fmu")),
    "sweep-no-dir": Case(("sweep", "{fmu}", "--grid", "M=2", "--workers", "0", "-o", "nodir/t.csv"), 2,
                         r"-o .*nodir/t\.csv: directory .*nodir does not exist", absent=("nodir",)),
    # -- sweep --plot that cannot be written: refused before the run (before: the sweep ran, wrote
    # its table, then failed: "File or stream is not seekable.", "OSError: [Errno 28] ...")
    "sweep-plot-directory": Case(("sweep", "{fmu}", "--grid", "M=2", "--workers", "0", "-o", "{out_csv}",
                                  "--plot", "{png_dir}"), 2, r"--plot .*p\.png: is a directory; give a file name",
                                 untouched=("png_dir",), absent=("out.csv",)),
    "sweep-plot-fifo": Case(("sweep", "{fmu}", "--grid", "M=2", "--workers", "0", "-o", "{out_csv}",
                             "--plot", "{fifo_png}"), 2, r"--plot .*fifo\.png: exists and is not a regular file",
                            untouched=("fifo_png",), absent=("out.csv",)),
    "sweep-plot-device": Case(("sweep", "{fmu}", "--grid", "M=2", "--workers", "0", "-o", "{out_csv}",
                               "--plot", "{full_png}"), 2, r"--plot .*full\.png: exists and is not a regular file",
                              untouched=("full_png",), absent=("out.csv",)),
    # -- the one memory rule (gyrowheel.arguments.check_memory), before the run ------------------
    "stop-time-1e9": Case(("simulate", "{fmu}", "--stop-time", "1e9", "-o", "{out_csv}"), 2,
                          r"--stop-time 1e\+09 s with --output-interval 0\.01 s: 100000000002 communication points "
                          r"of 14 columns would take [\d.e+]+ GiB, more than half of this machine's",
                          absent=("out.csv",)),
    "scene-stop-time-1e300": Case(("simulate", "{stop1e300}", "-o", "{out_csv}"), 2,
                                  r"--stop-time 1e\+300 s with --output-interval 0\.01 s: 1e\+302 communication points",
                                  absent=("out.csv",)),
    "scene-interval-1e-300": Case(("simulate", "{step1e300}", "-o", "{out_csv}"), 2,
                                  r"--stop-time 20 s with --output-interval 1e-300 s: 2e\+301 communication points",
                                  absent=("out.csv",)),
    # -- smaller ---------------------------------------------------------------------------------
    "set-nan": Case(("simulate", "{fmu}", "--set", "M=nan", "-o", "{out_csv}"), 2,
                    r"--set: value 'nan' for 'M' is not finite", absent=("out.csv",)),
    "set-inf-degrees": Case(("simulate", "{fmu}", "--set", "beta_deg=inf", "-o", "{out_csv}"), 2,
                            r"--set: value 'inf' for 'beta_deg' is not finite", absent=("out.csv",)),
    "set-angle-twice": Case(("simulate", "{fmu}", "--set", "beta=1", "--set", "beta_deg=80", "-o", "{out_csv}"), 2,
                            r"--set: 'beta' given twice \(as beta and beta_deg\)", absent=("out.csv",)),
    "solver-taylor": Case(("simulate", "{plain}", "--set", "solver=taylor", "-o", "{out_csv}"), 2,
                          r"--set: value 'taylor' for 'solver' is not a valid Enumeration; valid: euler, rk4, dopri5, "
                          r"rosenbrock, dop853, auto; taylor needs an FMU built with the Taylor kernel",
                          absent=("out.csv",)),
}


def _rewrite(src: Path, dest: Path, drop=(), replace=None) -> Path:
    """A copy of the FMU `src` without the members `drop`, with members replaced ({name: bytes})."""
    replace = replace or {}
    with zipfile.ZipFile(src) as zi, zipfile.ZipFile(dest, "w") as zo:
        for item in zi.infolist():
            if item.filename not in drop:
                zo.writestr(item, replace.get(item.filename, zi.read(item.filename)))
    return dest


def _experiment(src: Path, dest: Path, **attributes) -> Path:
    """A copy of the FMU with its DefaultExperiment's attributes changed (what the scene's
    [experiment] gives it; the binary does not read them)."""
    with zipfile.ZipFile(src) as zf:
        xml = zf.read("modelDescription.xml").decode()
    for key, value in attributes.items():
        xml, n = re.subn(rf'(<DefaultExperiment[^>]*\b{key}=")[^"]*"', rf'\g<1>{value}"', xml)
        assert n == 1, key
    return _rewrite(src, dest, replace={"modelDescription.xml": xml.encode()})


@pytest.fixture(scope="module")
def files(earth_fmu, example_build, tmp_path_factory) -> dict[str, Path]:
    """The inputs of the rows, made once: corrupt FMUs from the paper's earth FMU, scenes, outputs."""
    d = tmp_path_factory.mktemp("new_user")
    fmu = d / "earth.fmu"
    fmu.write_bytes(Path(earth_fmu).read_bytes())
    data = fmu.read_bytes()
    out = {"fmu": fmu}
    for name, content in (("truncated", data[:len(data) // 2]), ("nonzip", b"this is not an FMU\n" * 8),
                          ("empty", b"")):
        out[name] = d / f"{name}.fmu"
        out[name].write_bytes(content)
    out["plain"] = example_build("paper_earth", taylor=False).fmu  # the paper FMU without the Taylor kernel
    out["nomd"] = _rewrite(fmu, d / "nomd.fmu", drop=("modelDescription.xml",))
    out["badmd"] = _rewrite(fmu, d / "badmd.fmu", replace={"modelDescription.xml": b"<fmiModelDescription fmiVersion"})
    out["badbin"] = _rewrite(fmu, d / "badbin.fmu", replace={"binaries/linux64/paper_earth.so": b"not an ELF file"})
    out["nobin"] = _rewrite(fmu, d / "nobin.fmu", drop=("binaries/linux64/paper_earth.so",))
    out["stop1e300"] = _experiment(fmu, d / "stop1e300.fmu", stopTime="1e300")
    out["step1e300"] = _experiment(fmu, d / "step1e300.fmu", stepSize="1e-300")
    scenes = {"deep": "[outputs]\nkeep = " + "[" * 5000 + "]" * 5000 + "\n",
              "long": f'[model]\ndescription = "{"a" * (DESCRIPTION_MAX + 1)}"\n[effects.gravity]\n',
              "omega": '[model]\nname = "Ωwheel"\n[effects.gravity]\n'}
    for name, text in scenes.items():
        out[name] = d / f"{name}.toml"
        out[name].write_text(text)
    from gyrowheel.cosim.system import Component, SystemDescription
    from gyrowheel.cosim.ssp import write_ssp
    out["ssp"] = write_ssp(SystemDescription("one", [Component("wheel", fmu, {})], [], 0.0, 1.0), d / "one.ssp")
    out["run_csv"] = d / "run.csv"
    subprocess.run([sys.executable, "-m", "gyrowheel", "simulate", str(fmu), "--stop-time", "0.1", "-o",
                    str(out["run_csv"])], check=True, capture_output=True)
    return out


def _outputs(tmp_path: Path) -> dict[str, Path]:
    """A row's own outputs in its working directory: names to write, a copy of a scene, links
    to a device (what is written through one is the device) and a FIFO."""
    out = {name: tmp_path / file for name, file in (("out_csv", "out.csv"), ("out_fmu", "out.fmu"),
                                                     ("out_dir", "out_c"), ("txt", "x.txt"))}
    out["scene"] = tmp_path / "scene.toml"
    out["scene"].write_text(EARTH.read_text())
    for name in ("full_png", "full_csv", "full_fmu"):
        out[name] = tmp_path / name.replace("_", ".")
        out[name].symlink_to("/dev/full" if os.path.exists("/dev/full") else "/dev/null")
    out["fifo"] = tmp_path / "fifo.fmu"
    os.mkfifo(out["fifo"])
    out["fifo_png"] = tmp_path / "fifo.png"
    os.mkfifo(out["fifo_png"])
    out["png_dir"] = tmp_path / "p.png"
    out["png_dir"].mkdir()
    return out


def _state(path: Path):
    """What a file is: its kind (lstat: a link stays a link), its target or bytes."""
    if not os.path.lexists(path):
        return None
    mode = os.lstat(path).st_mode
    if stat.S_ISLNK(mode):
        return "link", os.readlink(path), stat.S_IFMT(os.stat(path).st_mode)
    if stat.S_ISREG(mode):
        return "file", path.read_bytes()
    if stat.S_ISDIR(mode):
        return "dir", sorted(p.name for p in path.iterdir())
    return "other", stat.S_IFMT(mode)


def run_cli(argv, tmp_path: Path) -> tuple[subprocess.CompletedProcess, Path]:
    """`python -m gyrowheel ARGV` in tmp_path, with its own empty TMPDIR."""
    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    env = {**os.environ, "TMPDIR": str(tmpdir)}
    r = subprocess.run([sys.executable, "-m", "gyrowheel", *argv], capture_output=True, text=True, cwd=tmp_path,
                       env=env, timeout=300)
    return r, tmpdir


@pytest.mark.parametrize("name", CASES)
def test_a_new_users_mistake_is_one_line_and_touches_nothing(name, files, tmp_path):
    case = CASES[name]
    paths = {**files, **_outputs(tmp_path)}
    argv = [a.format(**paths) for a in case.argv]
    watched = {n: paths[n] for n in case.untouched}
    before = {n: _state(p) for n, p in watched.items()}
    absent = [tmp_path / a for a in case.absent]
    assert not any(os.path.lexists(p) for p in absent)
    entries = sorted(os.listdir(tmp_path))
    r, tmpdir = run_cli(argv, tmp_path)
    assert r.returncode == case.status, r.stderr
    assert r.stdout == ""
    lines = r.stderr.splitlines()
    assert len(lines) == 1, r.stderr  # one line: never a traceback
    assert re.fullmatch(rf"gyrowheel: error: .*{case.line}.*", lines[0]), lines[0]
    assert "gyrowheel defect" not in lines[0]
    assert {n: _state(p) for n, p in watched.items()} == before
    assert [p for p in absent if os.path.lexists(p)] == []
    assert sorted(os.listdir(tmpdir)) == []  # nothing unpacked or built is left behind
    assert sorted(os.listdir(tmp_path)) == sorted(entries + ["tmp"])  # no new file (a part, an output)


def test_set_takes_angles_in_degrees_as_scenes_and_sweeps_do(files, tmp_path):
    """--set beta_deg=80 is beta = 80 pi / 180 rad (the start row of the CSV)."""
    r, tmpdir = run_cli(["simulate", str(files["fmu"]), "--stop-time", "0.02", "--set", "beta_deg=80",
                         "-o", "run.csv"], tmp_path)
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader((tmp_path / "run.csv").open()))
    assert float(rows[0]["beta"]) == 80 * math.pi / 180
    assert os.listdir(tmpdir) == []


def test_the_description_limit_is_one_fmpy_reads(files, tmp_path):
    """A description at the scene reader's limit, each character the longest XML escape (&quot;,
    6 bytes), is still read by fmpy (libxml2 refuses a start tag of about 10,000,000 bytes; a
    10 MB description was); one of 10 MB is not. The reader's limit is therefore safe."""
    from fmpy import read_model_description

    with zipfile.ZipFile(files["fmu"]) as zf:
        xml = zf.read("modelDescription.xml").decode()

    def readable(description_xml: str) -> bool:
        text = re.sub(r'(<fmiModelDescription[^>]*?\bdescription=")[^"]*"',
                      lambda m: m.group(1) + description_xml + '"', xml, count=1)
        fmu = _rewrite(files["fmu"], tmp_path / "d.fmu", replace={"modelDescription.xml": text.encode()})
        try:
            read_model_description(str(fmu))
            return True
        except Exception:
            return False
    assert readable("&quot;" * DESCRIPTION_MAX)
    assert not readable("a" * 10 * 2**20)


def test_a_failed_export_leaves_the_previous_one_as_it_was(earth, tmp_path, monkeypatch):
    """export-c over a previous export (with a file of the user's in it) that fails at its last
    step, the strict compile, leaves the directory exactly as it was and nothing beside it."""
    import shutil

    from gyrowheel.api import export_c
    from gyrowheel.fmu_build import export_c as export_module
    from gyrowheel.fmu_build.compiler import CompileError

    out = tmp_path / "paper_earth"
    shutil.copytree(earth, out, symlinks=True)
    (out / "notes.txt").write_text("mine\n")
    (out / "src" / "gw_core.c").write_text("an old export's file\n")
    before = {p.relative_to(out): _state(p) for p in sorted(out.rglob("*"))}

    def fail(unity):
        raise CompileError("cc: refused")
    monkeypatch.setattr(export_module, "compile_check", fail)
    monkeypatch.setattr(export_module.c_names, "probe", lambda name, cc: None)
    with pytest.raises(CompileError):
        export_c(EARTH, out)
    assert {p.relative_to(out): _state(p) for p in sorted(out.rglob("*"))} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["paper_earth"]


def test_info_names_the_solver_and_keeps_its_columns(files, tmp_path):
    """info shows an enumeration's start by its item's name (solver auto = 7, FMI 2.0.4 section
    2.2.3: the item's value) and every column of the variable table starts at one offset."""
    r, _ = run_cli(["info", str(files["fmu"])], tmp_path)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    rows = lines[next(i for i, line in enumerate(lines) if line.startswith("name ")):]
    rows = [row for row in rows if not row.startswith("items of ")]  # the Enumerations' items, after the table
    causality = rows[0].index("causality")
    assert all(row[causality - 2:causality] == "  " and row[causality] != " " for row in rows[1:])
    assert re.match(r"solver +parameter +fixed +auto \(7\) ", next(row for row in rows if row.startswith("solver ")))
