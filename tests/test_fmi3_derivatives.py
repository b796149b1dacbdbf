"""fmi3GetDirectionalDerivative (J w) and fmi3GetAdjointDerivative (v' J) of the paper_earth FMI 3.0
FMU, Model Exchange and Co-Simulation instances, for every dependency its ModelStructure
advertises (FMI 3.0.2 section 2.2.12): in Initialization Mode the InitialUnknowns, after it the
Outputs and ContinuousStateDerivatives.

Each partial is checked against central differences of the FMU's own values (Initialization Mode:
fmi3SetFloat64 of the known, fmi3GetFloat64 of the unknown; Continuous-Time Mode:
fmi3SetContinuousStates), against fmi2GetDirectionalDerivative of the FMI 2.0 FMU, and the two
functions against each other: v'(J w) == (v'J) w to rounding.  Event indicators are no unknowns
of these functions (2.2.12); their advertised dependencies are checked by differences alone.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from fmi3_helpers import Instance3
from fmi_helpers import Model, Slave
from test_fmi_partials import _mismatch


def structure(inst) -> dict[str, list[tuple[int, list[int]]]]:
    """{element: [(unknown value reference, [known value references])]} of the ModelStructure."""
    root = ET.fromstring(Path(inst.unzipdir, "modelDescription.xml").read_text())
    out: dict[str, list] = {}
    for el in root.find("ModelStructure"):
        out.setdefault(el.tag, []).append((int(el.get("valueReference")),
                                           [int(d) for d in el.get("dependencies", "").split()]))
    return out


def float_pairs(inst, *elements: str) -> list[tuple[int, int]]:
    """The advertised (unknown, known) pairs of the elements whose unknown is a scalar Float64 (the
    array outputs' partials are their elements': tests/test_fmi3_arrays.py)."""
    scalar = {v.valueReference for v in inst.md.modelVariables if v.type == "Float64" and not v.dimensions}
    s = structure(inst)
    return [(u, k) for e in elements for u, deps in s.get(e, []) for k in deps if u in scalar]


def name_of(inst, vr: int) -> str:
    return next(v.name for v in inst.md.modelVariables if v.valueReference == vr)


def adjoint_consistency(inst, unknowns: list[int], knowns: list[int], seed: int = 3) -> float:
    """|v'(J w) - (v'J) w| / (|v|' |J| |w|) for random v, w: both functions on the whole block."""
    rng = np.random.default_rng(seed)
    v, w = rng.standard_normal(len(unknowns)), rng.standard_normal(len(knowns))
    jw = np.array(inst.fmu3.getDirectionalDerivative(unknowns, knowns, list(w)))
    vj = np.array(inst.fmu3.getAdjointDerivative(unknowns, knowns, list(v), nSensitivity=len(knowns)))
    J = np.array([inst.fmu3.getDirectionalDerivative(unknowns, knowns, list(e)) for e in np.eye(len(knowns))]).T
    scale = np.abs(v) @ np.abs(J) @ np.abs(w)
    return abs(v @ jw - vj @ w) / scale


@pytest.fixture(scope="module")
def earth3(fmi3_build):
    return fmi3_build("paper_earth").fmu


@pytest.fixture(scope="module")
def earth2(example_build):
    return example_build("paper_earth").fmu


@pytest.mark.parametrize("interface", ["ME", "CS"])
def test_initial_unknown_partials(earth3, earth2, interface):
    f = Instance3(earth3, interface)
    s = Slave(earth2)
    try:
        f.fmu3.enterInitializationMode(startTime=0.0)
        s.slave.setupExperiment(startTime=0.0)
        s.slave.enterInitializationMode()
        pairs = float_pairs(f, "InitialUnknown")
        assert len(pairs) == 58  # as FMI 2.0's InitialUnknowns (tests/test_fmi_partials.py)
        worst_fd = worst_adj = 0.0
        for u, k in pairs:
            d = f.fmu3.getDirectionalDerivative([u], [k], [1.0])[0]
            a = f.fmu3.getAdjointDerivative([u], [k], [1.0], nSensitivity=1)[0]
            assert d == a == s.slave.getDirectionalDerivative([u], [k], [1.0])[0], (name_of(f, u), name_of(f, k))
            x0 = f.fmu3.getFloat64([k])[0]

            def value(x, u=u, k=k):
                f.fmu3.setFloat64([k], [x])
                return f.fmu3.getFloat64([u])[0]
            err, _ = _mismatch(value, x0, d)
            f.fmu3.setFloat64([k], [x0])
            worst_fd = max(worst_fd, err)
        unknowns = sorted({u for u, _ in pairs})
        knowns = sorted({k for _, k in pairs})
        worst_adj = max(adjoint_consistency(f, unknowns, knowns, seed) for seed in range(5))
        print(f"{interface} Initialization Mode: {len(pairs)} partials, worst vs central differences {worst_fd:.2g}, "
              f"v'(Jw) vs (v'J)w {worst_adj:.2g}")
        assert worst_fd < 1e-8  # measured 7.5e-11: the smooth paper wheel
        assert worst_adj < 1e-15
        f.fmu3.exitInitializationMode()
        assert [m for m in f.messages if m[0] > 0] == []
    finally:
        f.free()
        s.free()


def test_output_and_derivative_partials_in_continuous_time_mode(earth3, earth2):
    f = Instance3(earth3, "ME")
    m = Model(earth2)
    try:
        f.init()
        while f.fmu3.updateDiscreteStates()[0]:
            pass
        f.fmu3.enterContinuousTimeMode()
        m.init()
        m.fmu2.newDiscreteStates()
        m.fmu2.enterContinuousTimeMode()
        x0 = f.states() * (1 + 1e-3) + 1e-3
        f.set_states(0.1, x0)
        m.set_states(0.1, x0)
        state_vrs = [d.variable.derivative.valueReference for d in f.md.derivatives]
        pairs = float_pairs(f, "Output", "ContinuousStateDerivative")
        assert len(pairs) == 48  # as FMI 2.0's Outputs and Derivatives (tests/test_fmi_partials.py)
        worst_fd = 0.0
        for u, k in pairs:
            d = f.fmu3.getDirectionalDerivative([u], [k], [1.0])[0]
            a = f.fmu3.getAdjointDerivative([u], [k], [1.0], nSensitivity=1)[0]
            assert d == a == m.fmu2.getDirectionalDerivative([u], [k], [1.0])[0], (name_of(f, u), name_of(f, k))
            j = state_vrs.index(k)

            def value(xj, j=j, u=u):
                x = x0.copy()
                x[j] = xj
                f.set_states(0.1, x)
                return f.fmu3.getFloat64([u])[0]
            err, _ = _mismatch(value, x0[j], d)
            f.set_states(0.1, x0)
            worst_fd = max(worst_fd, err)
        unknowns = sorted({u for u, _ in pairs})
        worst_adj = max(adjoint_consistency(f, unknowns, state_vrs, seed) for seed in range(5))
        print(f"Continuous-Time Mode: {len(pairs)} partials, worst vs central differences {worst_fd:.2g}, "
              f"v'(Jw) vs (v'J)w {worst_adj:.2g}")
        assert worst_fd < 1e-8  # measured 2.3e-11
        assert worst_adj < 1e-15
        # the event indicator's advertised dependencies: exactly the states it changes with
        (z, deps), = structure(f)["EventIndicator"]
        for j, k in enumerate(state_vrs):
            def value(xj, j=j):
                x = x0.copy()
                x[j] = xj
                f.set_states(0.1, x)
                return f.fmu3.getFloat64([z])[0]
            h = 1e-6 * max(1.0, abs(x0[j]))
            fd = (value(x0[j] + h) - value(x0[j] - h)) / (2 * h)
            assert (abs(fd) > 1e-3) == (k in deps), (name_of(f, k), fd)
        f.set_states(0.1, x0)
        assert [msg for msg in f.messages if msg[0] > 0] == []
    finally:
        f.free()
        m.free()


def test_co_simulation_answers_what_model_exchange_answers_after_a_step(earth3, earth2):
    """In Step Mode, after a step, at the state the step reached: the same partials as a Model
    Exchange instance set to that state, and as the FMI 2.0 Co-Simulation instance."""
    f, me = Instance3(earth3), Instance3(earth3, "ME", name="me")
    s = Slave(earth2)
    try:
        f.init()
        s.init()
        f.fmu3.doStep(0.0, 0.5)
        s.slave.doStep(0.0, 0.5)
        me.init()
        while me.fmu3.updateDiscreteStates()[0]:
            pass
        me.fmu3.enterContinuousTimeMode()
        states = [d.variable.derivative.name for d in f.md.derivatives]
        me.set_states(0.5, np.array(f.get(*states)))
        pairs = float_pairs(f, "Output", "ContinuousStateDerivative")
        unknowns = sorted({u for u, _ in pairs})
        knowns = sorted({k for _, k in pairs})
        rng = np.random.default_rng(1)
        for _ in range(3):
            w = list(rng.standard_normal(len(knowns)))
            v = list(rng.standard_normal(len(unknowns)))
            jw = f.fmu3.getDirectionalDerivative(unknowns, knowns, w)
            assert jw == me.fmu3.getDirectionalDerivative(unknowns, knowns, w)
            assert jw == s.slave.getDirectionalDerivative(unknowns, knowns, w)
            vj = f.fmu3.getAdjointDerivative(unknowns, knowns, v, nSensitivity=len(knowns))
            assert vj == me.fmu3.getAdjointDerivative(unknowns, knowns, v, nSensitivity=len(knowns))
        assert adjoint_consistency(f, unknowns, knowns) < 1e-15
    finally:
        f.free()
        me.free()
        s.free()
