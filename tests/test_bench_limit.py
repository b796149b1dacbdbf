"""The work-precision benchmark's limit line (benchmarks/work_limit.py): the order it assigns to
solver taylor against heyoka's order rule (Jorba & Zou's p0, which heyoka implements; solver
taylor runs p0 + 4), and the choice of the fewest steps x order among the Taylor runs that reach a
target."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parent.parent / "benchmarks"


@pytest.fixture(scope="module")
def work_limit():
    sys.path.insert(0, str(BENCH))
    try:
        import work_limit
        import work_precision
    finally:
        sys.path.remove(str(BENCH))
    return work_limit, work_precision


def test_taylor_order_is_heyokas_plus_four(work_limit):
    hy = pytest.importorskip("heyoka", reason="heyoka is the [bench] extra: pip install -e '.[bench]'")
    import numpy as np
    wl, _ = work_limit
    x = hy.make_vars("x")
    for k in range(3, 16):
        tol = 10.0 ** -k
        ta = hy.taylor_adaptive([(x, -x)], np.array([1.0]), tol=tol)
        assert wl.taylor_order(tol) == ta.order + wl.EXTRA_ORDER, tol


def test_limit_takes_the_fewest_steps_times_order_that_reach_the_target(work_limit):
    wl, wp = work_limit
    P = wp.Point
    points = [P("gyrowheel/taylor", 1e-4, 1e-4, 5e-5, 0.0, steps=30, order=10),   # 300
              P("heyoka", 1e-4, 2e-4, 8e-5, 0.0, steps=60, order=6),              # 360
              P("gyrowheel/taylor", 1e-7, 2e-4, 5e-8, 0.0, steps=40, order=14),   # 560
              P("heyoka", 1e-7, 3e-4, 2e-8, 0.0, steps=50, order=10),             # 500
              P("gyrowheel/dop853", 1e-9, 1e-4, 1e-11, 0.0)]                      # not a Taylor run
    lim = wl.limits(points, (1e-4, 1e-7, 1e-10), t_rhs=2e-8)
    assert lim[1e-4] == pytest.approx((300 * 2e-8, 30, 10, "gyrowheel/taylor"))
    assert lim[1e-7] == pytest.approx((500 * 2e-8, 50, 10, "heyoka"))
    assert 1e-10 not in lim  # reached only by a method without steps x order
    text = wl.limit_table("s", {"gyrowheel/dop853": {1e-4: 6e-6}}, lim, (1e-4, 1e-7, 1e-10), 38, 2e-8)
    assert "| gyrowheel/dop853 | 1 | - | - |" in text and "30 steps x order 10, taylor" in text


def test_tolerance_grid_spans_1e_3_to_rel_tols_end_at_the_asked_density(work_limit):
    _, wp = work_limit
    import numpy as np
    half = wp.tolerance_grid(2)
    assert half == [10.0 ** -(k / 2) for k in range(6, 30)]  # 1e-3, 10^-3.5, ..., 10^-14.5
    quarter = np.array(wp.tolerance_grid(4))
    assert len(quarter) == 47 and quarter[0] == 1e-3 and quarter[-1] == 10.0 ** -14.5
    assert np.allclose(np.diff(np.log10(quarter)), -0.25, rtol=0, atol=1e-12)
    assert set(half) <= set(quarter.tolist())  # the finer grid keeps every coarse point
    with pytest.raises(ValueError, match="per_decade"):
        wp.tolerance_grid(0)
