"""Build and run benchmarks/rhs_bench.c: ns per RHS evaluation of a scene's generated model and, in
the same run, of the minimal hand-written closed form of the base wheel (rhs_minimal.c), with libm's
sin/cos and with the runtime's gw_sincos2 (c_src/gw_sincos.h, what the generated code uses)."""
from __future__ import annotations

import math
import subprocess
from pathlib import Path

from gyrowheel.fmu_build.runtime import RUNTIME_DIR
from gyrowheel.fmu_build.compiler import OPTIMISE, compiler

HERE = Path(__file__).resolve().parent


def build(sources: Path, out: Path) -> Path:
    """rhs_bench linked against the FMU's sources, with the FMU's own portable flags."""
    subprocess.run([compiler(), "-std=c99", *OPTIMISE, f"-I{sources}", f"-I{HERE}", f"-I{RUNTIME_DIR}",
                    str(HERE / "rhs_bench.c"),
                    str(HERE / "rhs_model.c"), str(HERE / "rhs_minimal.c"), "-o", str(out), "-lm"], check=True)
    return out


def run(exe: Path, calls: int = 2_000_000) -> tuple[float, float]:
    """(generated ns, minimal ns with libm's sin/cos); minimal is nan for a model that is not the
    base wheel."""
    return run3(exe, calls)[:2]


def run3(exe: Path, calls: int = 2_000_000) -> tuple[float, float, float]:
    """(generated ns, minimal ns with libm's sin/cos, minimal ns with gw_sincos2); nan for the
    minimal ones when the model is not the base wheel."""
    out = subprocess.run([str(exe), str(calls)], capture_output=True, text=True, check=True).stdout.split()
    return tuple(float(v) if v != "nan" else math.nan for v in out[:3])
