"""Bad and unusual system files (.ssp) for gyrowheel's master and `gyrowheel system run`: every fault is
one SystemFileError (CLI: one line, exit 2) naming the file and the element; every SSP 1.0 parameter
binding the master can apply is applied (typed, inline or from an .ssv file, on a component or the
system), never silently dropped; a failing component's own reason reaches the user (exit 1)."""
from __future__ import annotations

import math
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import xmlschema

from conftest import ROOT, loop_accuracy
from gyrowheel.cosim.master import MasterError, StartValueRefusedError, run
from gyrowheel.cosim.system import SystemFileError
from gyrowheel.cosim.ssp import read_ssp, write_ssp

SCHEMAS = Path(__file__).resolve().parent.parent / "cosim" / "schemas" / "ssp1"
SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
BINDING = ('<ssd:ParameterBindings><ssd:ParameterBinding{attrs}>{values}</ssd:ParameterBinding>'
           '</ssd:ParameterBindings>')
VALUES = ('<ssd:ParameterValues><ssv:ParameterSet version="1.0" name="start"><ssv:Parameters>{}</ssv:Parameters>'
          '</ssv:ParameterSet></ssd:ParameterValues>')


@pytest.fixture(scope="module")
def unpacked(earth_loop, tmp_path_factory):
    """The closed loop's SystemStructure.ssd text and its FMUs' bytes."""
    with zipfile.ZipFile(earth_loop.ssp) as zf:
        return zf.read("SystemStructure.ssd").decode(), {n: zf.read(n) for n in zf.namelist() if n.endswith(".fmu")}


def _ssv_ns(ssd: str) -> str:
    return ssd if "xmlns:ssv" in ssd else ssd.replace("<ssd:SystemStructureDescription ",
                                                      f'<ssd:SystemStructureDescription xmlns:ssv="{SSV}" ', 1)


def bind(ssd: str, comp: str | None, params: str = "", attrs: str = "") -> str:
    """ssd with a ParameterBinding on component `comp` (after its Connectors, beside the bindings
    it has) or on the system (before its Elements), where SSP 1.0 puts them (the file stays
    schema-valid); params: ssv:Parameter elements inline, attrs: the binding's attributes."""
    binding = BINDING.format(attrs=attrs, values=VALUES.format(params) if params else "")
    ssd = _ssv_ns(ssd)
    if comp is None:
        return ssd.replace("<ssd:Elements>", binding + "<ssd:Elements>", 1)
    head, tail = ssd.split(f'<ssd:Component name="{comp}"', 1)
    first, rest = tail.split("</ssd:Connectors>", 1)
    if rest.lstrip().startswith("<ssd:ParameterBindings>"):  # one ParameterBindings per element
        binding = binding.removeprefix("<ssd:ParameterBindings>").removesuffix("</ssd:ParameterBindings>")
        rest = rest.replace("<ssd:ParameterBindings>", "<ssd:ParameterBindings>" + binding, 1)
        binding = ""
    return head + f'<ssd:Component name="{comp}"' + first + "</ssd:Connectors>" + binding + rest


def archive(path: Path, ssd: str, fmus: dict, extra: dict | None = None) -> Path:
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("SystemStructure.ssd", ssd)
        for name, data in {**fmus, **(extra or {})}.items():
            zf.writestr(name, data)
    return path


def param(name: str, kind: str, value: str, unit: str = "") -> str:
    return f'<ssv:Parameter name="{name}"><ssv:{kind} value="{value}"{unit}/></ssv:Parameter>'


CONN = 'startElement="wheel" startConnector="beta" endElement="controller" endConnector="beta"'
BAD = {
    "bad_real": (lambda s: bind(s, "wheel", param("M", "Real", "heavy")), r"wheel\.M: 'heavy' is not a valid Real"),
    # libcosim and ecos leave Enumeration variables out and ignore such a binding: masters would disagree
    "enumeration": (lambda s: bind(s, "wheel", param("solver", "Enumeration", "rk4")),
                    r"wheel\.solver: an Enumeration; libcosim and ecos leave FMI 2.0 Enumeration variables out"),
    "enumeration_as_integer": (lambda s: bind(s, "wheel", param("solver", "Integer", "2")),
                               r"wheel\.solver: an Enumeration"),
    "bad_integer": (lambda s: bind(s, "wheel", param("max_internal_steps", "Integer", "1.5")),
                    r"wheel\.max_internal_steps: '1.5' is not a valid Integer"),
    # an fmi2Integer is 32 bits: ctypes would wrap 3e9 to -1294967296; the variable's range is named
    "integer_out_of_range": (lambda s: bind(s, "wheel", param("max_internal_steps", "Integer", "3000000000")),
                             r"wheel\.max_internal_steps: '3000000000' is out of range \[1, 2147483647\] \(Integer\)"),
    "type_mismatch": (lambda s: bind(s, "wheel", param("M", "Boolean", "true")),
                      r"wheel\.M: bound as ssv:Boolean, the FMU's variable is a Real"),
    "unit": (lambda s: bind(s, "wheel", param("M", "Real", "2000", ' unit="g"')),
             r"wheel\.M: value in 'g', the FMU's unit is 'kg' \(unit conversion is not supported\)"),
    "binary": (lambda s: bind(s, "wheel", param("M", "Binary", "00")), r"ssv:Binary values are not supported"),
    "mapping": (lambda s: bind(s, "wheel", param("M", "Real", "2") + "", "").replace(
        "</ssd:ParameterValues>", "</ssd:ParameterValues><ssd:ParameterMapping/>"),
        r"ssd:ParameterMapping is not supported"),
    "missing_ssv": (lambda s: bind(s, "wheel", attrs=' source="resources/none.ssv"'),
                    r"component 'wheel', parameter binding: resources/none.ssv is not in the archive"),
    "system_binding_name": (lambda s: bind(s, None, param("M", "Real", "2")),
                            r"system parameter binding 'M': expected <component>\.<variable>"),
    "bad_stop": (lambda s: s.replace('stopTime="60.0"', 'stopTime="sixty"'),
                 r"DefaultExperiment stopTime = 'sixty' is not a finite number"),
    "stop_before_start": (lambda s: s.replace('startTime="0.0"', 'startTime="70"'),
                          r"DefaultExperiment stopTime 60 is not after startTime 70"),
    "bool_to_real": (lambda s: s.replace(CONN, CONN.replace('startConnector="beta"', 'startConnector="fallen"')),
                     r"connection wheel\.fallen -> controller\.beta: joins a Boolean to a Real"),
    "duplicate": (lambda s: s.replace('<ssd:Component name="controller"', '<ssd:Component name="wheel"'),
                  r"two components are named 'wheel'"),
    "no_components": (lambda s: re.sub(r"<ssd:Connections>.*</ssd:Connections>", "",
                                       re.sub(r"<ssd:Elements>.*</ssd:Elements>", "<ssd:Elements/>", s, flags=re.S),
                                       flags=re.S), r"has no components"),
    "escape": (lambda s: s.replace('source="resources/controller.fmu"', 'source="../../../etc/passwd"'),
               r"component 'controller': '\.\./\.\./\.\./etc/passwd' points outside the \.ssp"),
    "no_element": (lambda s: s.replace(CONN, CONN.replace('startElement="wheel" ', "")),
                   r"connection \d+: startElement, startConnector, endElement and endConnector are required"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_system_file_names_its_fault(unpacked, tmp_path, case):
    """Each is refused with its fault named: not a crash (traceback), not misread (a Boolean read as
    a Real by the master, an unnamed 'could not convert string to float'), not run without
    complaint (no components)."""
    ssd, fmus = unpacked
    edit, message = BAD[case]
    path = archive(tmp_path / f"{case}.ssp", edit(ssd), fmus)
    with pytest.raises(SystemFileError, match=message):
        read_ssp(path, tmp_path / "u")


def test_a_component_that_is_not_an_fmu(unpacked, tmp_path):
    ssd, fmus = unpacked
    path = archive(tmp_path / "broken.ssp", ssd, {**fmus, "resources/controller.fmu": b"not a zip"})
    with pytest.raises(SystemFileError, match=r"component 'controller': controller\.fmu is not a readable FMU"):
        read_ssp(path, tmp_path / "u")


def test_every_binding_type_is_applied(unpacked, earth_loop, tmp_path):
    """ssv:Integer, an external .ssv file and a system-level binding ('controller.gain_scale') are
    applied, not dropped without a word (as a reader of inline ssv:Real alone would). A binding on
    the system overrides the component's (SSP 1.0 section 5.3.5)."""
    ssd, fmus = unpacked
    text = bind(ssd, "wheel", param("max_internal_steps", "Integer", "7"))
    text = bind(text, "controller", attrs=' source="resources/gains.ssv"')
    text = bind(text, None, param("controller.gain_scale", "Real", "1.5"))
    ssv = (f'<?xml version="1.0"?><ssv:ParameterSet xmlns:ssv="{SSV}" version="1.0" name="gains"><ssv:Parameters>'
           + param("gain_scale", "Real", "0.5") + param("mission_rate_2", "Real", "0.4")
           + "</ssv:Parameters></ssv:ParameterSet>")
    path = archive(tmp_path / "typed.ssp", text, fmus, {"resources/gains.ssv": ssv})
    system = read_ssp(path, tmp_path / "u")
    accuracy = loop_accuracy()  # the file's own bindings of each component's rel_tol stay
    assert system.component("wheel").start_values == {**accuracy["wheel"], "max_internal_steps": 7}
    assert system.component("controller").start_values == {**accuracy["controller"], "gain_scale": 1.5,
                                                           "mission_rate_2": 0.4}
    # applied: with no internal steps allowed the wheel cannot take its first step
    starved = bind(ssd, "wheel", param("max_internal_steps", "Integer", "0"))
    with pytest.raises(MasterError, match=r"^wheel refused the start values: .*max_internal_steps"):
        run(read_ssp(archive(tmp_path / "starved.ssp", starved, fmus), tmp_path / "s"), 0.01, stop_time=0.1)
    # the writer writes each binding as its variable's type; the file is valid SSP 1.0 and reads back
    system.component("wheel").start_values = {"max_internal_steps": 9, "M": 2.5}
    written = write_ssp(system, tmp_path / "written.ssp")
    with zipfile.ZipFile(written) as zf:
        zf.extract("SystemStructure.ssd", tmp_path / "w")
        ssd_text = zf.read("SystemStructure.ssd").decode()
    assert '<ssv:Parameter name="max_internal_steps"><ssv:Integer value="9"' in ssd_text
    xmlschema.XMLSchema10(SCHEMAS / "SystemStructureDescription.xsd").validate(tmp_path / "w" / "SystemStructure.ssd")
    again = read_ssp(written, tmp_path / "again")
    assert again.component("wheel").start_values == {**accuracy["wheel"], "max_internal_steps": 9, "M": 2.5}
    system.component("wheel").start_values = {"solver": "euler"}
    with pytest.raises(SystemFileError, match=r"wheel\.solver: an Enumeration"):
        write_ssp(system, tmp_path / "enum.ssp")


def gyrowheel(*args, cwd):
    return subprocess.run([sys.executable, "-m", "gyrowheel", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd)


@pytest.mark.parametrize("name, value, message", [
    ("max_internal_steps", 1.5, r"wheel\.max_internal_steps: 1\.5 is not a valid Integer"),  # not int() -> 1
    ("max_internal_steps", 3e9,  # not wrapped
     r"wheel\.max_internal_steps: 3000000000\.0 is out of range \[1, 2147483647\] \(Integer\)"),
    ("M", "heavy", r"wheel\.M: 'heavy' is not a valid Real"),
])
def test_master_start_values_are_checked_like_bindings(unpacked, tmp_path, name, value, message):
    """gyrowheel.cosim.master.run(start_values=...) (the Python side of `gyrowheel system run --set`) types
    its values with the bindings' checks: nothing truncated (1.5 must not run as
    max_internal_steps = 1), nothing wrapped (3e9 must not reach the FMU as -1294967296), the
    variable named."""
    ssd, fmus = unpacked
    system = read_ssp(archive(tmp_path / "plain.ssp", ssd, fmus), tmp_path / "u")
    with pytest.raises(MasterError, match=message):
        run(system, 0.01, stop_time=0.02, start_values={"wheel": {name: value}})


def test_a_component_refusing_a_bound_value_says_why(unpacked, tmp_path):
    """A component that refuses a value the system file binds: the error names it, the FMU's
    logged reason and the value; the CLI prints that one line and exits 2 (bad input: the file's).
    Not 'fmi2ExitInitializationMode failed with status 3 (run again with the FMU's logging
    categories on ...)', which the command cannot do, with the reason printed by fmpy to stdout."""
    ssd, fmus = unpacked
    path = archive(tmp_path / "neg.ssp", bind(ssd, "wheel", param("M", "Real", "-1")), fmus)
    reason = "wheel refused the start values: M (mass) must be > 0 (wheel.M = -1.0)"
    with pytest.raises(StartValueRefusedError, match=rf"^{re.escape(reason)}$") as exc:
        run(read_ssp(path, tmp_path / "u"), 0.01, stop_time=0.1)
    assert isinstance(exc.value, MasterError) and not exc.value.given
    r = gyrowheel("system", "run", path, "--stop-time", "0.1", cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr and r.stdout == ""
    assert r.stderr == f"gyrowheel: error: {path}: {reason}\n"


@pytest.mark.parametrize("args,code,fragment", [
    (("--stop-time", "1e-9"), 2, "stop time 1e-09 is not a whole number (>= 1) of steps 0.01 from 0: stop at 0.01"),
    (("--stop-time", "0.333"), 2, "stop at 0.33 or 0.34, or choose a step that divides 0.333 s"),
    (("--stop-time", "-1"), 2, "--stop-time must be > 0, got -1.0"),
    (("--step", "0"), 2, "--step must be > 0"),
    # 6e10 points refused before the run, not attempted (a list per point: the machine's memory, then a kill)
    (("--step", "1e-9"), 2, "60000000001 communication points of 39 columns would take"),
    (("--stop-time", "1", "-o", "{file}/x.csv"), 2, "is not a directory"),
    (("--stop-time", "1", "-o", "{dir}"), 2, "is a directory; give a file name"),
])
def test_cli_system_run_bad_options(earth_loop, tmp_path, args, code, fragment):
    """One line, the right exit, before the run: `--stop-time 1e-9` must not run zero steps and
    write one row, an unwritable -o must not raise a traceback after the whole run; a result
    larger than half the machine's memory is refused with its size."""
    (tmp_path / "file").write_text("")
    args = [a.format(file=tmp_path / "file", dir=tmp_path) for a in args]
    r = gyrowheel("system", "run", earth_loop.ssp, *args, cwd=tmp_path)
    assert r.returncode == code and "Traceback" not in r.stderr
    assert r.stderr.count("\n") == 1 and fragment in r.stderr, r.stderr


def test_the_master_removes_the_fmus_it_unpacked(earth_loop, tmp_path, monkeypatch):
    """fmpy.extract unpacks every component into a new temporary directory; the master removes
    them after the run (two per run left behind would fill /tmp: a step study makes a dozen)."""
    import tempfile
    system = read_ssp(earth_loop.ssp, tmp_path / "u")
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    run(system, 0.01, stop_time=0.05)
    with pytest.raises(MasterError):
        run(system, 0.01, stop_time=0.05, start_values={"wheel": {"M": -1.0}})
    assert list(scratch.iterdir()) == []


def test_animate_a_system_run_with_the_ssp_as_geometry(earth_loop, tmp_path):
    """`gyrowheel system run` then `gyrowheel animate` on its CSV, the .ssp giving the wheel's R and
    flywheel (a bound L_pend is the one drawn): the pair a user reaches for first."""
    from gyrowheel.animation import read_result, resolve_parameters
    out = tmp_path / "run.csv"
    assert gyrowheel("system", "run", earth_loop.ssp, "--stop-time", "0.5", "-o", out, cwd=tmp_path).returncode == 0
    r = gyrowheel("animate", out, "--fmu", earth_loop.ssp, "-o", tmp_path / "run.gif", "--fps", "10",
                  "--size", "96x64", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "6 frames" in r.stdout and "R = 0.17 m from " in r.stdout and "model's defaults" not in r.stderr
    system = read_ssp(earth_loop.ssp, tmp_path / "u")
    system.component("wheel").start_values = {"L_pend": 0.05}
    bound = write_ssp(system, tmp_path / "bound.ssp")
    table = read_result(out)
    assert table.component == "wheel" and math.isclose(float(table.text["beta"][0]), math.pi / 2 - math.radians(5))
    p = resolve_parameters(table, fmu=bound)
    assert (p.R, p.L_pend, p.m_fly) == (0.17, 0.05, 0.4)
    assert np.isfinite(table.number("tilt")).all()


def test_controller_tilt_stop_is_at_most_a_right_angle(controller_fmu, tmp_path):
    """tilt_max (the gimbal stop) past pi/2, e.g. 10 rad, would turn the spin axis through the link
    (docs/system.md): refused at initialisation, with the reason, as bad input (exit 2)."""
    r = gyrowheel("simulate", controller_fmu, "--stop-time", "0.05", "--set", "tilt_max=2", "-o", tmp_path / "c.csv",
                  cwd=tmp_path)
    assert r.returncode == 2 and "tilt_max must be <= 1.5708" in r.stderr, r.stderr
    r = gyrowheel("simulate", controller_fmu, "--stop-time", "0.05", "--set", "tilt_max=1.5", "-o", tmp_path / "c.csv",
                  cwd=tmp_path)
    assert r.returncode == 0, r.stderr


def test_cli_system_run_set(earth_loop, tmp_path):
    """`system run --set COMPONENT.VARIABLE=VALUE`, checked as `simulate --set` checks (name,
    settable, type): the run equals the master's with those start values."""
    out = tmp_path / "set.csv"
    r = gyrowheel("system", "run", earth_loop.ssp, "--stop-time", "0.5", "-o", out, "--set", "wheel.beta=1.55",
                  "--set", "controller.gain_scale=0.5", "--set", "wheel.solver=rk4", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    ours = np.genfromtxt(out, delimiter=",", names=True)
    direct = run(read_ssp(earth_loop.ssp, tmp_path / "u"), 0.01, stop_time=0.5, start_values={
        "wheel": {"beta": 1.55, "solver": 2}, "controller": {"gain_scale": 0.5}}).data
    assert ours["wheelbeta"][0] == 1.55 and np.array_equal(ours["wheelbeta"], direct["wheel.beta"])
    for args, fragment in ((("--set", "M=2"), "expected COMPONENT.VARIABLE=VALUE with a component of wheel, controller"),
                           (("--set", "wheel.colour=3"), "--set, component wheel: unknown variable 'colour'"),
                           (("--set", "wheel.solver=rk45"), "not a valid Enumeration; valid: euler, rk4")):
        r = gyrowheel("system", "run", earth_loop.ssp, "--stop-time", "0.1", "-o", out, *args, cwd=tmp_path)
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and fragment in r.stderr, r.stderr


def _unit(fmu: Path, name: str) -> str:
    """A variable's unit read straight from modelDescription.xml (its Real's unit or declared type's)."""
    from xml.etree import ElementTree as ET
    with zipfile.ZipFile(fmu) as zf:
        md = ET.fromstring(zf.read("modelDescription.xml"))
    real = md.find(f"ModelVariables/ScalarVariable[@name='{name}']/Real")
    unit = real.get("unit")
    if unit is None:
        unit = md.find(f"TypeDefinitions/SimpleType[@name='{real.get('declaredType')}']/Real").get("unit")
    return unit


def test_write_ssp_refuses_a_file_read_ssp_would_refuse(earth_loop, tmp_path):
    """wheel.beta (rad) -> controller.vx (m/s) needs a unit conversion the readers refuse: the
    writer refuses it too, before writing anything, with the reader's message; suppressing the
    conversion (SSP 1.0 suppressUnitConversion) writes a file the reader reads back."""
    from gyrowheel.cosim.system import Component, Connection, SystemDescription
    assert (_unit(earth_loop.wheel_fmu, "beta"), _unit(earth_loop.controller_fmu, "vx")) == ("rad", "m/s")
    components = [Component("wheel", earth_loop.wheel_fmu), Component("controller", earth_loop.controller_fmu)]
    system = SystemDescription("units", components, [Connection("wheel", "beta", "controller", "vx")], 0.0, 1.0)
    message = ("connection wheel.beta -> controller.vx: from 'rad' to 'm/s': unit conversion is not supported "
               "(state the factor with ssc:LinearTransformation and suppressUnitConversion=\"true\")")
    with pytest.raises(SystemFileError, match=re.escape(message)):
        write_ssp(system, tmp_path / "out" / "units.ssp")
    assert not (tmp_path / "out").exists()
    system.connections[0].suppress_unit_conversion = True
    path = write_ssp(system, tmp_path / "suppressed.ssp")
    assert read_ssp(path, tmp_path / "u").connections[0].suppress_unit_conversion
