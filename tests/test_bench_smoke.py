"""`gyrowheel bench --quick` runs end to end and writes its figure and table (no timing asserted)."""
from __future__ import annotations

import subprocess
import sys

import pytest

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


def test_dop853_ab_reference_is_a_git_ref_or_a_directory(tmp_path):
    """benchmarks/dop853_ab.py compared against /work/main by default, a path only the project's
    own machine has: from a clean clone it failed.  The reference is now a git ref of the
    repository (default main) exported with git archive, or a directory (found in review)."""
    import shutil
    import subprocess
    import sys
    from pathlib import Path
    bench = Path(__file__).resolve().parent.parent / "benchmarks"
    sys.path.insert(0, str(bench))
    try:
        import dop853_ab
    finally:
        sys.path.remove(str(bench))
    root = bench.parent
    if shutil.which("git") is None or subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"],
                                                      capture_output=True).returncode != 0:
        pytest.skip("not a git checkout")
    tree = dop853_ab.reference_tree("HEAD", tmp_path)
    assert (tree / "fmu_build" / "builder.py").is_file() and (tree / "c_src" / "gw_fastmath.h").is_file()
    assert dop853_ab.reference_tree(str(root), tmp_path / "x") == root
    with pytest.raises(SystemExit, match="neither a directory nor a git ref"):
        dop853_ab.reference_tree("no-such-ref-xyz", tmp_path / "y")
    assert "/work/main" not in (bench / "dop853_ab.py").read_text()
