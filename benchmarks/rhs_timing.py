"""Build and run benchmarks/rhs_bench.c: ns per RHS evaluation of a scene's generated model and, in
the same run, of the minimal hand-written closed form of the base wheel (rhs_minimal.c)."""
from __future__ import annotations

import math
import subprocess
from pathlib import Path

from fmu_build.compiler import OPTIMISE, compiler

HERE = Path(__file__).resolve().parent


def build(sources: Path, out: Path) -> Path:
    """rhs_bench linked against the FMU's sources, with the FMU's own portable flags."""
    subprocess.run([compiler(), "-std=c99", *OPTIMISE, f"-I{sources}", f"-I{HERE}", str(HERE / "rhs_bench.c"),
                    str(HERE / "rhs_model.c"), str(HERE / "rhs_minimal.c"), "-o", str(out), "-lm"], check=True)
    return out


def run(exe: Path, calls: int = 2_000_000) -> tuple[float, float]:
    """(generated ns, minimal ns); minimal is nan for a model that is not the base wheel."""
    out = subprocess.run([str(exe), str(calls)], capture_output=True, text=True, check=True).stdout.split()
    return float(out[0]), (float(out[1]) if out[1] != "nan" else math.nan)
