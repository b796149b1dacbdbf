"""Compile the FMU's C sources into binaries/linux64/<identifier>.so.

Portable flags only (no -march=native). Hand-written runtime code is held to
-Wall -Wextra -Werror; CasADi's generated files additionally get
-Wno-unused-parameter (its functions ignore some of the standard arguments).
Only fmi2* symbols are exported (-fvisibility=hidden plus FMI2_Export).
"""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import fmpy

WARNINGS = ["-Wall", "-Wextra", "-Werror"]
GENERATED_EXTRA = ["-Wno-unused-parameter"]
OPTIMISE = ["-O2", "-fno-math-errno"]


class CompileError(RuntimeError):
    """The C compiler failed; the message carries its output."""


def fmi_headers_dir() -> Path:
    """FMI 2.0 headers shipped with fmpy (DESIGN.md: not a copy in the repo)."""
    return Path(fmpy.__file__).parent / "c-code"


def compiler() -> str:
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc:
        raise CompileError("no C compiler found: install gcc (Debian: apt-get install gcc) or set CC")
    return cc


def _run(cmd: list[str]) -> None:
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise CompileError(f"{' '.join(cmd)}\n{proc.stdout}{proc.stderr}")


def compile_shared(sources: list[Path], generated: set[str], include_dirs: list[Path],
                   output: Path, build_dir: Path, extra_flags: list[str] | None = None) -> Path:
    """Compile each source to an object, link a shared library with hidden symbols."""
    cc = compiler()
    build_dir.mkdir(parents=True, exist_ok=True)
    output.parent.mkdir(parents=True, exist_ok=True)
    includes = [f"-I{d}" for d in include_dirs]
    objects = []
    for src in sources:
        obj = build_dir / (src.stem + ".o")
        flags = WARNINGS + (GENERATED_EXTRA if src.name in generated else [])
        _run([cc, "-std=c99", "-c", "-fPIC", "-fvisibility=hidden", *OPTIMISE, *flags,
              *(extra_flags or []), *includes, str(src), "-o", str(obj)])
        objects.append(str(obj))
    _run([cc, "-shared", "-fPIC", "-fvisibility=hidden", *(extra_flags or []), *objects,
          "-o", str(output), "-lm", "-static-libgcc"])
    return output
