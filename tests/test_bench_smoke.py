"""The work-precision benchmark (`python benchmarks/work_precision.py --quick`, a study of the
checkout, run in full by `make bench`) runs end to end and writes its figure and table (no timing asserted);
the benchmark scripts' helpers (dop853_ab reference tree, taylor_vs_heyoka.to_heyoka) refuse what they
cannot do."""
from __future__ import annotations

import subprocess
import sys

import pytest

from conftest import ROOT


def test_bench_quick_writes_figure_and_table(tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "work_precision.py"), "--quick", "--scenarios",
                        "paper", "--out", str(tmp_path)], capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    table = (tmp_path / "work_precision.md").read_text()
    for method in ("gyrowheel/dop853", "gyrowheel/rosenbrock", "gyrowheel/dopri5 (multipliers)", "casadi/cvodes",
                   "scipy/DOP853", "scipy/Radau", "fmpy-ME/CVode"):
        assert method in table, method
    assert "Constraint violation of the multiplier form" in table
    assert (tmp_path / "work_precision_paper.png").stat().st_size > 20_000


def test_dop853_ab_reference_is_a_git_ref_or_a_directory(tmp_path):
    """The reference of benchmarks/dop853_ab.py is a git ref of the repository (default main)
    exported with git archive, or a directory; never a path that only one machine has, so that
    the script runs from a clean clone."""
    import shutil
    import subprocess
    import sys
    from pathlib import Path
    bench = Path(__file__).resolve().parent.parent / "benchmarks"
    sys.path.insert(0, str(bench))
    try:
        from ref_tree import RefTree
    finally:
        sys.path.remove(str(bench))
    root = bench.parent
    if shutil.which("git") is None or subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"],
                                                      capture_output=True).returncode != 0:
        pytest.skip("not a git checkout")
    tree = RefTree("HEAD", tmp_path)
    assert (tree.root / "fmu_build" / "builder.py").is_file() and (tree.root / "c_src" / "gw_sincos.h").is_file()
    assert tree.layout == "package"
    assert RefTree(str(root), tmp_path / "x").root == root
    with pytest.raises(SystemExit, match="neither a directory nor a git ref"):
        RefTree("no-such-ref-xyz", tmp_path / "y")
    assert "/work/main" not in (bench / "dop853_ab.py").read_text()


def test_to_heyoka_refuses_inputs_it_does_not_translate():
    """benchmarks/taylor_vs_heyoka.py's to_heyoka read every input other than x and p as the time:
    an ode with inputs u or hoisted constants c (model/hoist.py) would have been compared with
    heyoka on a different system, silently (found in review).  The refusal comes before heyoka is
    imported, so it is checked without the [bench] extra; the translation itself when heyoka is
    installed."""
    import casadi as ca
    from pathlib import Path
    bench = Path(__file__).resolve().parent.parent / "benchmarks"
    sys.path.insert(0, str(bench))
    try:
        from taylor_vs_heyoka import to_heyoka
    finally:
        sys.path.remove(str(bench))
    t, x, u, p, c = (ca.SX.sym(n, k) for n, k in (("t", 1), ("x", 2), ("u", 0), ("p", 1), ("c", 1)))
    hoisted = ca.Function("ode", [t, x, u, p, c], [ca.vertcat(x[1] * c, -ca.sin(x[0]))], ["t", "x", "u", "p", "c"],
                          ["xdot"])
    with pytest.raises(ValueError, match="input 'c' of ode is neither t, x nor p"):
        to_heyoka(hoisted, None, [2.0])
    u1 = ca.SX.sym("u", 1)
    with_input = ca.Function("ode", [t, x, u1, p], [ca.vertcat(x[1] * u1, -ca.sin(x[0]))], ["t", "x", "u", "p"], ["xdot"])
    with pytest.raises(ValueError, match="input 'u' of ode is neither t, x nor p"):
        to_heyoka(with_input, None, [2.0])


def test_to_heyoka_translates_an_ode_of_t_x_p():
    """The translation itself needs heyoka (the [bench] extra): without it the test is reported
    as skipped, not passed."""
    hy = pytest.importorskip("heyoka", reason="heyoka is the [bench] extra: pip install -e '.[bench]'")
    import casadi as ca
    from pathlib import Path
    bench = Path(__file__).resolve().parent.parent / "benchmarks"
    sys.path.insert(0, str(bench))
    try:
        from taylor_vs_heyoka import to_heyoka
    finally:
        sys.path.remove(str(bench))
    t, x, u, p = (ca.SX.sym(n, k) for n, k in (("t", 1), ("x", 2), ("u", 0), ("p", 1)))
    good = ca.Function("ode", [t, x, u, p], [ca.vertcat(x[1] * p, -ca.sin(x[0]) + t)], ["t", "x", "u", "p"], ["xdot"])
    assert len(to_heyoka(good, hy.make_vars("x0", "x1"), [2.0])) == 2


def test_work_precision_repetitions_are_rounds_over_every_setting(monkeypatch):
    """work_precision times each setting as the best of --repeat rounds, each round running every
    setting of every method once (timed_rounds): a setting's repetitions spread over the run, not
    back to back, so that a period of a slower machine does not decide a whole row.  Kept per
    (method, setting): the fastest seconds and step_seconds; a peer's NaN step time stays NaN."""
    bench = ROOT / "benchmarks"
    sys.path.insert(0, str(bench))
    try:
        import work_precision as wp
    finally:
        sys.path.remove(str(bench))
    calls = []

    def one_round(sc, args, plain, base):
        k = len(calls)
        calls.append(k)
        return [wp.Point("gyrowheel/taylor", 1e-4, [3.0, 1.0, 2.0][k], 1e-5, 0.0, step_seconds=[2.5, 0.5, 1.5][k]),
                wp.Point("heyoka", 1e-4, [1.0, 4.0, 0.5][k], 2e-5, 0.0),
                wp.Point("gyrowheel/taylor", 1e-7, [6.0, 7.0, 5.0][k], 1e-8, 0.0, step_seconds=[5.5, 6.5, 4.5][k])]
    monkeypatch.setattr(wp, "timed_round", one_round)
    points = wp.timed_rounds(None, None, None, 3, True)
    assert calls == [0, 1, 2]
    assert [(p.method, p.setting, p.seconds) for p in points] == [
        ("gyrowheel/taylor", 1e-4, 1.0), ("heyoka", 1e-4, 0.5), ("gyrowheel/taylor", 1e-7, 5.0)]
    assert [p.step_seconds for p in points][::2] == [0.5, 4.5]
    assert points[1].step_seconds != points[1].step_seconds  # NaN
