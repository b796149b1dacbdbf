"""FMI 3.0 array variables (FMI 3.0.2 section 2.4.7.2): x_state, the continuous state vector, and
contact_force, [F_long, F_lat, F_n], beside the scalar variables they are made of.

  test_array_variables_in_model_description   one <Dimension> each, value references after the
                                  event indicators, fmpy.validate_fmu clean, ModelStructure
                                  dependencies the union of the elements' scalar variables'
  test_array_elements_are_the_scalars_in_co_simulation   along a run through a stiction mode
                                  switch, every element of one fmi3GetFloat64 is bit for bit the
                                  scalar it stands for
  test_array_elements_are_the_scalars_in_model_exchange  x_state is fmi3GetContinuousStates'
                                  states, contact_force the scalars, bit for bit
  test_simulate_fmu_records_the_arrays   fmpy.simulate_fmu (CS and ME) records the arrays; each
                                  column equals the scalar's
  test_array_misuse_refused       nValues, nSeed or nSensitivity not the sum of the sizes,
                                  fmi3SetFloat64, another type's getter, an output as a known:
                                  fmi3Error, reason logged
  test_array_partial_derivatives_are_the_scalars   directional and adjoint derivatives with the
                                  arrays among the unknowns and knowns: the scalars' bit for bit,
                                  v'(J w) = (v'J) w, in Initialization Mode and after it
  test_contact_force_only_with_its_scalars   [outputs] keep without F_n: no contact_force
  test_fmi2_fmu_has_no_arrays     the FMI 2 FMU of the scene: scalars only, GW_MODEL without arrays
  test_build_without_arrays       build(arrays=False): the FMU without them, valid; [build] arrays =
                                  false and --no-arrays reach the builder as False
  test_fmi2_build_refuses_leaving_out_arrays   arrays=False, --no-arrays, [build] arrays = false
                                  with FMI 2: refused in one line naming the argument or the key
  test_info_shows_the_array_sizes   gyrowheel info: x_state[n], contact_force[3]
"""
from __future__ import annotations

import contextlib
import ctypes as C
import re
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from fmi3_helpers import ERROR, OK, Model3, Slave3
from gyrowheel.fmu_build.variables import CONTACT_FORCE

SCENE = "slope_hold"  # contact_forces, and a stiction mode switch at t = 2.11 s


@pytest.fixture(scope="module")
def fmu3(example_build):
    return example_build(SCENE, fmi=3)


def _root(fmu) -> ET.Element:
    with zipfile.ZipFile(fmu) as zf:
        return ET.fromstring(zf.read("modelDescription.xml"))


def _state_vrs(inst) -> list[int]:
    """The scalar variables of the continuous states, in state order (ContinuousStateDerivative's
    order, each derivative naming its state)."""
    return [d.variable.derivative.valueReference for d in inst.md.derivatives]


def _arrays_and_scalars(inst) -> tuple[list[int], int, list[int]]:
    """value references [x_state, contact_force], the number of their values, and the scalars
    their elements stand for, in the same order"""
    scalars = _state_vrs(inst) + [inst.vr(n) for n in CONTACT_FORCE]
    return [inst.vr("x_state"), inst.vr("contact_force")], len(scalars), scalars


def test_array_variables_in_model_description(fmu3):
    assert validate_fmu(str(fmu3.fmu)) == []
    root = _root(fmu3.fmu)
    mvs = list(root.find("ModelVariables"))
    by_name = {e.get("name"): e for e in mvs}
    nx = len(root.findall("ModelStructure/ContinuousStateDerivative"))
    indicator_vrs = [int(e.get("valueReference")) for e in root.findall("ModelStructure/EventIndicator")]
    for name, n in (("x_state", nx), ("contact_force", 3)):
        e = by_name[name]
        assert e.tag == "Float64" and e.get("causality") == "output" and e.get("variability") == "continuous"
        assert [d.get("start") for d in e.findall("Dimension")] == [str(n)]
        assert int(e.get("valueReference")) > max(indicator_vrs)
    assert by_name["contact_force"].get("unit") == "N"
    # the scalars stay, without a dimension
    assert all(by_name[n].find("Dimension") is None for n in CONTACT_FORCE)

    def deps(kind: str, vr: str) -> set[str]:
        (u,) = [u for u in root.findall(f"ModelStructure/{kind}") if u.get("valueReference") == vr]
        return set(u.get("dependencies", "").split())

    outputs = {u.get("valueReference") for u in root.findall("ModelStructure/Output")}
    initial = {u.get("valueReference") for u in root.findall("ModelStructure/InitialUnknown")}
    states = {d.get("derivative") for d in mvs if d.get("derivative")}
    x_vr, f_vr = by_name["x_state"].get("valueReference"), by_name["contact_force"].get("valueReference")
    assert {x_vr, f_vr} <= outputs and {x_vr, f_vr} <= initial
    assert deps("Output", x_vr) == states  # the states are the knowns it is
    scalar_vrs = [by_name[n].get("valueReference") for n in CONTACT_FORCE]
    assert deps("Output", f_vr) == set().union(*(deps("Output", v) for v in scalar_vrs))
    assert deps("InitialUnknown", f_vr) == set().union(*(deps("InitialUnknown", v) for v in scalar_vrs))


def _same_bits(a, b) -> bool:
    return np.array_equal(np.asarray(a, dtype=float).view(np.int64), np.asarray(b, dtype=float).view(np.int64))


def test_array_elements_are_the_scalars_in_co_simulation(fmu3):
    inst = Slave3(fmu3.fmu)
    arrays, n, scalars = _arrays_and_scalars(inst)
    inst.init()
    t, checked = 0.0, 0
    while t < 3.0:  # through the mode switch (rolling_stiction) at 2.11 s
        status, _, terminate, _, _ = inst.do_step(t, 0.25)
        assert status == OK and not terminate
        t += 0.25
        # one call: both arrays, then every scalar (values concatenated, section 2.2.7.1)
        values = inst.fmu3.getFloat64(arrays + scalars, nValues=2 * n)
        assert _same_bits(values[:n], values[n:]), t
        checked += 1
    assert checked == 12 and inst.get("rolling_mode") == 0.0  # stopped and held
    assert inst.messages == [] or all(s == OK for s, _, _ in inst.messages)


def test_array_elements_are_the_scalars_in_model_exchange(fmu3):
    inst = Model3(fmu3.fmu)
    arrays, n, scalars = _arrays_and_scalars(inst)
    nx = inst.nx
    inst.fmu3.enterInitializationMode(startTime=0.0)
    inst.fmu3.exitInitializationMode()
    inst.fmu3.updateDiscreteStates()
    inst.fmu3.enterContinuousTimeMode()
    x, dx = (C.c_double * nx)(), (C.c_double * nx)()
    for k in range(1, 6):  # explicit Euler, h = 0.01: states the importer sets
        inst.fmu3.getContinuousStates(x, nx)
        inst.fmu3.getContinuousStateDerivatives(dx, nx)
        inst.fmu3.setTime(0.01 * k)
        new = (C.c_double * nx)(*[x[i] + 0.01 * dx[i] for i in range(nx)])
        inst.fmu3.setContinuousStates(new, nx)
        values = inst.fmu3.getFloat64(arrays + scalars, nValues=2 * n)
        assert _same_bits(values[:nx], list(new)), k
        assert _same_bits(values[:n], values[n:]), k


@pytest.mark.parametrize("fmi_type", ["CoSimulation", "ModelExchange"])
def test_simulate_fmu_records_the_arrays(fmu3, fmi_type):
    inst = Slave3(fmu3.fmu)
    state_names = [inst.md.modelVariables[[v.valueReference for v in inst.md.modelVariables].index(vr)].name
                   for vr in _state_vrs(inst)]
    inst.free()
    res = simulate_fmu(str(fmu3.fmu), fmi_type=fmi_type, stop_time=1.0, output_interval=0.1,
                       output=["x_state", "contact_force", *state_names, *CONTACT_FORCE])
    assert res["x_state"].shape == (len(res), len(state_names)) and res["contact_force"].shape == (len(res), 3)
    assert _same_bits(res["x_state"], np.column_stack([res[n] for n in state_names]))
    assert _same_bits(res["contact_force"], np.column_stack([res[n] for n in CONTACT_FORCE]))
    assert np.all(res["contact_force"][:, 2] > 0)  # the wheel stands on the ground: F_n = M g cos(slope) > 0


def test_array_misuse_refused(fmu3):
    inst = Slave3(fmu3.fmu)
    arrays, n, _ = _arrays_and_scalars(inst)
    inst.init()
    x_vr = inst.vr("x_state")
    nx = n - 3
    buf = (C.c_double * (n + 1))()

    def get(vrs, n_values):
        inst.messages.clear()
        return inst.raw("fmi3GetFloat64", (C.c_uint32 * len(vrs))(*vrs), len(vrs), buf, n_values)

    assert get(arrays, n) == OK
    for wrong in (2, n - 1, n + 1):  # one value per reference; one short; one too many
        assert get(arrays, wrong) == ERROR
        assert f"fmi3GetFloat64: nValues = {wrong}, but the referenced variables' sizes sum to {n} (2 value references" \
            in inst.log_text()
        inst.instantiate()
        inst.init()
    assert get([x_vr, 0], nx + 1) == OK and buf[nx] == 0.0  # an array, then time
    inst.messages.clear()
    vals = (C.c_double * nx)(*([0.0] * nx))
    assert inst.raw("fmi3SetFloat64", (C.c_uint32 * 1)(x_vr), 1, vals, nx) == ERROR
    assert f"fmi3SetFloat64: variable x_state (vr={x_vr}) is read-only" in inst.log_text()
    inst.instantiate()
    inst.init()
    inst.messages.clear()
    ints = (C.c_int64 * nx)()
    assert inst.raw("fmi3GetInt64", (C.c_uint32 * 1)(x_vr), 1, ints, 1) == ERROR
    assert f"fmi3GetInt64: value reference {x_vr} (x_state) is a Float64 array variable" in inst.log_text()
    inst.instantiate()
    inst.init()
    inst.messages.clear()  # the type named first, whatever nValues (the array's size here)
    flags = (C.c_bool * nx)()
    assert inst.raw("fmi3GetBoolean", (C.c_uint32 * 1)(x_vr), 1, flags, nx) == ERROR
    assert f"fmi3GetBoolean: value reference {x_vr} (x_state) is a Float64 array variable" in inst.log_text()
    inst.instantiate()
    inst.init()
    inst.messages.clear()
    # a derivative's seed and sensitivity count values too: nx for x_state, not 1
    seed, sens = (C.c_double * 1)(1.0), (C.c_double * nx)()
    unknowns, knowns = (C.c_uint32 * 1)(x_vr), (C.c_uint32 * 1)(_state_vrs(inst)[0])
    assert inst.raw("fmi3GetDirectionalDerivative", unknowns, 1, knowns, 1, seed, 1, sens, 1) == ERROR
    assert (f"fmi3GetDirectionalDerivative: nSensitivity = 1, but the unknowns have {nx} values"
            in inst.log_text())
    inst.instantiate()
    inst.init()
    inst.messages.clear()
    assert inst.raw("fmi3GetAdjointDerivative", unknowns, 1, knowns, 1, seed, 1, sens, 1) == ERROR
    assert f"fmi3GetAdjointDerivative: nSeed = 1, but the unknowns have {nx} values" in inst.log_text()
    # contact_force's elements are outputs: no knowns
    inst.instantiate()
    inst.init()
    inst.messages.clear()
    seed3 = (C.c_double * 3)(1.0, 1.0, 1.0)
    f_vr = (C.c_uint32 * 1)(inst.vr("contact_force"))
    assert inst.raw("fmi3GetDirectionalDerivative", unknowns, 1, f_vr, 1, seed3, 3, sens, nx) == ERROR
    assert "fmi3GetDirectionalDerivative: known F_long" in inst.log_text()


def _partials_agree(inst, arrays: list[int], scalars: list[int], knowns: list[int], known_scalars: list[int],
                    rng) -> float:
    """The directional and adjoint derivatives of `arrays` w.r.t. `knowns` (either list mixing array
    and scalar value references) are those of the scalars they stand for, bit for bit, for random
    seeds; returns the worst |v'(J w) - (v'J) w| / (|v|' |J| |w|) of the array calls."""
    f = inst.fmu3
    n, m = len(scalars), len(known_scalars)
    worst = 0.0
    for _ in range(3):
        v, w = rng.standard_normal(n), rng.standard_normal(m)
        jw = f.getDirectionalDerivative(arrays, knowns, list(w), nSensitivity=n)
        assert _same_bits(jw, f.getDirectionalDerivative(scalars, known_scalars, list(w)))
        vj = f.getAdjointDerivative(arrays, knowns, list(v), nSensitivity=m)
        assert _same_bits(vj, f.getAdjointDerivative(scalars, known_scalars, list(v), nSensitivity=m))
        J = np.array([f.getDirectionalDerivative(scalars, known_scalars, list(e)) for e in np.eye(m)]).T
        assert np.any(J != 0)
        worst = max(worst, abs(v @ np.array(jw) - np.array(vj) @ w) / (np.abs(v) @ np.abs(J) @ np.abs(w)))
    return worst


def _dependencies(fmu, kind: str, vrs: list[int]) -> list[int]:
    """The union of the ModelStructure dependencies of `kind` (Output, InitialUnknown) of vrs"""
    root = _root(fmu)
    deps = {int(d) for u in root.findall(f"ModelStructure/{kind}") if int(u.get("valueReference")) in vrs
            for d in u.get("dependencies", "").split()}
    return sorted(deps)


@pytest.mark.parametrize("interface", ["CS", "ME"])
def test_array_partial_derivatives_are_the_scalars(fmu3, interface):
    """fmi3GetDirectionalDerivative and fmi3GetAdjointDerivative of x_state and contact_force, as
    unknowns (and x_state as a known: its elements are the states), element by element: the
    seeds and sensitivities serialized as the values are (FMI 3.0.2 section 2.2.12), in
    Initialization Mode (the InitialUnknowns' dependencies) and after it (the Outputs')."""
    inst = (Slave3 if interface == "CS" else Model3)(fmu3.fmu)
    arrays, _, scalars = _arrays_and_scalars(inst)
    rng = np.random.default_rng(7)
    f_n = inst.vr("F_n")
    # mixed: a scalar, both arrays, the scalar again
    unknowns, unknown_scalars = [f_n, *arrays, f_n], [f_n, *scalars, f_n]
    inst.fmu3.enterInitializationMode(startTime=0.0)
    knowns = _dependencies(fmu3.fmu, "InitialUnknown", arrays)
    assert len(knowns) > 3
    init_worst = _partials_agree(inst, unknowns, unknown_scalars, knowns, knowns, rng)
    inst.fmu3.exitInitializationMode()
    if interface == "ME":
        inst.fmu3.updateDiscreteStates()
        inst.fmu3.enterContinuousTimeMode()
    states = _state_vrs(inst)
    inputs = [k for k in _dependencies(fmu3.fmu, "Output", arrays) if k not in states]
    assert set(_dependencies(fmu3.fmu, "Output", arrays)) >= set(states)
    worst = _partials_agree(inst, unknowns, unknown_scalars, [inst.vr("x_state"), *inputs], states + inputs, rng)
    print(f"{interface}: v'(Jw) vs (v'J)w {init_worst:.2g} (Initialization Mode), {worst:.2g} (after)")
    assert init_worst < 1e-15 and worst < 1e-15
    assert [m for m in inst.messages if m[0] > OK] == []
    inst.free()


def test_contact_force_only_with_its_scalars(fmu3):
    """contact_force is there when the FMU has F_long, F_lat and F_n: its partial derivatives are
    theirs. [outputs] keep leaving one out leaves the array out (x_state stays: states always are
    variables)."""
    from gyrowheel.fmu_build.scene import Experiment
    from gyrowheel.fmu_build.variables import build_table

    def arrays(keep):
        return [v.name for v in build_table(fmu3.spec, Experiment(), keep, fmi=3) if v.kind == "array"]
    assert arrays(None) == arrays(list(CONTACT_FORCE)) == ["x_state", "contact_force"]
    assert arrays(list(CONTACT_FORCE[:2])) == ["x_state"]


def test_fmi2_fmu_has_no_arrays(example_build):
    built = example_build(SCENE)
    names = {e.get("name") for e in _root(built.fmu).iter("ScalarVariable")}
    assert "F_n" in names and not names & {"x_state", "contact_force"}
    assert "arrays" not in (built.sources / "model_desc.c").read_text()  # GW_MODEL as before


def test_build_without_arrays(example_build, tmp_path, monkeypatch):
    """[build] arrays = false, build(arrays=False), --no-arrays: the FMU without the arrays,
    everything else as with them"""
    from conftest import SCENES
    from gyrowheel import api
    from gyrowheel.cli import main
    from gyrowheel.fmu_build import builder

    scene = SCENES / f"{SCENE}.toml"
    with3 = {e.get("name") for e in _root(example_build(SCENE, fmi=3).fmu).find("ModelVariables")}
    root = _root(api.build(scene, tmp_path / "api.fmu", fmi=3, arrays=False).fmu)
    assert {e.get("name") for e in root.find("ModelVariables")} == with3 - {"x_state", "contact_force"}
    assert root.find(".//Dimension") is None and validate_fmu(str(tmp_path / "api.fmu")) == []
    # the scene key and the command line reach the same argument (stopped there: no second build)
    seen = []

    def stop(*args, **kw):
        seen.append(kw["arrays"])
        raise RuntimeError("stop")
    monkeypatch.setattr(builder, "build_spec_fmu", stop)
    keyed = tmp_path / "keyed.toml"
    keyed.write_text(scene.read_text() + "\n[build]\nfmi = 3\narrays = false\n")
    for call in (lambda: api.build(keyed, tmp_path / "k.fmu"),
                 lambda: main(["build", str(scene), "--fmi", "3", "--no-arrays", "-o", str(tmp_path / "c.fmu")]),
                 lambda: api.build(scene, tmp_path / "d.fmu", fmi=3)):
        with contextlib.suppress(RuntimeError):  # (the command line reports it and returns 1)
            call()
    assert seen == [False, False, True]


def test_fmi2_build_refuses_leaving_out_arrays(tmp_path, capsys):
    """An FMI 2 FMU has no arrays to leave out: refused before anything is built."""
    from conftest import SCENES
    from gyrowheel import ArgumentError, SceneError, api
    from gyrowheel.cli import main

    scene = SCENES / f"{SCENE}.toml"
    with pytest.raises(ArgumentError) as exc:
        api.build(scene, tmp_path / "a.fmu", fmi=2, arrays=False)
    assert exc.value.argument == "arrays" and "\n" not in str(exc.value)
    assert str(exc.value) == "arrays: leaving out the array outputs is for FMI 3 FMUs; an FMI 2 FMU has none"
    keyed = tmp_path / "keyed.toml"
    keyed.write_text(scene.read_text() + "\n[build]\narrays = false\n")  # FMI 2, the default
    with pytest.raises(SceneError, match=rf"^{re.escape(str(keyed))}: \[build\] arrays: false leaves out an FMI 3 "
                                         rf"FMU's array outputs; an FMI 2 FMU has none: [^\n]*$"):
        api.build(keyed, tmp_path / "k.fmu")
    with pytest.raises(SceneError, match=r"\[build\] arrays.*: build FMI 3 \(\[build\] fmi = 3\) or remove the key$"):
        api.build(keyed, tmp_path / "k.fmu", fmi=2)
    fmi3_keyed = tmp_path / "fmi3_keyed.toml"  # the scene asks for FMI 3, the call overrides it
    fmi3_keyed.write_text(scene.read_text() + "\n[build]\nfmi = 3\narrays = false\n")
    with pytest.raises(SceneError, match=r"fmi 2 was asked for \(the --fmi option, the fmi argument\) over the "
                                         r"scene's \[build\] fmi = 3: ask for FMI 3 or remove the key$"):
        api.build(fmi3_keyed, tmp_path / "k.fmu", fmi=2)
    assert main(["build", str(scene), "--fmi", "2", "--no-arrays", "-o", str(tmp_path / "c.fmu")]) == 2
    assert capsys.readouterr().err == ("gyrowheel: error: --no-arrays: leaving out the array outputs is for FMI 3 "
                                       "FMUs; an FMI 2 FMU has none\n")
    assert not any(tmp_path.glob("*.fmu"))


def test_info_shows_the_array_sizes(fmu3, capsys):
    """gyrowheel.info gives an array's dimensions; `gyrowheel info` prints them after its name."""
    import gyrowheel
    from gyrowheel.cli import main

    info = {v.name: v for v in gyrowheel.info(fmu3.fmu).variables}
    assert info["x_state"].dimensions == (fmu3.spec.x.numel(),) and info["contact_force"].dimensions == (3,)
    assert info["beta"].dimensions == ()
    assert main(["info", str(fmu3.fmu)]) == 0
    out = capsys.readouterr().out
    assert f"x_state[{fmu3.spec.x.numel()}] " in out and "contact_force[3] " in out
