"""The output contact_mode as an FMI Enumeration (type ContactMode: rolling 0, sliding 1, flight 2).

FMI 2.0.4 (sections 2.2.3, 2.2.7): a <SimpleType> with <Enumeration> items, the variable
<Enumeration declaredType="ContactMode"/>, causality output, variability discrete, read through
fmi2GetInteger; FMI 3.0.2 (sections 2.4.4, 2.4.7.6): an <EnumerationType>, the variable
<Enumeration>, read through fmi3GetInt64. Checked against what the model did not produce: fmpy's
schema validation, the drop's analytic times (fall sqrt(2 h / g), rest after the truncated
geometric series of the bounces), and the slip velocities the same run reports (the wheel slides
exactly while its contact point slips).
"""
from __future__ import annotations

import ctypes as C
import math

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

import gyrowheel
from fmi3_helpers import Slave3
from fmi_helpers import Slave, replayed
from paper_wheel import G

ITEMS = {"rolling": 0, "sliding": 1, "flight": 2}
TIGHT = {"rel_tol": 1e-12, "abs_tol": 1e-14}
H, E, IMPACTS = 0.1, 0.5, 10  # drop_bounce.toml: drop height, restitution; the 10th rebound rests


def drop_times() -> tuple[float, float]:
    """(first touchdown, rest) of the upright drop: t0 = sqrt(2 h / g), then 2 e^k v0 / g of flight
    after impact k = 1 .. IMPACTS - 1 (the IMPACTS-th rebound is below the rest speed)."""
    t0 = math.sqrt(2 * H / G)
    return t0, t0 + sum(2 * E ** k * t0 for k in range(1, IMPACTS + 1))


@pytest.mark.parametrize("fmi", [2, 3])
def test_contact_mode_is_an_enumeration_that_validates(example_build, fmi):
    fmu = str(example_build("drop_bounce", fmi=fmi).fmu)
    assert validate_fmu(fmu) == []
    md = read_model_description(fmu)
    v = next(v for v in md.modelVariables if v.name == "contact_mode")
    assert (v.type, v.causality, v.variability, v.initial) == ("Enumeration", "output", "discrete", "calculated")
    assert v.declaredType.name == "ContactMode"
    assert {i.name: int(i.value) for i in v.declaredType.items} == ITEMS
    assert gyrowheel.info(fmu).variable("contact_mode").items == ITEMS
    line = next(row for row in str(gyrowheel.info(fmu)).splitlines() if row.startswith("contact_mode "))
    assert line.split()[1:3] == ["output", "discrete"]  # the table of `gyrowheel info`


def test_a_sliding_only_scene_lists_no_flight(example_build):
    md = read_model_description(str(example_build("ice_slide").fmu))
    v = next(v for v in md.modelVariables if v.name == "contact_mode")
    assert {i.name: int(i.value) for i in v.declaredType.items} == {"rolling": 0, "sliding": 1}


def test_rolling_only_scenes_declare_no_contact_mode(example_build):
    md = read_model_description(str(example_build("paper_earth").fmu))
    assert [t.name for t in md.typeDefinitions] == ["Solver"]
    assert "contact_mode" not in {v.name for v in md.modelVariables}


@pytest.mark.parametrize("interface", ["CoSimulation", "ModelExchange"])
@pytest.mark.parametrize("fmi", [2, 3])
def test_fmpy_records_the_drops_flight_then_rolling(example_build, fmi, interface):
    """In flight from the release to the rest (the drop's analytic time), rolling after."""
    fmu = str(example_build("drop_bounce", fmi=fmi).fmu)
    extra = {"early_return_allowed": True} if fmi == 3 and interface == "CoSimulation" else {}
    r = simulate_fmu(fmu, fmi_type=interface, stop_time=0.6, output_interval=1e-3, output=["contact_mode", "height"],
                     start_values=TIGHT, **extra)
    mode, t = r["contact_mode"], r["time"]
    assert np.issubdtype(mode.dtype, np.integer)
    t0, rest = drop_times()
    assert np.all(mode[t < rest - 1e-4] == ITEMS["flight"])
    assert np.all(mode[t > rest + 1e-4] == ITEMS["rolling"])
    assert np.all(r["height"][t > rest + 1e-4] == 0)
    assert np.all(r["height"][(t > 0) & (t < t0 - 1e-4)] > 0)


@pytest.mark.parametrize("interface", ["CoSimulation", "ModelExchange"])
@pytest.mark.parametrize("fmi", [2, 3])
def test_fmpy_records_the_ice_slide_sliding_exactly_while_it_slips(example_build, fmi, interface):
    """ice_slide: sliding from the start, rolling for good after the slip died out (2.2055 s,
    docs/effects.md); at every recorded point the mode is sliding exactly where the contact point
    slips after the start (slip_long, slip_lat, the same run's other outputs)."""
    fmu = str(example_build("ice_slide", fmi=fmi).fmu)
    extra = {"early_return_allowed": True} if fmi == 3 and interface == "CoSimulation" else {}
    r = simulate_fmu(fmu, fmi_type=interface, stop_time=3.0, output_interval=0.01,
                     output=["contact_mode", "slip_long", "slip_lat"], **extra)
    mode, t = r["contact_mode"], r["time"]
    assert np.issubdtype(mode.dtype, np.integer)
    assert np.all(mode[t < 2.2] == ITEMS["sliding"]) and np.all(mode[t > 2.21] == ITEMS["rolling"])
    slipping = np.hypot(r["slip_long"], r["slip_lat"]) > 0
    # (at t = 0 the slip is 0: the wheel starts sliding because rolling needs more than mu F_n)
    assert np.array_equal(mode[1:] == ITEMS["sliding"], slipping[1:])


def test_gyrowheel_simulate_writes_the_mode_as_a_number(example_build, tmp_path):
    fmu = example_build("drop_bounce").fmu
    r = gyrowheel.simulate(fmu, stop_time=0.5, output_interval=0.01, output=tmp_path / "drop.csv")
    assert r["contact_mode"][0] == ITEMS["flight"] and r["contact_mode"][-1] == ITEMS["rolling"]
    table = np.genfromtxt(tmp_path / "drop.csv", delimiter=",", names=True)
    assert np.array_equal(table["contact_mode"], r["contact_mode"])


def _refused_fmi2(fmu: str, function: str, ctype) -> str:
    s = Slave(fmu)
    s.init(**TIGHT)
    vr = (C.c_uint * 1)(s.vr("contact_mode"))
    out = (ctype * 1)()
    status = s.raw(function, vr, C.c_size_t(1), out)
    text = s.log_text()
    s.free()
    assert status == 3, function  # fmi2Error
    return text


@pytest.mark.parametrize("function, ctype", [("fmi2GetReal", C.c_double), ("fmi2GetBoolean", C.c_int)])
def test_fmi2_refuses_the_mode_through_another_getter(example_build, function, ctype):
    fmu = str(example_build("drop_bounce").fmu)
    text = _refused_fmi2(fmu, function, ctype)
    assert "contact_mode" in text and "is of type Enumeration" in text


def test_fmi2_answers_the_mode_through_get_integer_only(example_build):
    s = Slave(str(example_build("drop_bounce").fmu))
    s.init(**TIGHT)
    assert s.fmu2.getInteger([s.vr("contact_mode")]) == [ITEMS["flight"]]
    with pytest.raises(Exception):
        s.fmu2.setInteger([s.vr("contact_mode")], [0])
    assert "contact_mode" in s.log_text()
    s.free()


@pytest.mark.parametrize("function, ctype", [("fmi3GetFloat64", C.c_double), ("fmi3GetInt32", C.c_int32),
                                             ("fmi3GetBoolean", C.c_bool)])
def test_fmi3_refuses_the_mode_through_another_getter(example_build, function, ctype):
    s = Slave3(str(example_build("drop_bounce", fmi=3).fmu))
    s.init(**TIGHT)
    vr = (C.c_uint32 * 1)(s.vr("contact_mode"))
    out = (ctype * 1)()
    assert s.raw(function, vr, C.c_size_t(1), out, C.c_size_t(1)) == 3  # fmi3Error
    assert f"value reference {s.vr('contact_mode')} (contact_mode) is an Enumeration (Int64) variable" \
        in s.log_text()
    s.free()


def test_fmi3_answers_the_mode_through_get_int64(example_build):
    s = Slave3(str(example_build("drop_bounce", fmi=3).fmu))
    s.init(**TIGHT)
    assert s.fmu3.getInt64([s.vr("contact_mode")]) == [ITEMS["flight"]]
    s.free()


NAMES = ("contact_mode", "vz", "height", "dissipated_energy")


def test_fmi2_state_keeps_the_mode(example_build):
    """Saved in flight between bounces, restored after the rest: flight again, the replay equal."""
    s = Slave(str(example_build("drop_bounce").fmu), logging_on=False)
    s.init(**TIGHT)
    s.slave.doStep(0.0, 0.2)
    assert s.get("contact_mode") == ITEMS["flight"]
    first, second = replayed(s, 0.2, 0.03, 10, NAMES)
    assert first[-1][0] == ITEMS["rolling"] and second == first
    s.free()


def test_fmi3_state_keeps_the_mode(example_build):
    """As in FMI 2, the state also restored from its serialized bytes."""
    s = Slave3(str(example_build("drop_bounce", fmi=3).fmu), logging_on=False)
    s.init(**TIGHT)
    s.slave.doStep(0.0, 0.2)
    assert s.get("contact_mode") == ITEMS["flight"]
    state = s.fmu3.getFMUState()
    copy = s.fmu3.deserializeFMUState(s.fmu3.serializeFMUState(state))  # through its bytes
    runs = []
    for restored in (state, copy):
        s.fmu3.setFMUState(restored)
        assert s.get("contact_mode") == ITEMS["flight"]
        out = []
        for k in range(10):
            s.fmu3.doStep(0.2 + 0.03 * k, 0.03)
            out.append(s.get(*NAMES))
        runs.append(out)
    assert runs[0][-1][0] == ITEMS["rolling"] and runs[1] == runs[0]
    s.fmu3.freeFMUState(state)
    s.fmu3.freeFMUState(copy)
    s.free()
