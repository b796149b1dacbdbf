"""Run a system's .ssp in OMSimulator's command line and in gyrowheel's master; compare them.

    python benchmarks/omsimulator_run.py SYSTEM.ssp --omsimulator PATH/bin/OMSimulator
        [--stop-time 5] [--tolerance 1e-4] [--without-accuracy] [--out DIR]

OMSimulator (3.0, not on PyPI for offline use: its package downloads binaries when installed) is
built from OpenModelica/OMSimulator's sources with CMake; its command line runs the file as it is:

    OMSimulator --stopTime=T --tolerance=TOL --resultFile=oms.csv SYSTEM.ssp

(the system's type and its communication step come from the .ssd's org.openmodelica annotation,
which gyrowheel.cosim.ssp.write_ssp writes; OMSimulator 3.0 does not apply --stepSize to an
.ssp, and gyrowheel's master runs at that annotation's step too). `--tolerance` is the tolerance OMSimulator passes to
every FMU's fmi2SetupExperiment (its default 1e-4); the file's rel_tol bindings take precedence
(docs/system.md). `--without-accuracy` runs a copy of the file with those bindings removed, to
show what they are for. gyrowheel's master runs the same file at the same step. Printed: for
every output both results have, the largest difference over the communication points both
recorded and the difference at the last one, the worst first (OMSimulator's CSV carries 12
significant digits); exit status 1 if OMSimulator fails.

Not part of `make test` (it needs the OMSimulator binary). docs/system.md and docs/fmi.md say
what was run and what it gave.
"""
from __future__ import annotations

import argparse
import csv
import re
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from gyrowheel.cosim.master import run
from gyrowheel.cosim.ssp import read_ssp


def without_accuracy(ssp: Path, out: Path) -> Path:
    """A copy of the .ssp whose bindings of rel_tol are removed (a binding left empty too)."""
    with zipfile.ZipFile(ssp) as zf, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as new:
        for name in zf.namelist():
            data = zf.read(name)
            if name == "SystemStructure.ssd":
                data = re.sub(rb'<ssv:Parameter name="rel_tol">\s*<ssv:Real [^>]*/>\s*</ssv:Parameter>', b"", data)
                data = re.sub(rb"<ssd:ParameterBindings>(?:(?!</ssd:ParameterBindings>).)*?<ssv:Parameters>\s*"
                              rb"</ssv:Parameters>.*?</ssd:ParameterBindings>", b"", data, flags=re.S)  # left empty
            new.writestr(name, data)
    return out


def annotated_step(ssp: Path) -> float:
    """The communication step of the .ssd's OMSimulator annotation (oms:FixedStepMaster stepSize)."""
    with zipfile.ZipFile(ssp) as zf:
        found = re.search(rb'<oms:FixedStepMaster [^>]*stepSize="([^"]+)"', zf.read("SystemStructure.ssd"))
    if found is None:
        sys.exit(f"{ssp}: no oms:FixedStepMaster annotation (OMSimulator's command line cannot run it); "
                 "write it with gyrowheel.cosim.ssp.write_ssp")
    return float(found.group(1))


def omsimulator(binary: str, ssp: Path, stop: float, tolerance: float, work: Path) -> dict:
    """OMSimulator's CSV result as {<component>.<variable>: array}, 'time' included."""
    result = work / "oms.csv"
    cmd = [binary, f"--stopTime={stop!r}", f"--tolerance={tolerance!r}",
           f"--resultFile={result}", str(ssp.resolve())]
    print("$", " ".join(cmd))
    r = subprocess.run(cmd, cwd=work, capture_output=True, text=True)
    if r.returncode != 0 or not result.is_file():
        sys.exit(f"OMSimulator failed (exit {r.returncode}):\n{r.stdout[-2000:]}\n{r.stderr[-2000:]}")
    with open(result, newline="") as f:
        rows = list(csv.reader(f))
    head = rows[0]
    data = np.array([[float(x) for x in row] for row in rows[1:] if row], dtype=float)
    # columns are <model>.<root system>.<component>.<variable>
    out = {"time": data[:, 0]}
    for j, name in enumerate(head[1:], 1):
        parts = name.split(".")
        if len(parts) >= 4:
            out[".".join(parts[2:])] = data[:, j]
    return out


def compare(ours: np.ndarray, theirs: dict) -> list[tuple[str, float, float]]:
    """(column, largest |difference|, |difference| at the last point) at the times both recorded
    (OMSimulator may add rows at events)."""
    t = theirs["time"]
    index = np.searchsorted(t, ours["time"] - 1e-9)
    index = np.minimum(index, len(t) - 1)
    keep = np.abs(t[index] - ours["time"]) < 1e-9
    # OMSimulator writes each communication point twice (before and after its exchange): the last
    # row is the one gyrowheel's master records
    last = np.minimum(index + (np.r_[t[1:] == t[:-1], False][index]).astype(int), len(t) - 1)
    worst = []
    for name in ours.dtype.names[1:]:
        if name in theirs:
            diff = np.abs(ours[name][keep] - theirs[name][last[keep]])
            worst.append((name, float(np.max(diff)), float(diff[-1])))
    print(f"compared at {keep.sum()} of {len(ours)} communication points")
    return sorted(worst, key=lambda w: -w[1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ssp", type=Path)
    ap.add_argument("--omsimulator", required=True, help="the OMSimulator command line program")
    ap.add_argument("--stop-time", type=float, default=5.0)
    ap.add_argument("--tolerance", type=float, default=1e-4, help="OMSimulator's --tolerance (its default 1e-4)")
    ap.add_argument("--without-accuracy", action="store_true", help="remove the file's rel_tol bindings first")
    ap.add_argument("--out", type=Path, help="keep OMSimulator's result and log here")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="gyrowheel-oms-") as tmp:
        work = args.out or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        ssp = without_accuracy(args.ssp, work / "without_accuracy.ssp") if args.without_accuracy else args.ssp
        step = annotated_step(args.ssp)
        theirs = omsimulator(args.omsimulator, ssp, args.stop_time, args.tolerance, work)
        ours = run(read_ssp(args.ssp, Path(tmp) / "unpacked"), step, stop_time=args.stop_time).data
    worst = compare(ours, theirs)
    print(f"{'output':32s} {'largest difference':>20s} {'at the end':>12s}")
    for name, diff, end in worst[:12]:
        print(f"{name:32s} {diff:20.3g} {end:12.3g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
