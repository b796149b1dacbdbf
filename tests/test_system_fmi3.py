"""The closed loop with FMI 3.0 FMUs: gyrowheel's master against the FMI 2.0 loop, mixed versions,
the fall as fmi3DoStep's terminateSimulation, the FMU's own error messages, ecos and libcosim."""
from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
import xmlschema
from fmpy import read_model_description

from gyrowheel.controller.closed_loop import closed_loop_system, component_versions
from gyrowheel.cosim import ecos_run, libcosim_run
from gyrowheel.cosim.exchange import feedthrough
from gyrowheel.cosim.master import MasterError, run
from gyrowheel.cosim.ssp import PARAMETER_SET, read_ssp, write_ssp
from gyrowheel.cosim.system import Component, SystemDescription, SystemFileError
from gyrowheel.errors import ArgumentError

SCHEMAS = Path(__file__).resolve().parent.parent / "cosim" / "schemas" / "ssp1"
COMPARED = {"wheel": ["beta", "alpha", "x", "y", "tilt"], "controller": ["tilt_cmd", "drive_torque"]}


def _largest_difference(a: np.ndarray, b: np.ndarray) -> float:
    assert a.dtype.names == b.dtype.names and len(a) == len(b)
    return max(float(np.max(np.abs(a[n] - b[n]))) for n in a.dtype.names)


def test_the_fmi3_loop_is_an_ssp_of_fmi3_fmus(earth_loop_fmi3, tmp_path):
    """Both FMUs are FMI 3.0 and pass fmpy's validation (the .ssp refers to them as to FMI 2.0
    ones: resources/<name>.fmu, valid SSP 1.0), and the system reads back with the same
    feedthrough as the FMI 2.0 loop's."""
    from fmpy.validation import validate_fmu
    for fmu in (earth_loop_fmi3.wheel_fmu, earth_loop_fmi3.controller_fmu):
        assert validate_fmu(str(fmu)) == [], fmu
    with zipfile.ZipFile(earth_loop_fmi3.ssp) as zf:
        zf.extract("SystemStructure.ssd", tmp_path)
    xmlschema.XMLSchema10(SCHEMAS / "SystemStructureDescription.xsd").validate(tmp_path / "SystemStructure.ssd")
    system = read_ssp(earth_loop_fmi3.ssp, tmp_path / "unpacked")
    assert [read_model_description(str(c.fmu)).fmiVersion for c in system.components] == ["3.0", "3.0"]
    assert feedthrough(earth_loop_fmi3.wheel_fmu) == {"tilt_torque": ("tilt_cmd", "drive_torque"),
                                                      "flywheel_torque": ("tilt_cmd", "drive_torque")}
    assert feedthrough(earth_loop_fmi3.controller_fmu) == {"heading_error": ("alpha",)}


def test_the_earth_mission_runs_the_same_with_fmi3(earth_loop, earth_loop_fmi3, tmp_path):
    """`gyrowheel system run` of the earth mission (60 s at 10 ms, read from each .ssp): the FMI 3.0
    loop gives every output of both components exactly as the FMI 2.0 loop does (same generated C,
    same core, same steps: difference 0)."""
    from gyrowheel.api import system_run
    two = system_run(earth_loop.ssp, step=0.01)
    three = system_run(earth_loop_fmi3.ssp, step=0.01)
    assert two.stopped_by is None and three.stopped_by is None
    assert len(three.data) == 6001
    assert _largest_difference(two.data, three.data) == 0.0


@pytest.mark.parametrize("wheel_fmi, controller_fmi", [(2, 3), (3, 2)])
def test_fmi2_and_fmi3_components_in_one_system(earth_loop, earth_loop_fmi3, wheel_fmi, controller_fmi):
    """A wheel of one version with a controller of the other: 5 s from the scene's lean, the same
    as the all-FMI 2.0 loop."""
    fmus = {2: earth_loop, 3: earth_loop_fmi3}
    mixed = closed_loop_system("mixed", fmus[wheel_fmi].wheel_fmu, fmus[controller_fmi].controller_fmu)
    plain = closed_loop_system("plain", earth_loop.wheel_fmu, earth_loop.controller_fmu)
    assert _largest_difference(run(mixed, 0.01, stop_time=5.0).data, run(plain, 0.01, stop_time=5.0).data) == 0.0


def test_an_fmi3_component_ends_the_run_at_its_last_successful_time(earth_fmu, example_build):
    """The paper's wheel alone, not spinning, falls at t = 0.4335 s, inside a 10 ms step: the FMI 3.0
    wheel says so with fmi3DoStep's terminateSimulation and lastSuccessfulTime; the system's last
    row is there, at the time and state the FMI 2.0 wheel reports through fmi2Discard and
    fmi2LastSuccessfulTime."""
    ends = []
    for fmu in (earth_fmu, example_build("paper_earth", fmi=3).fmu):
        r = run(SystemDescription("alone", [Component("wheel", fmu)], [], stop_time=2.0), 0.01,
                start_values={"wheel": {"gamma_dot": 0.0}})
        assert r.stopped_by == "wheel"
        ends.append(r.data)
    assert ends[1]["time"][-1] == pytest.approx(0.4335, abs=1e-3) and len(ends[1]) == 45  # 0 .. 0.43, the fall
    assert _largest_difference(ends[0], ends[1]) == 0.0


def test_an_fmi3_array_output_is_recorded_by_its_scalars_and_is_no_connector(earth_loop_fmi3):
    """The FMI 3.0 wheel's array outputs (x_state, contact_force) repeat its scalar outputs: the
    master records the scalars (one column each, the FMI 2.0 loop's columns: test above), and a
    connection from an array is refused naming it."""
    from gyrowheel.cosim.system import Connection
    from gyrowheel.cosim.units import scalar_outputs
    wheel, controller = earth_loop_fmi3.wheel_fmu, earth_loop_fmi3.controller_fmu
    md = read_model_description(str(wheel))
    arrays = {v.name for v in md.modelVariables if v.dimensions}
    assert "x_state" in arrays and not arrays & set(scalar_outputs(md))
    assert len(scalar_outputs(md)) == sum(v.causality == "output" for v in md.modelVariables) - len(arrays)
    target = next(v.name for v in read_model_description(str(controller)).modelVariables
                  if v.causality == "input" and v.type == "Float64")
    system = SystemDescription("arrays", [Component("wheel", wheel), Component("controller", controller)],
                               [Connection("wheel", "x_state", "controller", target)])
    with pytest.raises(SystemFileError, match=r"wheel\.x_state is an array variable \(connections join scalar "):
        system.check()


def test_an_fmi3_component_failing_names_its_logged_reason(earth_loop_fmi3):
    """A refused value ends the run with the FMU's own message, through the FMI 3.0 log callback."""
    system = closed_loop_system("loop", earth_loop_fmi3.wheel_fmu, earth_loop_fmi3.controller_fmu)
    with pytest.raises(MasterError, match=r"^wheel refused the start values: M \(mass\) must be > 0 \(wheel\.M = -1\.0\)$"):
        run(system, 0.01, stop_time=1.0, start_values={"wheel": {"M": -1.0}})


def test_libcosim_refuses_an_fmi3_component_naming_its_file(earth_loop_fmi3, tmp_path):
    system = read_ssp(earth_loop_fmi3.ssp, tmp_path / "unpacked")
    with pytest.raises(SystemFileError, match=r"component 'wheel': .*wheel\.fmu: an FMI 3\.0 FMU; libcosim runs "
                                              r"FMI 1\.0 and 2\.0 FMUs only"):
        libcosim_run.run(str(earth_loop_fmi3.ssp), system, 0.01, 1.0, COMPARED)


def test_ecos_runs_the_fmi3_loop(earth_loop_fmi3, tmp_path):
    """ecos (ecospy) runs the FMI 3.0 loop's .ssp, with a binding, at 10 ms for 5 s: within 1e-8
    of gyrowheel's master."""
    system = read_ssp(earth_loop_fmi3.ssp, tmp_path / "unpacked")
    system.components[1].start_values = {"gain_scale": 1.2}
    bound = write_ssp(system, tmp_path / "bound.ssp")
    ours = run(read_ssp(bound, tmp_path / "bound"), 0.01, stop_time=5.0).data
    by_ecos = ecos_run.run(str(bound), 0.01, 5.0, COMPARED, parameter_set=PARAMETER_SET)
    assert len(by_ecos) == len(ours)
    worst = max(float(np.max(np.abs(ours[f"{c}.{v}"] - by_ecos[f"{c}.{v}"]))) for c, vs in COMPARED.items()
                for v in vs)
    print("ecos FMI 3", worst)
    assert worst < 1e-8


def test_the_closed_loop_fmi_option():
    assert component_versions(None, 3) == {"wheel": 3, "controller": 3}
    assert component_versions(3, 2) == {"wheel": 3, "controller": 3}
    assert component_versions({"controller": 3}, 2) == {"wheel": 2, "controller": 3}
    with pytest.raises(ArgumentError, match="fmi: 'wheels' is not a component of the closed loop"):
        component_versions({"wheels": 3}, 2)
    with pytest.raises(ArgumentError, match="fmi: must be 2 or 3"):
        component_versions(4, 2)


@pytest.mark.parametrize("fmi_type, value, expected", [
    ("Float64", "2.5", 2.5), ("Int32", 7, 7), ("UInt8", 255, 255), ("Enumeration", "3", 3), ("Boolean", "true", True)])
def test_fmi3_values_are_read_as_their_type(fmi_type, value, expected):
    from types import SimpleNamespace

    from gyrowheel.cosim.ssp import coerce_value
    assert coerce_value(SimpleNamespace(type=fmi_type), value, "c.v") == expected


@pytest.mark.parametrize("fmi_type, value, reason", [
    ("UInt8", 256, "is out of range [0, 255] (UInt8)"), ("UInt8", -1, "is out of range [0, 255] (UInt8)"),
    ("Int8", 128, "is out of range [-128, 127] (Int8)"), ("Int32", 2**31, "is out of range [-2147483648, 2147483647] "
                                                                         "(Int32)"),
    ("Int32", 1.5, "is not a valid Int32"), ("Float64", True, "is not a valid Float64")])
def test_fmi3_values_outside_their_type_are_refused(fmi_type, value, reason):
    """A value ctypes would wrap is refused naming the variable and its type's range, one it
    would truncate (or a bool for a number) naming the type."""
    from types import SimpleNamespace

    from gyrowheel.cosim.ssp import coerce_value
    with pytest.raises(SystemFileError) as exc:
        coerce_value(SimpleNamespace(type=fmi_type), value, "c.v")
    assert str(exc.value) == f"c.v: {value!r} {reason}"


FMI3_DESCRIPTION = """<fmiModelDescription fmiVersion="3.0" modelName="m" instantiationToken="t">
  <CoSimulation modelIdentifier="m"/>
  <ModelVariables>
    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>
    <Float64 name="u" valueReference="1" causality="input" start="0"/>
    <Int32 name="k" valueReference="2" causality="input" start="0"/>
    <Float64 name="y" valueReference="3" causality="output"/>
    <Float64 name="z" valueReference="4" causality="output"/>
    <Float64 name="w" valueReference="5" causality="output"/>
  </ModelVariables>
  <ModelStructure>
    <Output valueReference="3" dependencies="1 0"/>
    <Output valueReference="4" dependencies=""/>
    <Output valueReference="5"/>
    {extra}
  </ModelStructure>
</fmiModelDescription>"""


def test_fmi3_feedthrough_reads_outputs_by_value_reference(tmp_path):
    """FMI 3.0 ModelStructure/Output: variables and dependencies by value reference; of the
    dependencies only inputs count; no attribute means every input (FMI 3.0.2 section 2.4.8)."""
    (tmp_path / "modelDescription.xml").write_text(FMI3_DESCRIPTION.format(extra=""))
    assert feedthrough(tmp_path) == {"y": ("u",), "w": ("u", "k")}
    (tmp_path / "modelDescription.xml").write_text(FMI3_DESCRIPTION.format(extra='<Output valueReference="9"/>'))
    with pytest.raises(SystemFileError, match="ModelStructure has an Output with a bad valueReference or "
                                              "dependencies"):
        feedthrough(tmp_path)
