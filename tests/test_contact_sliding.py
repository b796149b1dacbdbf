"""The sliding contact mode and its switches (docs/effects.md, "Sliding").

Against results the code did not produce: the upright wheel launched sliding on level ground
(the slip decays at mu_k g (1 + 1/k_axial); rolling starts when it reaches 0, at the speed the
angular momentum about the contact point gives), the incline (rolling holds exactly while
tan(theta) <= mu (1 + k_axial) / k_axial; above, the centre accelerates at g (sin - mu_k cos) and
the spin at mu_k g cos(theta) / (k_axial R)), the energy balance through the switches, FMU states
that keep the mode, and a leaning wheel on low friction that slips and re-sticks.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu

from fmi_helpers import Slave, simulate_logged
from gyrowheel.fmu_build import build_fmu, parse_scene
from gyrowheel.fmu_build.scene import SceneError
from paper_wheel import G, KA, M, R
from paper_wheel import PAPER_WHEEL_TOML as WHEEL

TIGHT = {"rel_tol": 1e-12, "abs_tol": 1e-14}
MU = 0.3
SLIDE = """
[effects.slope]
slope_angle = 0.0
[effects.contact_forces]
on_slip = "slide"
mu = 0.3
[effects.energy]
"""
OUT = ["x", "vx", "gamma_dot", "beta", "contact_mode", "slip_long", "slip_lat", "energy", "dissipated_energy",
       "F_n", "F_long", "contact_switched"]


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    root = tmp_path_factory.mktemp("sliding")
    scene = parse_scene('[model]\nname = "sliding"\n' + WHEEL + SLIDE, "sliding.toml")
    return str(build_fmu(scene, root / "sliding.fmu", build_dir=root / "build").fmu)


def run(fmu, stop, dt=0.01, **start):
    """simulate_fmu with the FMU's event messages: (result, [(event name, t)])."""
    return simulate_logged(fmu, stop, dt, OUT, {**TIGHT, **start})


def slip_rate(mu_k: float) -> float:
    """d|slip|/dt of an upright wheel sliding straight on level ground: the friction -mu_k M g sign(s)
    decelerates the centre by mu_k g and turns the spin by mu_k M g R / (k_axial M R^2), so the
    contact point's slip s = v - R gamma_dot changes at mu_k g (1 + 1/k_axial)."""
    return mu_k * G * (1 + 1 / KA)


@pytest.mark.parametrize("v0, w0", [(2.0, -5.0), (0.5, 20.0)], ids=["backspin", "topspin"])
def test_upright_wheel_launched_sliding_starts_rolling(fmu, v0, w0):
    """Angular momentum about the contact point, M R (v + k_axial R w), is conserved (friction acts at
    the point, gravity and the normal force along the vertical through it); rolling (v = R w) starts
    at t* = |s0| / (mu_k g (1 + 1/k)) with v* = (v0 + k R w0) / (1 + k), whichever way it slips."""
    mu_k = 0.25
    s0 = v0 - R * w0
    t_star = abs(s0) / slip_rate(mu_k)
    v_star = (v0 + KA * R * w0) / (1 + KA)
    r, events = run(fmu, 1.2, beta=math.pi / 2, gamma_dot=w0, slip_long=s0, mu_k=mu_k)
    assert [name for name, _ in events] == ["contact_slip"]
    assert events[0][1] == pytest.approx(t_star, abs=1e-9)
    before = r["time"] < t_star - 1e-6
    assert np.all(r["contact_mode"][before] == 1)
    expected = s0 - math.copysign(slip_rate(mu_k), s0) * r["time"][before]
    assert np.max(np.abs(r["slip_long"][before] - expected)) < 1e-9 * abs(s0)
    assert np.max(np.abs(r["vx"][before] - (v0 - math.copysign(mu_k * G, s0) * r["time"][before]))) < 1e-9
    after = r["time"] > t_star
    assert np.all(r["contact_mode"][after] == 0)
    assert np.max(np.abs(r["vx"][after] - v_star)) < 1e-9 * abs(v_star)
    assert np.max(np.abs(R * r["gamma_dot"][after] - v_star)) < 1e-9 * abs(v_star)
    assert np.all(r["slip_long"][after] == 0) and np.all(r["F_long"][after] == pytest.approx(0, abs=1e-9))


def test_energy_balance_through_the_switches(fmu):
    """energy + dissipated_energy constant through the slide and the switch to rolling; the friction's
    work is mu_k M g times the slip's path, |s0|^2 / (2 mu_k g (1 + 1/k)) for the slip s."""
    mu_k, v0, w0 = 0.25, 2.0, -5.0
    s0 = v0 - R * w0
    r, events = run(fmu, 1.0, beta=math.pi / 2, gamma_dot=w0, slip_long=s0, mu_k=mu_k)
    assert len(events) == 1
    total = r["energy"] + r["dissipated_energy"]
    assert np.max(np.abs(total - total[0])) < 1e-10 * total[0]
    lost = mu_k * M * G * s0**2 / (2 * slip_rate(mu_k))
    assert r["dissipated_energy"][-1] == pytest.approx(lost, rel=1e-9)


def test_incline_rolls_exactly_up_to_the_friction_limit(fmu):
    """Rolling straight down an incline needs the friction M g sin(th) k / (1 + k) against the normal
    force M g cos(th): it holds while tan(th) <= mu (1 + k) / k. Just below (1 - 1e-6) the wheel rolls
    at g sin(th) / (1 + k) without a switch; just above (1 + 1e-6) it slides from the start, the centre
    at g (sin th - mu_k cos th), the spin at mu_k g cos(th) / (k R)."""
    limit = math.atan(MU * (1 + KA) / KA)
    below = limit * (1 - 1e-6)
    r, events = run(fmu, 0.5, beta=math.pi / 2, gamma_dot=0.0, slope_angle=below)
    assert events == [] and not r["contact_switched"].any()
    a = G * math.sin(below) / (1 + KA)
    assert np.max(np.abs(r["x"] - 0.5 * a * r["time"]**2)) < 1e-9 * 0.5 * a * 0.25
    above = limit * (1 + 1e-6)
    for mu_k in (MU, 0.2):
        r, events = run(fmu, 0.5, beta=math.pi / 2, gamma_dot=0.0, slope_angle=above, mu_k=mu_k)
        assert [name for name, _ in events] == ["contact_slip"] and events[0][1] == 0.0
        assert np.all(r["contact_mode"] == 1)
        a = G * (math.sin(above) - mu_k * math.cos(above))
        spin = mu_k * G * math.cos(above) / (KA * R)
        t = r["time"]
        assert np.max(np.abs(r["vx"] - a * t)) < 1e-9 * a * t[-1]
        assert np.max(np.abs(r["x"] - 0.5 * a * t**2)) < 1e-9 * 0.5 * a * t[-1]**2
        assert np.max(np.abs(r["gamma_dot"] - spin * t)) < 1e-9 * spin * t[-1]
        assert np.all(r["slip_long"][1:] > 0)


def test_fmu_state_keeps_the_mode(fmu):
    """An FMU state saved mid-slide and restored reproduces the run exactly, the switch included."""
    s = Slave(fmu, logging_on=False)
    s.init(**TIGHT, beta=math.pi / 2, gamma_dot=-5.0, slip_long=2.85, mu_k=0.25)
    s.slave.doStep(0.0, 0.1)
    assert s.get("contact_mode") == 1.0
    state = s.slave.getFMUState()

    def rest():
        out = []
        for k in range(10):
            s.slave.doStep(0.1 + 0.05 * k, 0.05)
            out.append(s.get("contact_mode", "vx", "gamma_dot", "slip_long", "dissipated_energy"))
        return out
    first = rest()
    assert first[-1][0] == 0.0 and first[0][0] == 1.0
    s.slave.setFMUState(state)
    assert s.get("contact_mode") == 1.0
    assert rest() == first
    s.slave.freeFMUState(state)
    s.free()


@pytest.mark.parametrize("start, most", [
    ({"beta": math.radians(80), "gamma_dot": 8.0, "mu": 0.1, "mu_k": 0.08}, 50),
    # mu_k = mu: the friction needed hovers at the limit, stick and slip alternate (35 events)
    ({"beta": math.radians(75), "gamma_dot": 10.0, "alpha_dot": 1.5, "mu": 0.2, "mu_k": 0.2}, 200)],
    ids=["ice", "at_the_limit"])
def test_leaning_wheel_on_low_friction_slips_and_resticks(fmu, start, most):
    """A leaning, spinning wheel on low friction: it slips and rolls again; no NaN, a bounded number
    of events, the run within the default step budget, the energy balance kept."""
    r, events = run(fmu, 3.0, dt=0.01, **start)
    switches = [t for name, t in events if name == "contact_slip"]
    assert r["time"][-1] == pytest.approx(3.0)
    for key in ("x", "vx", "beta", "slip_long", "slip_lat", "energy"):
        assert np.all(np.isfinite(r[key]))
    assert 2 <= len(switches) <= most
    assert set(r["contact_mode"]) == {0.0, 1.0}
    total = r["energy"] + r["dissipated_energy"]
    assert np.max(np.abs(total - total[0])) < 1e-9 * total[0]


@pytest.mark.parametrize("text, message", [
    ('[effects.contact_forces]\nmu_k = 0.2\n', 'mu_k: is the kinetic friction of on_slip = "slide"'),
    ('[effects.contact_forces]\non_slip = "slide"\nmu = 0.3\nmu_k = 0.4\n', "mu_k: must be <= mu"),
    ('[effects.contact_forces]\non_slip = "slide"\non_lift_off = "warn"\n', 'on_lift_off: must be "terminate"'),
    ('[effects.contact_forces]\n[initial]\nslip_long = 1.0\n', 'slip_long: is a start value of the sliding mode'),
    ('[model]\nformulation = "multipliers"\n[effects.contact_forces]\non_slip = "slide"\n',
     'on_slip: "slide" needs formulation = "reduced"'),
    ('[effects.contact_forces]\non_slip = "slide"\n[initial]\nvx = 1.0\n',
     "vx: is not a start value: the centre velocity is the rolling one (from alpha_dot, beta_dot, gamma_dot) "
     "plus the start slip slip_long, slip_lat"),
])
def test_scene_refuses_what_sliding_cannot_honour(text, message):
    with pytest.raises(SceneError, match=re.escape(message)):
        parse_scene(WHEEL + text, "s.toml")


# GUIDs of rolling-only example scenes' FMUs: the GUID hashes the generated C (gw_funcs.c), the
# variable table, the experiment and the name, so an equal GUID is the same generated model,
# variables and value references: the sliding mode adds nothing to them. Change these only with a
# change meant for rolling scenes (and say so in its commit). Both run the default solver auto
# (its experiment: solver auto, max_step the run's length).
ROLLING_GUIDS = {"paper_earth": "{507a1f5e-dce8-52db-bf2e-79fbb8822f46}",  # base wheel
                 "slope_hold": "{c0c3578f-993e-5015-9346-6d12d405b7ef}"}  # contact_forces + a stiction law


@pytest.mark.parametrize("name", sorted(ROLLING_GUIDS))
def test_rolling_scenes_generate_what_they_did(name, tmp_path, monkeypatch):
    """A scene that does not ask for sliding gets the same generated C and variables (no compile:
    the binaries do not enter the GUID)."""
    from fmpy import read_model_description

    from gyrowheel.fmu_build import builder, load_scene
    monkeypatch.setattr(builder, "write_binaries", lambda *args, **kwargs: None)
    scene = load_scene(Path(__file__).parent.parent / "examples" / "scenes" / f"{name}.toml")
    fmu = build_fmu(scene, tmp_path / f"{name}.fmu", build_dir=tmp_path / "build").fmu
    assert read_model_description(str(fmu)).guid == ROLLING_GUIDS[name]


def test_sliding_adds_exactly_its_variables(fmu):
    """on_slip = "slide" adds mu_k, the slip start values (outputs), contact_mode, the flag of its event
    and four local states; the slip check's flag `slipping` is gone (the switch replaces it)."""
    from fmpy import read_model_description
    variables = {v.name: v for v in read_model_description(fmu).modelVariables}
    for name in ("mu_k", "contact_mode", "slip_long", "slip_lat", "contact_switched", "x_dot", "y_dot",
                 "contact_state", "slip_dir_x", "slip_dir_y"):
        assert name in variables, name
    assert "slipping" not in variables
    assert variables["slip_long"].causality == "output" and variables["slip_long"].initial == "exact"
    assert variables["contact_state"].causality == "local"


def _sliding_newton_euler(q, w, v, mu_k, g, M_, R_, kd, ka):
    """Centre acceleration (3), angular acceleration (3) and F_n of a rigid axisymmetric wheel sliding
    on the plane z = 0, by Newton-Euler, written here from vectors (not the model's code).

    q = (alpha, beta), w = (alpha_dot, beta_dot, gamma_dot), v = (vx, vy) the centre's horizontal
    velocity. Axle n = Rz(alpha) Rx(pi/2 - beta) j = (-sin a sin b, cos a sin b, cos b); angular
    velocity alpha_dot k - beta_dot (cos a, sin a, 0) + gamma_dot n; the contact point C = A + R l,
    l = -(k - cos(b) n) / sin(b). Unknowns a_A, omega_dot, F_n from M a_A = F + M g_vec,
    I omega_dot + omega x I omega = (C - A) x F, F = F_n (k - mu_k e) (e the slip direction), and
    the contact staying on the ground, z_A = R sqrt(1 - n_z^2) differentiated twice."""
    a, b = q
    ad, bd, gd = w
    k = np.array([0.0, 0.0, 1.0])
    n = np.array([-math.sin(a) * math.sin(b), math.cos(a) * math.sin(b), math.cos(b)])
    om = ad * k - bd * np.array([math.cos(a), math.sin(a), 0.0]) + gd * n
    lv = -(k - math.cos(b) * n) / math.sin(b)
    vA = np.array([v[0], v[1], R_ * math.cos(b) * bd])
    slip = (vA + np.cross(om, R_ * lv))[:2]
    e = np.array([*slip / np.linalg.norm(slip), 0.0])
    I_w = kd * M_ * R_**2 * (np.eye(3) - np.outer(n, n)) + ka * M_ * R_**2 * np.outer(n, n)
    nd = np.cross(om, n)
    s = math.sqrt(1 - n[2]**2)
    # unknowns u = (a_A (3), omega_dot (3), F_n); A u = rhs
    A, rhs = np.zeros((7, 7)), np.zeros(7)
    A[0:3, 0:3] = M_ * np.eye(3)
    A[0:3, 6] = -(k - mu_k * e)
    rhs[0:3] = M_ * np.array([0.0, 0.0, -g])
    r = R_ * lv
    A[3:6, 3:6] = I_w
    A[3:6, 6] = -np.cross(r, k - mu_k * e)
    rhs[3:6] = -np.cross(om, I_w @ om)
    # z_A'' = -R [(nz'^2 + nz nz'') / s + nz^2 nz'^2 / s^3], nz'' = (omega_dot x n)_z + (omega x n')_z
    nz, nzd = n[2], nd[2]
    coeff = -R_ * nz / s  # of nz''
    A[6, 2] = 1.0
    A[6, 3:6] = -coeff * np.cross(n, k)  # (omega_dot x n)_z = omega_dot . (n x k)
    rhs[6] = coeff * np.cross(om, nd)[2] - R_ * (nzd**2 / s + nz**2 * nzd**2 / s**3)
    u = np.linalg.solve(A, rhs)
    return u[0:3], u[3:6], u[6], slip, n, om, nd


def test_sliding_equations_match_newton_euler():
    """The sliding mode's accelerations and F_n (derived by CasADi from the Lagrangian) equal an
    independent Newton-Euler solution at random leaning, spinning, slipping states, to 1e-10."""
    import casadi as ca

    from gyrowheel.model.build import build_model
    rng = np.random.default_rng(7)
    mu_k, g = 0.35, 9.81
    spec = build_model({"M": M, "R": R, "k_diam": 0.25, "k_axial": KA}, {},
                       {"gravity": {"g": g}, "contact_forces": {"on_slip": "slide", "mu": 0.5, "mu_k": mu_k}})
    f = ca.Function("f", [spec.x, spec.p], [spec.ode])
    y = ca.Function("y", [spec.x, spec.p], [ca.vertcat(*[e for _, e in spec.outputs])])
    names = [q.name for q, _ in spec.outputs]
    p = [q.start for q in spec.parameters]
    idx = {n: i for i, n in enumerate(spec.x_names)}
    for _ in range(5):
        a, b = rng.uniform(-3, 3), rng.uniform(0.4, 2.7)
        w = rng.uniform(-4, 4, 3)
        v = rng.uniform(-1.5, 1.5, 2)
        aA, wd, Fn, slip, n, om, nd = _sliding_newton_euler((a, b), w, v, mu_k, g, M, R, 0.25, KA)
        x = np.zeros(len(spec.x_names))
        x[idx["alpha"]], x[idx["beta"]] = a, b
        x[idx["alpha_dot"]], x[idx["beta_dot"]], x[idx["gamma_dot"]] = w
        x[idx["x_dot"]], x[idx["y_dot"]] = v
        x[idx["contact_state"]] = 1
        x[idx["slip_dir_x"]], x[idx["slip_dir_y"]] = slip / np.linalg.norm(slip)
        xd = np.array(f(x, p)).ravel()
        out = dict(zip(names, np.array(y(x, p)).ravel()))
        add, bdd, gdd = xd[idx["alpha_dot"]], xd[idx["beta_dot"]], xd[idx["gamma_dot"]]
        ea = np.array([math.cos(a), math.sin(a), 0.0])
        ea_dot = w[0] * np.array([-math.sin(a), math.cos(a), 0.0])
        wd_model = add * np.array([0, 0, 1.0]) - bdd * ea - w[1] * ea_dot + gdd * n + w[2] * nd
        scale = 1 + np.abs(aA).max() + np.abs(wd).max()
        assert np.max(np.abs(xd[[idx["x_dot"], idx["y_dot"]]] - aA[:2])) < 1e-10 * scale
        assert np.max(np.abs(wd_model - wd)) < 1e-10 * scale
        assert out["F_n"] == pytest.approx(Fn, rel=1e-10)
        heading = np.array([math.cos(a), math.sin(a)])
        assert out["slip_long"] == pytest.approx(slip @ heading, rel=1e-10, abs=1e-12)


@pytest.mark.parametrize("extra", [{}, {"rolling_resistance": {"c_rr": 0.02}}, {"spin_friction": {"c_pivot": 0.003}},
                                   {"air_drag": {"c_lin": 0.5}}, {"gyrover": {}}],
                         ids=["wheel", "rolling_resistance", "spin_friction", "air_drag", "gyrover"])
def test_every_effect_keeps_the_energy_balance_while_sliding(extra):
    """d/dt (energy + dissipated_energy - actuator_work) = 0 while sliding, with each effect acting
    (the power of every force counted once, the friction's included): the time derivative along the
    ode, exact by CasADi's chain rule, at random sliding states, to 1e-9 of the power scale."""
    import casadi as ca

    from gyrowheel.model.build import build_model
    effects = {"gravity": {}, **extra, "contact_forces": {"on_slip": "slide", "mu": 0.5, "mu_k": 0.4},
               "energy": {}}
    spec = build_model({}, {}, effects)
    names = [q.name for q, _ in spec.outputs]
    out = {n: e for n, e in zip(names, (e for _, e in spec.outputs))}
    total = out["energy"] + spec.x[spec.x_names.index("dissipated_energy")]
    if "actuator_work" in spec.x_names:
        total = total - spec.x[spec.x_names.index("actuator_work")]
    rate = ca.Function("rate", [spec.x, spec.u, spec.p], [ca.mtimes(ca.jacobian(total, spec.x), spec.ode),
                                                          out["dissipated_power"]])
    p = [q.start for q in spec.parameters]
    rng = np.random.default_rng(3)
    idx = {n: i for i, n in enumerate(spec.x_names)}
    for _ in range(4):
        x = rng.uniform(-1, 1, len(spec.x_names))
        x[idx["beta"]] = rng.uniform(0.6, 2.5)
        x[idx["contact_state"]] = 1
        d = rng.normal(size=2)
        x[idx["slip_dir_x"]], x[idx["slip_dir_y"]] = d / np.linalg.norm(d)
        rates = {"rolling_mode": x[idx["gamma_dot"]],  # each law sliding the way its rate goes
                 "pivot_mode": x[idx["alpha_dot"]] + x[idx["gamma_dot"]] * math.cos(x[idx["beta"]])}
        for law, r in rates.items():
            if law in idx:
                x[idx[law]] = math.copysign(1.0, r)
        u = rng.uniform(-0.05, 0.05, spec.u.numel())
        dE, P = (float(v) for v in rate(x, u, p))
        assert P > 0
        assert abs(dE) < 1e-9 * (1 + P)


@pytest.mark.parametrize("initial, extra", [
    ({"beta": math.pi / 2, "gamma_dot": 0.0}, {"slope": {"slope_angle": 0.7}}),  # too steep: slides at once
    ({"beta": math.radians(80), "gamma_dot": 8.0}, {}),  # leaning on ice
    ({"beta": math.radians(70), "gamma_dot": 12.0, "alpha_dot": 1.0}, {})])
def test_indicator_is_not_negative_after_any_update(initial, extra):
    """As a stiction law's: the update of contact_slip leaves its indicator >= 0, so it fires again
    only after a new crossing. Rolling -> sliding gives d . v_slip = 0; firing again there (the slip
    still 0, the friction needed still beyond mu F_n) keeps sliding at 0; a slide that stops where
    rolling holds gives the rolling indicator > 0."""
    from gyrowheel.model.build import build_model
    spec = build_model({}, initial, {"gravity": {}, **extra, "contact_forces": {"on_slip": "slide", "mu": 0.1},
                                     "energy": {}})
    f = spec.functions()
    p, s = [q.start for q in spec.parameters], [q.start for q in spec.starts]
    k, mode = [e.name for e in spec.events].index("contact_slip"), spec.x_names.index("contact_state")
    x = np.array(f["init"](s, p)).ravel()
    assert x[mode] == 0 and float(f["evt"](0, x, [], p)[k]) < 0
    for expected in (1, 1):
        x = np.array(f["upd"](0, x, [], p, k)).ravel()
        assert x[mode] == expected and float(f["evt"](0, x, [], p)[k]) >= 0
    if not extra:  # a level wheel, mu raised: the stop rule finds rolling holds
        p[[q.name for q in spec.parameters].index("mu")] = 10.0
        x = np.array(f["upd"](0, x, [], p, k)).ravel()
        assert x[mode] == 0 and float(f["evt"](0, x, [], p)[k]) > 0


@pytest.mark.parametrize("solver", ["dop853", "rosenbrock"])
def test_other_solvers_locate_the_switch(fmu, solver):
    """The FMU's other adaptive solvers locate the backspin case's switch as DOPRI5 does."""
    v0, w0, mu_k = 2.0, -5.0, 0.25
    s0 = v0 - R * w0
    r, events = run(fmu, 0.6, beta=math.pi / 2, gamma_dot=w0, slip_long=s0, mu_k=mu_k,
                    solver={"dop853": 5, "rosenbrock": 4}[solver])
    assert [name for name, _ in events] == ["contact_slip"]
    assert events[0][1] == pytest.approx(abs(s0) / slip_rate(mu_k), abs=1e-9)
    assert r["vx"][-1] == pytest.approx((v0 + KA * R * w0) / (1 + KA), rel=1e-9)


def test_model_exchange_switches_at_the_importers_event(fmu):
    """Model Exchange: fmpy's CVode locates the crossing of contact_slip's indicator and
    fmi2NewDiscreteStates switches the mode; the rolling speed after it is the analytic one."""
    v0, w0, mu_k = 2.0, -5.0, 0.25
    s0 = v0 - R * w0
    r = simulate_fmu(fmu, stop_time=0.6, output_interval=0.01, fmi_type="ModelExchange", solver="CVode",
                     relative_tolerance=1e-10, output=OUT,
                     start_values={"beta": math.pi / 2, "gamma_dot": w0, "slip_long": s0, "mu_k": mu_k})
    t_star = abs(s0) / slip_rate(mu_k)
    assert np.all(r["contact_mode"][r["time"] < t_star - 1e-3] == 1)
    assert np.all(r["contact_mode"][r["time"] > t_star + 1e-3] == 0)
    assert r["vx"][-1] == pytest.approx((v0 + KA * R * w0) / (1 + KA), rel=1e-6)


def test_rolling_resistance_breaks_away_and_acts_while_sliding(tmp_path):
    """A wheel launched sliding without spin, with rolling resistance (its stiction law stuck at
    gamma_dot = 0): the friction torque mu_k F_n R exceeds the holding limit c_rr R F_n, so the law
    breaks away at the start (its holding torque taken in the sliding mode), and then
    k M R^2 gamma_ddot = (mu_k - c_rr) M g R while M v_dot = -mu_k M g: the slip s = v - R gamma_dot
    reaches 0 at t* = s0 / (g (mu_k + (mu_k - c_rr) / k)); rolling, the wheel then decelerates at
    c_rr g / (1 + k)."""
    c_rr, mu_k, v0 = 0.05, 0.25, 2.0
    scene = parse_scene('[model]\nname = "slide_rr"\n' + WHEEL + SLIDE.replace(
        "[effects.contact_forces]", f"[effects.rolling_resistance]\nc_rr = {c_rr}\n[effects.contact_forces]"),
        "slide_rr.toml")
    fmu = str(build_fmu(scene, tmp_path / "slide_rr.fmu", build_dir=tmp_path / "build").fmu)
    t_star = v0 / (G * (mu_k + (mu_k - c_rr) / KA))
    r, events = run(fmu, 0.6, beta=math.pi / 2, gamma_dot=0.0, slip_long=v0, mu_k=mu_k)
    assert events[0] == ("rolling_stiction", 0.0)
    assert [name for name, _ in events[1:]] == ["contact_slip"] and events[1][1] == pytest.approx(t_star, abs=1e-9)
    t = r["time"]
    before, after = t < t_star, t > t_star
    assert np.max(np.abs(r["vx"][before] - (v0 - mu_k * G * t[before]))) < 1e-9 * v0
    spin = (mu_k - c_rr) * G / (KA * R)
    assert np.max(np.abs(r["gamma_dot"][before] - spin * t[before])) < 1e-9 * spin * t_star
    v_star = v0 - mu_k * G * t_star
    expected = v_star - c_rr * G / (1 + KA) * (t[after] - t_star)
    assert np.max(np.abs(r["vx"][after] - expected)) < 1e-9 * v0
    total = r["energy"] + r["dissipated_energy"]
    assert np.max(np.abs(total - total[0])) < 1e-10 * total[0]


def test_leaning_slide_switches_as_scipy_locates_them(fmu):
    """The leaning wheel on ice (80 deg, gamma_dot0 = 8 rad/s, mu = 0.1, mu_k = 0.08): the FMU's
    switches (its DOPRI5 and its event location, in C) against scipy's DOP853 with its own event
    location on the same model (studies/scipy_reference.py, rtol 1e-12): every switch within 1e-9 s,
    the state at 3 s within 1e-7."""
    from gyrowheel.fmu_build.builder import model_spec
    from gyrowheel.studies.scipy_reference import solve_hybrid
    start = {"beta": math.radians(80), "gamma_dot": 8.0}
    scene = parse_scene('[model]\nname = "ice"\n' + WHEEL + SLIDE.replace("mu = 0.3", "mu = 0.1\nmu_k = 0.08")
                        + "[initial]\nbeta_deg = 80\ngamma_dot = 8.0\n", "ice.toml")
    spec = model_spec(scene)
    f = spec.functions()
    p, s = [q.start for q in spec.parameters], [q.start for q in spec.starts]
    k = [e.name for e in spec.events].index("contact_slip")
    x0 = np.array(f["init"](s, p)).ravel()
    assert float(f["evt"](0, x0, [], p)[k]) < 0  # it slides from the start: the initial event
    x0 = np.array(f["upd"](0, x0, [], p, k)).ravel()
    _, x_end, switches = solve_hybrid(spec, x0, p, 3.0)
    r, events = run(fmu, 3.0, mu=0.1, mu_k=0.08, **start)
    assert events[0] == ("contact_slip", 0.0)
    assert [name for name, _ in events[1:]] == [name for _, name in switches] == ["contact_slip"] * 3
    assert np.max(np.abs(np.array([t for _, t in events[1:]]) - [t for t, _ in switches])) < 1e-9
    for name in ("x", "vx", "beta", "gamma_dot"):
        expected = x_end[spec.x_names.index(name)] if name in spec.x_names else \
            x_end[spec.x_names.index("x_dot")]
        assert r[name][-1] == pytest.approx(expected, rel=1e-7, abs=1e-9), name
