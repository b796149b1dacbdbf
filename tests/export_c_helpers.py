"""Helpers of the `gyrowheel export-c` tests (test_export_c.py, test_export_c_realtime.py) and of
their shared fixtures in conftest.py: the command line, the C compiler with strict flags."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]


def gyrowheel(*args, cwd=None) -> subprocess.CompletedProcess:
    """`gyrowheel ARGS` (python -m gyrowheel), output captured."""
    return subprocess.run([sys.executable, "-m", "gyrowheel", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd or ROOT)


def cc(compiler: str, *args) -> subprocess.CompletedProcess:
    """Run the compiler; assert it succeeded (its stderr is the result's, for warnings)."""
    r = subprocess.run([compiler, *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, f"{compiler} {' '.join(map(str, args))}\n{r.stderr}"
    return r
