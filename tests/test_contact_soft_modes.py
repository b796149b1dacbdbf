"""The hybrid contact modes against the soft-contact reference (tests/reference/soft_contact.py,
docs/contact_reference.md) where no closed form exists: a leaning wheel sliding on ice until it
rolls again, and a leaning, spinning, slipping wheel dropped. The reference has no modes (a
penalty spring of stiffness kappa, Coulomb friction smoothed below eps); its event times converge
as kappa grows and eps shrinks, and the hybrid's must lie where they converge.

Measured (this file's runs; the reference's errors against the hybrid's times):
  leaning slide (80 deg, gamma_dot0 = 8 rad/s, mu = 0.1, mu_k = 0.08), rolling again (the slip
  speed falling to eps) at the hybrid's 2.205516 s:
    kappa 1e4, eps 1e-3: -3.25e-2 s;  kappa 1e5, eps 1e-4: -2.8e-3 s  (1e5, 1e-3: -9.4e-3;
    1e6, 1e-3: -7.5e-3: at eps 1e-3 the smoothing's share dominates)
  leaning drop (h 0.05 m, beta 1.1, gamma_dot 15, alpha_dot 1, slip_long 0.3, e 0.5, mu 0.3),
  second touchdown (the first is pure flight: the same to 1e-7 s):
    kappa 1e6, 1e7, 1e8: 0.1630236, 0.1628963, 0.1628559 s (converging as kappa^-1/2, Richardson
    0.1628373 s); the hybrid 0.1628372 s: 2.0e-8 s before the limit, a thousandth of the limit's
    distance from the stiffest run (1.9e-5 s). The hybrid's impact (model/impact.py) is the rigid
    limit of the reference's own contact: Coulomb friction integrated as the slip turns, the
    normal impulse that of the Kelvin-Voigt spring-damper.
"""
from __future__ import annotations

import math

import pytest

from fmi_helpers import simulate_logged
from reference.soft_contact import Ground, SoftWheel, Wheel, initial_state
from reference.soft_contact_scenarios import extrapolate

WHEEL = Wheel()  # the paper's wheel, as drop_bounce's
G = 9.81
TIGHT = {"rel_tol": 1e-12, "abs_tol": 1e-14}
ICE = {"beta": math.radians(80), "gamma_dot": 8.0, "mu": 0.1, "mu_k": 0.08, "height": 0.0}
LEANING_DROP = {"height": 0.05, "beta": 1.1, "gamma_dot": 15.0, "alpha_dot": 1.0, "slip_long": 0.3,
                "restitution": 0.5}


@pytest.fixture(scope="module")
def hybrid(example_build):
    """drop_bounce with the Taylor kernel: the build tests/test_contact_solvers.py shares."""
    return str(example_build("drop_bounce", taylor=True).fmu)


def soft_ice_roll(stiffness: float, eps: float) -> float:
    """The reference's leaning wheel on ice: the first time its slip speed falls to eps (s)."""
    ground = Ground(stiffness=stiffness, mu_k=0.08, mu_s=0.1, eps=eps, g=G)
    y0 = initial_state(WHEEL, beta=ICE["beta"], gamma_dot=ICE["gamma_dot"], height=-G / stiffness)
    run = SoftWheel(WHEEL, ground).simulate(y0, 2.4, rtol=1e-6, atol=1e-8)
    return [t for t, _ in run.named("stick")][0]


def test_leaning_slide_rolls_again_where_the_soft_reference_converges(hybrid):
    """The hybrid slides from t = 0 and rolls again at 2.2055 s; the reference, tenfold stiffer and
    with a tenth of the smoothing, comes tenfold nearer from below (-3.25e-2 s, then -2.8e-3 s)."""
    _, events = simulate_logged(hybrid, 2.3, 0.01, ["contact_mode"], {**TIGHT, **ICE})
    t_roll = events[-1][1]
    assert [name for name, _ in events] == ["contact_slip"] * 4 and t_roll == pytest.approx(2.2055159, abs=1e-6)
    coarse, fine = soft_ice_roll(1e4, 1e-3), soft_ice_roll(1e5, 1e-4)
    assert coarse < fine < t_roll
    assert t_roll - fine < (t_roll - coarse) / 8 and t_roll - fine < 4e-3


def test_leaning_drop_touches_down_where_the_soft_reference_converges(hybrid):
    """The first touchdown follows a flight both integrate exactly alike (1e-7 s); the second
    converges in the reference as kappa^-1/2 (successive differences in the ratio sqrt(10)), and the
    hybrid's lies at the extrapolated limit: nearer to it than the stiffest run, by far (measured
    2.0e-8 s against 1.9e-5 s)."""
    _, events = simulate_logged(hybrid, 0.17, 0.001, ["contact_mode"], {**TIGHT, **LEANING_DROP})
    touch = [t for name, t in events if name == "contact_flight"]
    second = []
    for stiffness in (1e6, 1e7, 1e8):
        ground = Ground(stiffness=stiffness, restitution=0.5, mu_k=0.3, eps=1e-4, g=G)
        y0 = initial_state(WHEEL, beta=1.1, gamma_dot=15.0, alpha_dot=1.0, slip_long=0.3, height=0.05)
        run = SoftWheel(WHEEL, ground).simulate(y0, 0.17, rtol=1e-8, atol=1e-10)
        downs = [t for t, name, _ in run.switches if name == "touchdown"]
        assert downs[0] == pytest.approx(touch[0], abs=1e-7)
        second.append(downs[1])
    ratio = (second[0] - second[1]) / (second[1] - second[2])
    assert 2.8 < ratio < 3.6
    limit = extrapolate(second[1], second[2])
    assert abs(limit - second[2]) < 5e-5
    assert abs(touch[1] - limit) < 0.1 * abs(limit - second[2])
