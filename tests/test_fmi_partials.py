"""Every partial derivative the model description advertises is answered, exactly, in every state
where FMI 2.0.4 allows fmi2GetDirectionalDerivative (sections 2.1.9, 2.2.8; docs/fmi.md).

  Initialization Mode  InitialUnknowns x their `dependencies` (start values, parameters, inputs):
                       the generated `dini` (CasADi Jacobian at x = init(s, p)).
      all 58 advertised partials of paper_earth answered, the 18 with a parameter (M, R, k_diam,
      k_axial, g) as the known included (not refused as "known R is not a continuous state or a
      Real input"), d z / d R = sin(beta) exactly; partials the model description leaves out
      are exactly 0 (test_unadvertised_initial_partials_are_zero).
  after initialisation Outputs and Derivatives x their `dependencies` (states, inputs): `dir`.
  every example scene  dependency lists sorted and unique (not "2 14 14", "16 16").
Each answer is checked against central differences of the FMU itself (Initialization Mode:
fmi2SetReal on the known, fmi2GetReal of the unknown; Continuous-Time Mode:
fmi2SetContinuousStates).
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from conftest import SCENES
from fmi_helpers import Model, Slave
from gyrowheel.fmu_build import build_fmu, load_scene
from gyrowheel.fmu_build.builder import model_spec
from gyrowheel.fmu_build.model_description import write_model_description
from gyrowheel.fmu_build.variables import build_table


@pytest.fixture(scope="module")
def disk_fmu(example_build):
    return example_build("euler_disk").fmu


@pytest.fixture(scope="module")
def rest_fmu(tmp_path_factory):
    """A wheel at rest (no spin) with air drag and contact forces: drag_force and the tangential
    contact force are magnitudes of vectors that are 0 at the start."""
    from gyrowheel.fmu_build.scene import parse_scene
    text = ('[model]\nname = "drag_at_rest"\n[effects.gravity]\n[effects.air_drag]\nc_lin = 0.1\n'
            '[effects.contact_forces]\n[initial]\nbeta_deg = 80.0\ngamma_dot = 0.0\n')
    return build_fmu(parse_scene(text, "drag_at_rest.toml"),
                     tmp_path_factory.mktemp("rest_partials") / "drag_at_rest.fmu").fmu

@pytest.fixture(scope="module")
def mult_fmu(tmp_path_factory):
    """paper_earth in the multipliers formulation (outputs constraint_violation, lambda_x, lambda_y)."""
    from gyrowheel.fmu_build.scene import parse_scene
    text = (SCENES / "paper_earth.toml").read_text().replace('[model]\n', '[model]\nformulation = "multipliers"\n', 1)
    text = text.replace('name = "paper_earth"', 'name = "earth_multipliers"')
    scene = parse_scene(text, "earth_multipliers.toml")
    assert scene.formulation == "multipliers"
    return build_fmu(scene, tmp_path_factory.mktemp("mult_partials") / "earth_multipliers.fmu").fmu


def _structure(md_xml: str):
    """{list name: [(unknown index, [dependency indices])]} and the variables, 1-based."""
    root = ET.fromstring(md_xml)
    variables = [None] + list(root.find("ModelVariables"))
    out = {}
    for name in ("Outputs", "Derivatives", "InitialUnknowns"):
        el = root.find(f"ModelStructure/{name}")
        out[name] = [(int(u.get("index")), [int(d) for d in u.get("dependencies", "").split()])
                     for u in (el if el is not None else [])]
    return out, variables


def _real_partials(inst, listname):
    """The advertised (unknown, known) pairs of a ModelStructure list with a Real unknown."""
    structure, _ = _structure(Path(inst.unzipdir, "modelDescription.xml").read_text())
    names = [None] + [v.name for v in inst.md.modelVariables]
    return [(names[u], names[d]) for u, deps in structure[listname] for d in deps
            if inst.vars[names[u]].type == "Real"]


def _mismatch(f, x0: float, d: float) -> tuple[float, float]:
    """Difference between d and central differences of f at x0, the best over step sizes 1e-4 ..
    1e-8 relative to x0 (truncation against cancellation: the disk's c_pivot is 5e-5, its
    derivatives are large), relative to the sensitivity's own scale max(1, |d|, |f(x0) / x0|)
    (a derivative that is 0 of a large f is measured against f's size); and that quotient."""
    scale = max(1.0, abs(d), abs(f(x0) / x0) if x0 != 0.0 else 0.0)
    best = (math.inf, math.nan)
    for rel in (1e-4, 1e-5, 1e-6, 1e-7, 1e-8):
        h = rel * abs(x0) if x0 != 0.0 else rel
        fd = (f(x0 + h) - f(x0 - h)) / (2 * h)
        best = min(best, (abs(d - fd) / max(scale, abs(fd)), fd))
    return best


@pytest.mark.parametrize("fixture", ["earth_fmu", "disk_fmu", "mult_fmu", "rest_fmu"])
def test_every_initial_unknown_partial_is_answered_and_right(fixture, request):
    fmu = request.getfixturevalue(fixture)
    s = Slave(fmu)
    try:
        s.slave.setupExperiment(startTime=0.0)
        s.slave.enterInitializationMode()
        pairs = _real_partials(s, "InitialUnknowns")
        worst = 0.0
        for unknown, known in pairs:
            d = s.slave.getDirectionalDerivative([s.vr(unknown)], [s.vr(known)], [1.0])[0]
            x0 = s.get(known)

            def value(x, known=known, unknown=unknown):
                s.set(**{known: x})
                return s.get(unknown)
            err, fd = _mismatch(value, x0, d)
            s.set(**{known: x0})
            if err >= worst:
                worst, where = err, (unknown, known, d, fd)
        print(f"{Path(fmu).stem}: {len(pairs)} InitialUnknown partials, worst vs central "
              f"differences {worst:.2g} at {where}")
        assert worst < 1e-5  # central differences resolve ~1e-5 where large terms cancel
        assert s.messages == [] or all(st < 2 for st, _, _ in s.messages)
        if Path(fmu).stem == "paper_earth":
            # the simplified right-hand side (cyclic alpha dropped, M cancelled, R only with g,
            # beta_ddot free of beta_dot) has no other dependencies: the 9 partials a fuller
            # form would list are exactly 0 (test_unadvertised_initial_partials_are_zero)
            assert len(pairs) == 58
            assert sum(k in ("M", "R", "k_diam", "k_axial", "g") for _, k in pairs) == 18
        s.slave.exitInitializationMode()
    finally:
        s.free()


def test_unadvertised_initial_partials_are_zero(earth_fmu):
    """The other side of completeness: every (InitialUnknown, Real known) pair that modelDescription
    does not list has a zero partial by central differences of the FMU (so the simplified RHS,
    which dropped alpha, M and some R and beta_dot dependencies, dropped only true zeros)."""
    s = Slave(earth_fmu)
    try:
        s.slave.setupExperiment(startTime=0.0)
        s.slave.enterInitializationMode()
        structure, variables = _structure(Path(s.unzipdir, "modelDescription.xml").read_text())
        names = [None] + [v.name for v in s.md.modelVariables]
        knowns = [v.name for v in s.md.modelVariables if v.type == "Real" and v.initial == "exact"
                  and v.causality in ("parameter", "input", "output")
                  and v.name not in ("rel_tol", "abs_tol", "max_step")]
        checked, worst = 0, 0.0
        for u, deps in structure["InitialUnknowns"]:
            unknown = names[u]
            if s.vars[unknown].type != "Real":
                continue
            listed = {names[d] for d in deps}
            for known in knowns:
                if known in listed:
                    continue
                x0 = s.get(known)

                def value(x, known=known, unknown=unknown):
                    s.set(**{known: x})
                    return s.get(unknown)
                err, fd = _mismatch(value, x0, 0.0)
                s.set(**{known: x0})
                worst = max(worst, err)
                checked += 1
        print(f"paper_earth: {checked} unadvertised InitialUnknown partials, largest {worst:.2g}")
        assert checked > 100 and worst < 1e-9
    finally:
        s.free()


@pytest.mark.parametrize("scene,fixture", [("paper_earth", "earth_fmu"), ("euler_disk", "disk_fmu")])
def test_initial_partials_equal_casadis_jacobian(scene, fixture, request):
    """Exact: the FMU's answers in Initialization Mode equal CasADi's Jacobian of the
    InitialUnknowns at x = init(s, p), evaluated in Python (rel 1e-12)."""
    from gyrowheel.fmu_build.codegen import init_jacobian, initial_unknowns
    fmu = request.getfixturevalue(fixture)
    sc = load_scene(SCENES / f"{scene}.toml")
    spec = model_spec(sc)
    table = build_table(spec, sc.experiment, sc.outputs)
    rows = initial_unknowns(table)
    s0 = [q.start for q in spec.starts]
    p0 = [q.start for q in spec.parameters]
    D = np.array(init_jacobian(spec, table)(0.0, s0, [q.start for q in spec.inputs], p0))
    knowns = [v for v in table if v.kind in ("start", "param", "input") and v.type == "Real"]
    col = {v.name: (v.index if v.kind == "start" else len(s0) + v.index if v.kind == "param"
                    else len(s0) + len(p0) + v.index) for v in knowns}
    s = Slave(fmu)
    try:
        s.slave.setupExperiment(startTime=0.0)
        s.slave.enterInitializationMode()
        for i, v in enumerate(rows):
            got = s.slave.getDirectionalDerivative([v.vr] * len(knowns), [k.vr for k in knowns], [1.0] * len(knowns))
            assert got[0] == pytest.approx(float(D[i].sum()), rel=1e-12, abs=1e-12), v.name
            for k in knowns:
                d = s.slave.getDirectionalDerivative([v.vr], [k.vr], [1.0])[0]
                assert d == pytest.approx(float(D[i, col[k.name]]), rel=1e-12, abs=1e-14), (v.name, k.name)
    finally:
        s.free()


def test_dz_dR_is_sin_beta(earth_fmu):
    """z = R sin(beta): in Initialization Mode d z / d R = sin(beta), d z / d beta = R cos(beta)."""
    s = Slave(earth_fmu)
    try:
        s.slave.setupExperiment(startTime=0.0)
        s.set(beta=1.1, R=0.3)
        s.slave.enterInitializationMode()
        z = s.vr("z")
        assert s.slave.getDirectionalDerivative([z], [s.vr("R")], [1.0]) == [math.sin(1.1)]
        assert s.slave.getDirectionalDerivative([z], [s.vr("beta")], [1.0])[0] == pytest.approx(
            0.3 * math.cos(1.1), rel=1e-15)
        # a combined seed is the linear combination; settings are knowns nothing depends on
        r = s.slave.getDirectionalDerivative([z], [s.vr("R"), s.vr("beta"), s.vr("rel_tol")],
                                             [2.0, -1.0, 5.0])[0]
        assert r == pytest.approx(2 * math.sin(1.1) - 0.3 * math.cos(1.1), rel=1e-15)
        s.slave.exitInitializationMode()
        # after initialisation parameters are no knowns (FMI 2.0.4 section 2.2.8): refused
        with pytest.raises(Exception):
            s.slave.getDirectionalDerivative([z], [s.vr("R")], [1.0])
        assert "parameters are knowns only in Initialization Mode" in s.log_text()
    finally:
        s.free()


@pytest.mark.parametrize("fixture", ["earth_fmu", "disk_fmu", "mult_fmu"])
def test_every_output_and_derivative_partial_in_continuous_time_mode(fixture, request):
    fmu = request.getfixturevalue(fixture)
    m = Model(fmu)
    try:
        m.init()
        m.fmu2.newDiscreteStates()
        m.fmu2.enterContinuousTimeMode()
        x0 = m.states() * (1 + 1e-3) + 1e-3
        m.set_states(0.1, x0)
        state_names = [v.variable.derivative.name for v in m.md.derivatives]
        index = {n: i for i, n in enumerate(state_names)}
        pairs = _real_partials(m, "Outputs") + _real_partials(m, "Derivatives")
        worst = 0.0
        for unknown, known in pairs:
            d = m.fmu2.getDirectionalDerivative([m.vr(unknown)], [m.vr(known)], [1.0])[0]
            j = index[known]

            def value(xj, j=j, unknown=unknown):
                x = x0.copy()
                x[j] = xj
                m.set_states(0.1, x)
                return m.get(unknown)
            err, _ = _mismatch(value, x0[j], d)
            m.set_states(0.1, x0)
            worst = max(worst, err)
        print(f"{Path(fmu).stem}: {len(pairs)} Outputs/Derivatives partials, worst {worst:.2g}")
        # paper_earth: 52 before the simplified RHS (alpha, and beta_dot in der(beta_dot), dropped)
        assert len(pairs) == 48 if Path(fmu).stem == "paper_earth" else len(pairs) > 50
        assert worst < 1e-6
    finally:
        m.free()


def test_constraint_violation_partials_at_the_start_are_zero(mult_fmu):
    """Multipliers formulation: the initial state lies on the constraint manifold for every start
    value and parameter (x = init(s, p) builds the speeds from the null space), so
    constraint_violation = |A(q) q_dot| is identically 0 there and its partials in
    Initialization Mode are exactly 0. They must not come from norm_2's derivative v / |v|, 0/0
    at v = 0: one NaN entry would refuse every partial of the model (134 advertised, all
    fmi2Error: "partial derivative (4, 2) is not finite"). After a step the violation is > 0
    and its partials are the smooth ones."""
    s = Slave(mult_fmu)
    try:
        s.slave.setupExperiment(startTime=0.0)
        s.slave.enterInitializationMode()
        cv = s.vr("constraint_violation")
        knowns = ["alpha", "beta", "alpha_dot", "beta_dot", "gamma_dot", "M", "R", "g", "k_diam", "k_axial"]
        assert s.get("constraint_violation") == 0.0
        assert [s.slave.getDirectionalDerivative([cv], [s.vr(k)], [1.0])[0] for k in knowns] == [0.0] * 10
        s.slave.exitInitializationMode()
        s.slave.doStep(0.0, 1.0)
        assert 0.0 < s.get("constraint_violation") < 1e-6  # the stabilised drift
        assert math.isfinite(s.slave.getDirectionalDerivative([cv], [s.vr("beta")], [1.0])[0])
        assert [m for m in s.messages if m[0] >= 2] == []
    finally:
        s.free()


def test_magnitudes_of_zero_vectors_have_partials_at_rest(rest_fmu):
    """At rest the drag force F = -(c_lin + ...) v is 0 for every drag parameter, so
    d drag_force / d (c_lin, rho_air, cd_area) = 0 exactly; with respect to a rate the magnitude
    has a symmetric kink, answered 0 like fabs (sign(0) = 0) and like central differences, not
    norm_2's 0/0: one NaN entry would refuse every partial of the model in Initialization Mode."""
    s = Slave(rest_fmu)
    try:
        s.slave.setupExperiment(startTime=0.0)
        s.slave.enterInitializationMode()
        assert s.get("drag_force") == 0.0
        f = s.vr("drag_force")
        for k in ("c_lin", "rho_air", "cd_area", "gamma_dot", "alpha_dot"):
            assert s.slave.getDirectionalDerivative([f], [s.vr(k)], [1.0]) == [0.0], k
        s.slave.exitInitializationMode()
        s.slave.doStep(0.0, 0.05)  # falling: v > 0, the smooth partials
        assert s.get("drag_force") > 0.0
        d = s.slave.getDirectionalDerivative([f, s.vr("friction_use")], [s.vr("beta_dot")], [1.0])
        assert all(math.isfinite(x) for x in d) and d[0] != 0.0
        assert [m for m in s.messages if m[0] >= 2] == []
    finally:
        s.free()


def test_co_simulation_answers_what_model_exchange_answers(earth_fmu):
    """At a communication point the same partials (outputs and derivatives w.r.t. states)."""
    s, m = Slave(earth_fmu), Model(earth_fmu)
    try:
        s.init()
        m.init()
        unknowns = [s.vr(n) for n in ("z", "vx", "energy", "der(beta_dot)")]
        knowns = [s.vr(n) for n in ("beta", "gamma_dot", "alpha_dot")]
        seed = [0.3, -1.0, 2.0]
        assert (s.slave.getDirectionalDerivative(unknowns, knowns, seed) ==
                m.fmu2.getDirectionalDerivative(unknowns, knowns, seed))
    finally:
        s.free()
        m.free()


@pytest.mark.parametrize("scene", sorted(p.stem for p in SCENES.glob("*.toml")))
def test_dependencies_sorted_unique_and_of_the_right_knowns(scene):
    sc = load_scene(SCENES / f"{scene}.toml")
    spec = model_spec(sc)
    table = build_table(spec, sc.experiment, sc.outputs)
    xml = write_model_description(spec.name, sc.experiment, table, spec.name, "{g}", ["gw_fmu.c"], "",
                                  model_exchange=True, directional=True)
    structure, variables = _structure(xml)
    root = ET.fromstring(xml)
    assert float(root.find("DefaultExperiment").get("tolerance")) == sc.experiment.rel_tol
    states = {int(e.get("derivative")) for sv in variables[1:] for e in sv if e.get("derivative")}
    for name, unknowns in structure.items():
        for index, deps in unknowns:
            assert deps == sorted(set(deps)), f"{scene} {name} {index}: {deps}"
            for d in deps:
                v = variables[d]
                if name == "InitialUnknowns":  # knowns: initial = "exact" or inputs
                    assert v.get("initial") == "exact" or v.get("causality") == "input", (index, d)
                else:  # knowns: continuous states or inputs
                    assert d in states or v.get("causality") == "input", (index, d)
