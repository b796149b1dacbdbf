"""Statements of the docs that are easy to read wrongly, stated precisely and tested.

Each test names the document and the claim it keeps true.
"""
from __future__ import annotations

import math
import re

import casadi as ca
import numpy as np
import pytest

from conftest import ROOT, SCENES, steady_precession
from gyrowheel.fmu_build import load_scene, parse_scene
from gyrowheel.fmu_build.scene import SOLVERS, SceneError
from gyrowheel.model import build_model
from gyrowheel.model.kinematics import WheelKinematics, frame_lmn

DOCS = ROOT / "docs"


def _rot_x(t):
    """Right-handed rotation by t about the ground x axis (i)."""
    c, s = math.cos(t), math.sin(t)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rot_z(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


# -- docs/model.md: the frame and its sense ------------------------------------------------

def test_frame_is_upright_turned_about_i_then_about_k():
    """docs/model.md: from l = -k, m = -i, n = +j (upright, alpha = 0) the frame is turned
    right-handedly about the ground axis i (= -m there) by pi/2 - beta, then about k by alpha;
    so n . k = cos(beta) and l . k = -sin(beta) (eqs. 9-11). The opposite sense (right-handed
    about m) would give n . k = -cos(beta)."""
    a, b = ca.SX.sym("a"), ca.SX.sym("b")
    f = ca.Function("lmn", [a, b], [frame_lmn(a, b)])
    upright = np.array([[0, -1, 0], [0, 0, 1], [-1, 0, 0]], dtype=float)  # columns l, m, n
    rng = np.random.default_rng(3)
    for alpha, beta in zip(rng.uniform(-4, 4, 10), rng.uniform(0.01, math.pi - 0.01, 10)):
        lmn = np.array(f(alpha, beta))
        np.testing.assert_allclose(lmn, _rot_z(alpha) @ _rot_x(math.pi / 2 - beta) @ upright, atol=1e-15)
        assert lmn[2, 2] == pytest.approx(math.cos(beta), abs=1e-15)   # n . k
        assert lmn[2, 0] == pytest.approx(-math.sin(beta), abs=1e-15)  # l . k
        wrong = _rot_z(alpha) @ _rot_x(-(math.pi / 2 - beta)) @ upright  # right-handed about m = -i
        assert wrong[2, 2] == pytest.approx(-math.cos(beta), abs=1e-15)


def test_pivot_and_axle_rates():
    """docs/effects.md: omega . k = alpha_dot + gamma_dot cos(beta), omega . n = gamma_dot + alpha_dot cos(beta)."""
    q, qd = ca.SX.sym("q", 5), ca.SX.sym("qd", 5)
    kin = WheelKinematics(q, qd, ca.SX(0.3))
    f = ca.Function("w", [q, qd], [kin.omega[2], ca.dot(kin.omega, kin.n)])
    rng = np.random.default_rng(4)
    for _ in range(10):
        qv, qdv = rng.uniform(-3, 3, 5), rng.uniform(-5, 5, 5)
        qv[3] = rng.uniform(0.05, math.pi - 0.05)
        w_k, w_n = (float(v) for v in f(qv, qdv))
        assert w_k == pytest.approx(qdv[2] + qdv[4] * math.cos(qv[3]), abs=1e-13)
        assert w_n == pytest.approx(qdv[4] + qdv[2] * math.cos(qv[3]), abs=1e-13)


# -- docs/scenes.md: the solver list and the table of refusals --------------------------------

def test_scene_docs_list_every_solver_the_reader_takes():
    text = (DOCS / "scenes.md").read_text()
    line = next(line for line in text.splitlines() if line.startswith("solver = "))
    listed = line.split("#", 1)[1].split("(")[0].split("|")
    assert [s.strip() for s in listed] == list(SOLVERS)


def _refusal_rows():
    text = (DOCS / "scenes.md").read_text()
    section = text[text.index("## Rules: what is refused"):text.index("**Why x_dot")]
    rows = [line.split(" | ") for line in section.splitlines() if line.startswith("| `")]
    # a table cell's '|' is written '\|', in code spans too
    return [("\n".join(re.findall(r"`([^`]*)`", cells[0])) + "\n",
             re.findall(r"`([^`]*)`", cells[1])[0].replace("\\|", "|")) for cells in rows]


@pytest.mark.parametrize("snippet,message", _refusal_rows())
def test_scene_docs_refusals_are_the_readers(snippet, message):
    with pytest.raises(SceneError) as err:
        parse_scene(snippet, "s.toml")
    if "not valid TOML" in message:  # the position wording is tomllib's and varies between Pythons
        message = message.split(" (at ")[0]
    assert str(err.value).startswith(message)


def test_annotated_scene_example_parses():
    text = (DOCS / "scenes.md").read_text()
    example = re.search(r"## An annotated example\n\n```toml\n(.*?)```", text, re.S).group(1)
    scene = parse_scene(example, "rover_demo.toml")
    assert scene.experiment.solver == "auto" and "gyrover" in scene.effects


# -- docs/effects.md: drag_force and rolling_resistance_torque ---------------------------------

def _spec_functions(effects, **wheel):
    spec = build_model(wheel=wheel, effects={"gravity": {}, **effects})
    fns = spec.functions()
    p = np.array([q.start for q in spec.parameters], dtype=float)
    names = [q.name for q, _ in spec.outputs]
    return spec, fns, p, names


def test_drag_force_uses_the_smoothed_speed():
    """drag_force = |F| = (c_lin + rho cd_area |v|_s / 2) |v| with |v|_s = sqrt(v . v + (1e-6 m/s)^2):
    at 3 m/s the smoothing is invisible (1e-13 relative); at 1 um/s it doubles the quadratic law."""
    spec, fns, p, names = _spec_functions({"air_drag": {"c_lin": 0.0, "cm_spin": 0.0}})
    rho_cd = 1.225 * 0.02
    i = names.index("drag_force")
    for v in (3.0, 1e-6):
        x0 = np.array(fns["init"]([{"beta": math.pi / 2, "gamma_dot": v / 0.17}.get(q.name, q.start)
                                   for q in spec.starts], p)).ravel()
        out = np.array(fns["out"](0.0, x0, [], p)).ravel()
        speed = math.hypot(out[names.index("vx")], out[names.index("vy")])
        assert speed == pytest.approx(v, rel=1e-14)
        assert out[i] == pytest.approx(0.5 * rho_cd * math.sqrt(v**2 + 1e-12) * v, rel=1e-12)
    assert out[i] == pytest.approx(math.sqrt(2) * 0.5 * rho_cd * v**2, rel=1e-12)  # v = 1e-6


def test_rolling_resistance_torque_is_a_generalised_force_on_gamma():
    """rolling_resistance_torque is Q_gamma = -c_rr R F_n sign(gamma_dot) while rolling (the default
    stiction law; the smoothed law's tanh(5 / 0.01) is 1 too) (N.m per rad of gamma): its power is
    Q_gamma gamma_dot, not a torque about the axle times omega . n."""
    spec, fns, p, names = _spec_functions({"rolling_resistance": {}, "contact_forces": {}, "energy": {}})
    start = {"beta": 1.2, "alpha_dot": 2.0, "gamma_dot": 5.0}
    x = np.array(fns["init"]([start.get(q.name, q.start) for q in spec.starts], p)).ravel()
    out = dict(zip(names, np.array(fns["out"](0.0, x, [], p)).ravel()))
    q_gamma = out["rolling_resistance_torque"]
    assert q_gamma == pytest.approx(-0.01 * 0.17 * out["F_n"] * math.tanh(5.0 / 0.01), rel=1e-12)
    assert out["dissipated_power"] == pytest.approx(-q_gamma * 5.0, rel=1e-12)
    w_n = 5.0 + 2.0 * math.cos(1.2)  # omega . n differs from gamma_dot here
    assert abs(out["dissipated_power"] + q_gamma * w_n) > 0.1 * out["dissipated_power"]


# -- examples/scenes/euler_disk.toml: the steady precession it claims ---------------------------

def test_euler_disk_scene_starts_in_steady_precession():
    """Eq. 52 generalised with rho = 0: alpha_dot^2 = g / (k_diam R sin(beta)),
    gamma_dot = -cos(beta) alpha_dot, to the last digit; the conservative model then holds the
    lean (beta_ddot = 0) and the centre (vx = vy = 0)."""
    scene = load_scene(SCENES / "euler_disk.toml")
    w = scene.wheel
    steady = steady_precession(scene.initial["beta"], 0.0, w["M"], w["R"], w["k_diam"], w["k_axial"], 9.81, sign=1.0)
    assert scene.initial["alpha_dot"] == pytest.approx(steady["alpha_dot"], rel=1e-15)
    assert scene.initial["gamma_dot"] == pytest.approx(steady["gamma_dot"], rel=1e-15)
    spec = build_model(wheel=w, initial=scene.initial, effects={"gravity": {}})
    fns = spec.functions()
    p = np.array([q.start for q in spec.parameters], dtype=float)
    x0 = np.array(fns["init"]([q.start for q in spec.starts], p)).ravel()
    xdot = np.array(fns["ode"](0.0, x0, [], p)).ravel()
    assert abs(xdot[6]) < 1e-9 * x0[5] ** 2  # beta_ddot against the scale alpha_dot^2
    assert np.abs(xdot[:2]).max() < 1e-15 * w["R"] * x0[5]


# -- docs/fmi.md: what the FMI 3.0 FMU does not have, and how it answers ----------------------

def _absent_rows():
    text = (DOCS / "fmi.md").read_text()
    section = text[text.index("### What the FMU does not have"):text.index("### The state machine", text.index("## FMI 3.0"))]
    return [line.split(" | ") for line in section.splitlines() if line.startswith("| `fmi3")]


def _named_functions(cell: str) -> set[str]:
    """`fmi3Get/SetX` names fmi3GetX and fmi3SetX; `...Y` after it, fmi3GetY and fmi3SetY."""
    names, pair = set(), ("fmi3",)
    for token in re.findall(r"`([^`]+)`", cell):
        if token.startswith("fmi3Get/Set"):
            pair = ("fmi3Get", "fmi3Set")
            token = token[len("fmi3Get/Set"):]
        elif token.startswith("..."):
            token = token[3:]
        else:
            pair = ("",)
        names |= {prefix + token for prefix in pair}
    return names


def test_fmi_docs_list_every_absent_function_with_its_logged_reason():
    """docs/fmi.md, "What the FMU does not have": the table names exactly the functions of
    c_src/gw_fmi3_absent.c, and every reason it quotes is made of the C source's text."""
    source = (ROOT / "c_src" / "gw_fmi3_absent.c").read_text()
    defined = set(re.findall(r"^fmi3Status (fmi3\w+)\(", source, re.M))
    rows = _absent_rows()
    listed = set().union(*(_named_functions(cells[0]) for cells in rows))
    assert listed == defined
    c_text = re.sub(r'"\s*\n\s*"', "", source)  # C's adjacent string literals joined
    quoted = [q for cells in rows for q in re.findall(r'"([^"]+)"', cells[1])]
    assert len(quoted) >= 4
    for q in quoted:  # the pieces a message is put together from ("%s: %s")
        for part in re.split(r"\.\.\.|: ", q):
            assert part.strip() in c_text, part
