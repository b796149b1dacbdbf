"""Building FMI 3.0 FMUs: the option, the model description, the FMU's files, the tools.

  test_every_example_scene_builds_as_fmi3_and_validates  fmpy.validate_fmu finds no problem;
                                        the FMI 2 rows keep their value references, then one
                                        event indicator per event, then the array outputs; the
                                        token is the C table's
  test_fmi3_model_structure_*           ModelStructure by value reference, indicators listed
  test_fmi2_fmu_carries_no_fmi3_file / test_fmi3_fmu_carries_no_fmi2_file   sources/ per version
  test_build_description_*              sources/buildDescription.xml against fmpy's schema
  test_fmi3_binary_exports_only_fmi3    nm -D: exactly the fmi3 functions of fmi3Functions.h
  test_fmi3_binaries_in_platform_tuple_folders   folders per version, no universal binary
  test_bad_fmi_*                        scene key, Scene object, API and CLI refusals
  test_info_and_simulate_read_fmi3      gyrowheel.info / simulate on an FMI 3 FMU, the same
                                        trajectory as the FMI 2 FMU of the scene
"""
from __future__ import annotations

import dataclasses
import re
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy.validation import validate_fmu

from c_programs import FMI_HEADERS
from conftest import SCENES
from gyrowheel.fmu_build import builder, load_scene
from gyrowheel.fmu_build.scene import SceneError, check_scene, parse_scene, scene_toml
from gyrowheel.fmu_build.variables import build_table

SCENE_NAMES = sorted(p.stem for p in SCENES.glob("*.toml"))
FMI3_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "Enumeration": "Enumeration"}


def _members(fmu: Path) -> list[str]:
    with zipfile.ZipFile(fmu) as zf:
        return zf.namelist()


def _xml(fmu: Path, member: str = "modelDescription.xml") -> ET.Element:
    with zipfile.ZipFile(fmu) as zf:
        return ET.fromstring(zf.read(member))


@pytest.fixture(scope="module")
def earth3(example_build):
    return example_build("paper_earth", fmi=3)


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_every_example_scene_builds_as_fmi3_and_validates(example_build, name):
    built = example_build(name, fmi=3)
    assert built.fmi == 3
    assert validate_fmu(str(built.fmu)) == [], name
    root = _xml(built.fmu)
    assert root.get("fmiVersion") == "3.0"
    token = re.search(r'\.token = "([^"]+)"', (built.sources / "model_desc.c").read_text()).group(1)
    assert root.get("instantiationToken") == token
    variables = list(root.find("ModelVariables"))
    assert (variables[0].tag, variables[0].get("name"), variables[0].get("valueReference"),
            variables[0].get("causality")) == ("Float64", "time", "0", "independent")
    scene = load_scene(SCENES / f"{name}.toml")
    fmi2 = build_table(built.spec, scene.experiment, scene.outputs)  # the FMI 2 FMU's rows
    rows = variables[1:]
    assert [(v.tag, v.get("name"), int(v.get("valueReference")), v.get("causality")) for v in rows[:len(fmi2)]] == \
        [(FMI3_TYPES[r.type], r.name, r.vr, r.causality) for r in fmi2]
    indicators, arrays = rows[len(fmi2):len(fmi2) + len(built.spec.events)], rows[len(fmi2) + len(built.spec.events):]
    assert [v.get("name") for v in indicators] == [f"{e.name}_indicator" for e in built.spec.events]
    assert all((v.tag, v.get("causality"), v.get("variability")) == ("Float64", "local", "continuous")
               for v in indicators)
    assert [int(v.get("valueReference")) for v in indicators + arrays] == list(range(len(fmi2) + 1, len(rows) + 1))
    # then the array outputs (tests/test_fmi3_arrays.py): the states, the contact force if any
    assert [v.get("name") for v in arrays] == ["x_state"] + (["contact_force"] if "F_n" in
                                                                 {q.name for q, _ in built.spec.outputs} else [])
    c_rows = re.findall(r'\{(\d+)u, "(\w+)", GW_REAL, GW_VAR_INDICATOR, (\d+),', (built.sources / "model_desc.c").read_text())
    assert [(int(vr), n, int(k)) for vr, n, k in c_rows] == \
        [(int(v.get("valueReference")), v.get("name"), k) for k, v in enumerate(indicators)]


def test_fmi3_model_structure_names_value_references(earth3):
    root = _xml(earth3.fmu)
    by_vr = {int(v.get("valueReference")): v for v in root.find("ModelVariables")}
    ms = root.find("ModelStructure")
    tags = [e.tag for e in ms]
    assert tags == sorted(tags, key=["Output", "ContinuousStateDerivative", "InitialUnknown", "EventIndicator"].index)
    outputs = {int(e.get("valueReference")) for e in ms.iter("Output")}
    assert outputs == {vr for vr, v in by_vr.items() if v.get("causality") == "output"}
    for e in ms.iter("ContinuousStateDerivative"):
        derivative = by_vr[int(e.get("valueReference"))]
        state = by_vr[int(derivative.get("derivative"))]  # a value reference, not an index
        assert derivative.get("name") == f"der({state.get('name')})"
    indicators = [by_vr[int(e.get("valueReference"))].get("name") for e in ms.iter("EventIndicator")]
    assert indicators == [f"{e.name}_indicator" for e in earth3.spec.events] and indicators
    fall = next(e for e in ms.iter("EventIndicator"))
    beta = next(vr for vr, v in by_vr.items() if v.get("name") == "beta")
    assert beta in map(int, fall.get("dependencies").split())  # the fall: sin(beta) - sin(beta_min)
    cs, me = root.find("CoSimulation"), root.find("ModelExchange")
    for element in (cs, me):
        for key in ("canGetAndSetFMUState", "canSerializeFMUState", "providesDirectionalDerivatives",
                    "providesAdjointDerivatives"):
            assert element.get(key) == "true", key
    assert (cs.get("hasEventMode"), cs.get("providesIntermediateUpdate"), cs.get("maxOutputDerivativeOrder"),
            me.get("needsCompletedIntegratorStep")) == ("true", "false", "0", "false")
    items = [i.get("name") for i in root.find("TypeDefinitions").find("EnumerationType").iter("Item")]
    assert items == ["euler", "rk4", "dopri5", "rosenbrock", "dop853", "taylor", "auto"]  # auto: the kernel


def test_fmi3_reinit_marks_states_of_a_model_with_update_events(example_build):
    """stiction's mode switch sets the state anew at an event: the states say reinit; a
    model without update events (paper_earth) says nothing."""
    held = example_build("slope_hold", fmi=3)
    assert any(e.action == "update" for e in held.spec.events)
    for built, expected in ((held, "true"), (example_build("paper_earth", fmi=3), None)):
        root = _xml(built.fmu)
        states = {v.get("derivative") for v in root.find("ModelVariables") if v.get("derivative")}
        for v in root.find("ModelVariables"):
            if v.get("valueReference") in states:
                assert v.get("reinit") == expected, (built.identifier, v.get("name"))


def test_fmi3_fmu_carries_no_fmi2_file(earth3):
    names = _members(earth3.fmu)
    sources = {n.split("/", 1)[1] for n in names if n.startswith("sources/")}
    assert {"gw_fmu3.c", "gw_fmi3.h", "fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h",
            "buildDescription.xml", "gw_core.c", "model_desc.c"} <= sources
    assert not [n for n in sources if n.startswith(("gw_fmi2", "fmi2")) or n == "gw_fmu.c"]
    assert f"binaries/x86_64-linux/{earth3.identifier}.so" in names
    assert not [n for n in names if n.startswith("binaries/linux64")]
    assert "documentation/index.html" in names


def test_fmi2_fmu_carries_no_fmi3_file(earth_build):
    names = _members(earth_build.fmu)
    sources = {n.split("/", 1)[1] for n in names if n.startswith("sources/")}
    assert {"gw_fmu.c", "gw_fmi2.h", "fmi2Functions.h"} <= sources
    assert not [n for n in sources if n.startswith(("gw_fmi3", "fmi3")) or n in ("gw_fmu3.c", "buildDescription.xml")]
    root = _xml(earth_build.fmu)
    assert root.get("fmiVersion") == "2.0" and root.get("guid")
    assert not [v for v in root.find("ModelVariables") if v.get("name").endswith("_indicator")]
    assert f"binaries/linux64/{earth_build.identifier}.so" in names


def test_build_description_is_valid_and_lists_the_unity_file(earth3):
    from lxml import etree
    from fmpy import read_model_description
    import fmpy
    schema = etree.XMLSchema(file=str(Path(fmpy.__file__).parent / "schema" / "fmi3" / "fmi3BuildDescription.xsd"))
    with zipfile.ZipFile(earth3.fmu) as zf:
        doc = etree.fromstring(zf.read("sources/buildDescription.xml"))
    assert schema.validate(doc), schema.error_log
    configs = read_model_description(str(earth3.fmu)).buildConfigurations
    assert [(c.modelIdentifier, [(s.language, s.sourceFiles) for s in c.sourceFileSets]) for c in configs] == \
        [(earth3.identifier, [("C99", ["gw_fmu3.c"])])]


def _exports(lib: Path) -> set[str]:
    nm = subprocess.run(["nm", "-D", "--defined-only", str(lib)], capture_output=True, text=True, check=True)
    return {line.split()[-1] for line in nm.stdout.splitlines() if line.strip()}


def test_fmi3_binary_exports_only_fmi3(earth3, tmp_path):
    names = set(re.findall(r"FMI3_Export\s+fmi3\w+TYPE\s+(fmi3\w+)\s*;", (FMI_HEADERS / "fmi3Functions.h").read_text()))
    assert len(names) == 75  # FMI 3.0's functions: fmi3GetVersion ... fmi3ActivateModelPartition
    with zipfile.ZipFile(earth3.fmu) as zf:
        lib = tmp_path / "earth.so"
        lib.write_bytes(zf.read(f"binaries/x86_64-linux/{earth3.identifier}.so"))
    assert _exports(lib) == names


@pytest.mark.parametrize("fmi, folders", [
    (2, {"x86_64-linux": "linux64", "x86_64-windows": "win64", "x86_64-darwin": "darwin64",
         "aarch64-darwin": "aarch64-darwin"}),
    (3, {"x86_64-linux": "x86_64-linux", "x86_64-windows": "x86_64-windows", "x86_64-darwin": "x86_64-darwin",
         "aarch64-darwin": "aarch64-darwin"}),
])
def test_fmi3_binaries_in_platform_tuple_folders(monkeypatch, tmp_path, fmi, folders):
    """Where write_binaries puts each platform's library (the compilers replaced by a file
    writer); FMI 2 joins both Mac slices into darwin64, FMI 3 keeps them apart."""
    from gyrowheel.fmu_build import platforms
    written = []
    host = platforms.host_platform()

    def fake_compile(source, include_dirs, output, *_):
        output.parent.mkdir(parents=True, exist_ok=True)
        output.write_bytes(b"x")
        written.append(output)

    def fake_cross(targets, source, include_dirs, outputs, flags):
        for o in outputs:
            fake_compile(source, include_dirs, o)
    universal = []
    monkeypatch.setattr(builder, "compile_shared", fake_compile)
    monkeypatch.setattr(platforms, "cross_compile_all", fake_cross)
    monkeypatch.setattr(platforms, "write_universal", lambda slices, out: universal.append(out) or out.write_bytes(b"u"))
    libs = builder.write_binaries(tmp_path / "gw.c", [tmp_path], tmp_path / "binaries", "m", tuple(folders), fmi)
    assert {n: p.parent.name for n, p in libs.items()} == folders
    assert host.name in folders
    assert universal == ([tmp_path / "binaries" / "darwin64" / "m.dylib"] if fmi == 2 else [])


# -- refusals ------------------------------------------------------------------------------

@pytest.mark.parametrize("value", ["4", "1", '"3"', "3.0", "true", "[3]"])
def test_bad_fmi_in_a_scene_file_names_the_key(value):
    with pytest.raises(SceneError) as exc:
        parse_scene(f"[build]\nfmi = {value}\n", "s.toml")
    assert str(exc.value).startswith("s.toml: [build] fmi: must be 2 or 3 (the FMI version), got ")
    assert "\n" not in str(exc.value)


def test_fmi_in_a_scene_round_trips_and_a_bad_object_is_refused():
    scene = parse_scene("[build]\nfmi = 3\n", "s.toml")
    assert scene.fmi == 3 and parse_scene("", "s.toml").fmi == 2
    assert parse_scene(scene_toml(check_scene(scene)), "s.toml").fmi == 3
    assert "fmi" not in scene_toml(check_scene(parse_scene("", "s.toml")))  # FMI 2 scenes read as before
    with pytest.raises(SceneError, match=r"^scene 's': \[build\] fmi: must be 2 or 3 \(the FMI version\), got 5$"):
        check_scene(dataclasses.replace(scene, fmi=5))


def test_bad_fmi_argument_is_refused_before_anything_is_built(tmp_path):
    import gyrowheel
    out = tmp_path / "m.fmu"
    with pytest.raises(gyrowheel.ArgumentError) as exc:
        gyrowheel.build(SCENES / "paper_moon.toml", out, fmi=4)
    assert exc.value.argument == "fmi" and str(exc.value) == "fmi: must be 2 or 3 (the FMI version), got 4"
    for value in ("3", 3.0, True):  # the wrong type: ArgumentTypeError, as for every argument
        with pytest.raises(gyrowheel.ArgumentTypeError) as exc:
            gyrowheel.build(SCENES / "paper_moon.toml", out, fmi=value)
        assert exc.value.argument == "fmi"
        assert str(exc.value).startswith(f"fmi: must be the integer 2 or 3 (the FMI version), got {value!r}")
    assert not out.exists()


@pytest.mark.parametrize("flag, message", [
    ("4", "gyrowheel: error: argument --fmi: invalid choice: 4 (choose from 2, 3) (see gyrowheel build --help)"),
    ("x", "gyrowheel: error: argument --fmi: invalid int value: 'x' (see gyrowheel build --help)"),
])
def test_bad_fmi_flag_is_one_line_exit_2(tmp_path, flag, message):
    import sys
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "build", str(SCENES / "paper_moon.toml"), "--fmi", flag,
                        "-o", str(tmp_path / "m.fmu")], capture_output=True, text=True)
    assert (r.returncode, r.stdout, r.stderr) == (2, "", message + "\n")
    assert not (tmp_path / "m.fmu").exists()


def test_bad_fmi_scene_key_through_the_cli(tmp_path):
    import sys
    scene = tmp_path / "s.toml"
    scene.write_text("[build]\nfmi = 4\n")
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "build", str(scene), "-o", str(tmp_path / "m.fmu")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr == f"gyrowheel: error: {scene}: [build] fmi: must be 2 or 3 (the FMI version), got 4\n"


# -- the tools on an FMI 3 FMU ---------------------------------------------------------------

def test_info_and_simulate_read_fmi3(earth3, earth_build):
    import gyrowheel
    info = gyrowheel.info(earth3)
    assert info.fmi_version == "3.0" and info.guid == _xml(earth3.fmu).get("instantiationToken")
    assert [str(p) for p in info.platforms] == ["x86_64-linux (binaries/x86_64-linux)"]
    by_name = {v.name: v for v in info.variables}
    assert by_name["beta"].type == "Float64" and by_name["solver"].items and by_name["time"].causality == "independent"
    assert info.effects == gyrowheel.info(earth_build).effects and info.solvers == gyrowheel.info(earth_build).solvers
    three = gyrowheel.simulate(earth3, stop_time=1.0, start_values={"beta_deg": 80})
    two = gyrowheel.simulate(earth_build, stop_time=1.0, start_values={"beta_deg": 80})
    assert len(three) == len(two) and three.dtype.names == two.dtype.names
    for name in two.dtype.names:  # same model, same core: the same numbers
        np.testing.assert_array_equal(three[name], two[name], err_msg=name)


def test_simulate_ends_an_fmi3_fall_at_the_located_time(earth3, earth_build):
    """The spinless wheel falls inside a communication step: the last row is at the located
    time (0.4334798... s), the same row as the FMI 2 FMU's, not at the step's end."""
    import gyrowheel
    three = gyrowheel.simulate(earth3, stop_time=2.0, start_values={"gamma_dot": 0.0})
    two = gyrowheel.simulate(earth_build, stop_time=2.0, start_values={"gamma_dot": 0.0})
    assert 0.43 < two["time"][-1] < 0.44 and three["time"][-1] == two["time"][-1]
    for name in two.dtype.names:
        np.testing.assert_array_equal(three[name], two[name], err_msg=name)


def test_a_sweep_refuses_an_fmi3_fmu_in_one_line(earth3):
    """The sweep's runner calls the FMI 2.0 API: an FMI 3 FMU is refused before it starts."""
    import gyrowheel
    with pytest.raises(gyrowheel.FmuError) as exc:
        gyrowheel.sweep(earth3, grid={"M": [2.0]}, workers=0)
    assert exc.value.argument == "source"
    assert str(exc.value) == f"{earth3.fmu}: FMI 3.0 is not supported: a sweep runs FMI 2.0 FMUs"
