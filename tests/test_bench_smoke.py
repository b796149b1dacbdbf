"""`gyrowheel bench --quick` runs end to end and writes its figure and table (no timing asserted)."""
from __future__ import annotations

import subprocess
import sys

from conftest import ROOT


def test_bench_quick_writes_figure_and_table(tmp_path):
    r = subprocess.run([sys.executable, "-m", "fmu_build", "bench", "--quick", "--scenarios", "paper",
                        "--out", str(tmp_path)], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    table = (tmp_path / "work_precision.md").read_text()
    for method in ("gyrowheel/dop853", "gyrowheel/rosenbrock", "gyrowheel/dopri5 (multipliers)", "casadi/cvodes",
                   "scipy/DOP853", "scipy/Radau", "fmpy-ME/CVode"):
        assert method in table, method
    assert "Constraint violation of the multiplier form" in table
    assert (tmp_path / "work_precision_paper.png").stat().st_size > 20_000
