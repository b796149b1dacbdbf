"""The closed loop as SSP 1.0 / OSP files, run by gyrowheel's master and libcosim."""
from __future__ import annotations

import math
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest
import xmlschema

from conftest import ROOT, loop_accuracy
from gyrowheel.cosim import ecos_run, libcosim_run
from gyrowheel.cosim.master import run
from gyrowheel.cosim.system import SystemFileError, write_osp
from gyrowheel.cosim.ssp import PARAMETER_SET, read_ssp, write_ssp

SCHEMAS = Path(__file__).resolve().parent.parent / "cosim" / "schemas" / "ssp1"
COMPARED = {"wheel": ["beta", "alpha", "x", "y", "tilt"], "controller": ["tilt_cmd", "drive_torque"]}


def test_ssd_is_valid_ssp_1_0(earth_loop, tmp_path):
    """SystemStructure.ssd against the SSP 1.0 schemas (XSD 1.0 and the XSD 1.1 variant)."""
    with zipfile.ZipFile(earth_loop.ssp) as zf:
        names = set(zf.namelist())
        zf.extract("SystemStructure.ssd", tmp_path)
    assert {"SystemStructure.ssd", "resources/wheel.fmu", "resources/controller.fmu"} <= names
    ssd = tmp_path / "SystemStructure.ssd"
    xmlschema.XMLSchema10(SCHEMAS / "SystemStructureDescription.xsd").validate(ssd)
    xmlschema.XMLSchema11(SCHEMAS / "SystemStructureDescription11.xsd").validate(ssd)


def test_the_ssp_tells_omsimulator_its_system_type(earth_loop, tmp_path):
    """OMSimulator 3.0's command line takes a system's type only from its own annotation
    (ssc:Annotation type "org.openmodelica", oms:SimulationInformation; without it: "[NewSystem]
    internal error", exit 134). The .ssd carries a fixed-step master with the 10 ms step and the
    components' tolerance, inside ssd:Annotations, which the SSP schema leaves open (the file
    stays valid: test_ssd_is_valid_ssp_1_0) and other masters skip."""
    from xml.etree import ElementTree as ET
    with zipfile.ZipFile(earth_loop.ssp) as zf:
        root = ET.fromstring(zf.read("SystemStructure.ssd"))
    ns = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
          "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
          "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"}
    annotation = root.findall("ssd:System/ssd:Annotations/ssc:Annotation", ns)
    assert [a.get("type") for a in annotation] == ["org.openmodelica"]
    master = annotation[0].find("oms:Annotations/oms:SimulationInformation/oms:FixedStepMaster", ns)
    assert master is not None and master.get("description") == "oms-ma"
    assert float(master.get("stepSize")) == 0.01
    assert float(master.get("relativeTolerance")) == min(t["rel_tol"] for t in loop_accuracy().values())


def test_a_master_passing_its_own_tolerance_gets_the_scenes(earth_loop, tmp_path):
    """SSP 1.0 has no tolerance field; a master that passes its own to fmi2SetupExperiment
    (OMSimulator: 1e-4, after setting the start values) must still run each component at its own
    accuracy: the .ssp binds each rel_tol, which takes precedence (docs/interface.md,
    "Tolerances", rule 1). In force after initialisation: the scene file's rel_tol and abs_tol
    for the wheel, the controller's build rel_tol (without the binding: 1e-4 and 1e-6)."""
    import tomllib

    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    scene = tomllib.loads((ROOT / "examples" / "scenes" / "gyrover_mission_earth.toml").read_text())["experiment"]
    system = read_ssp(earth_loop.ssp, tmp_path / "unpacked")
    expected = {"wheel": (scene["rel_tol"], scene["abs_tol"]),
                "controller": (loop_accuracy()["controller"]["rel_tol"],)}
    for c in system.components:
        md = read_model_description(str(c.fmu))
        vr = {v.name: v.valueReference for v in md.modelVariables}
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(c.fmu), tmp_path / c.name),
                        modelIdentifier=md.coSimulation.modelIdentifier, instanceName=c.name)
        fmu.instantiate()
        try:
            for name, value in c.start_values.items():  # the file's bindings, as the master applies them
                fmu.setReal([vr[name]], [value])
            fmu.setupExperiment(tolerance=1e-4, startTime=0.0)
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            in_force = tuple(fmu.getReal([vr[n] for n in ("rel_tol", "abs_tol")[:len(expected[c.name])]]))
        finally:
            fmu.terminate()
            fmu.freeInstance()
        assert in_force == expected[c.name], (c.name, in_force)


def test_ssp_round_trip(earth_loop, tmp_path):
    system = read_ssp(earth_loop.ssp, tmp_path)
    assert [c.name for c in system.components] == ["wheel", "controller"]
    assert len(system.connections) == 9


def _agree(a: np.ndarray, b: np.ndarray, tol: float) -> float:
    """Largest difference of the compared signals at the communication points both recorded."""
    ia = np.searchsorted(a["time"], b["time"] - 1e-9)
    keep = (ia < len(a)) & (np.abs(a["time"][np.minimum(ia, len(a) - 1)] - b["time"]) < 1e-9)
    assert keep.sum() >= 400, keep.sum()  # 5 s at 10 ms: (nearly) every point
    worst = 0.0
    for comp, names in COMPARED.items():
        for v in names:
            col = f"{comp}.{v}"
            worst = max(worst, float(np.max(np.abs(a[col][ia[keep]] - b[col][keep]))))
    assert worst < tol, worst
    return worst


def test_masters_agree(earth_loop, tmp_path):
    """gyrowheel's master (reading the .ssp) and libcosim reading OspSystemStructure.xml:
    same 10 ms step, 5 s from a 1 deg lean: every compared signal within 1e-8 (measured 1e-13;
    libcosim counts time in integer nanoseconds, gyrowheel in t0 + k h)."""
    lean0 = math.radians(-1.0)
    starts = {"wheel": {"beta": math.pi / 2 + lean0}}
    system = read_ssp(earth_loop.ssp, tmp_path / "unpacked")
    system.components[0].start_values = dict(starts["wheel"])
    ours = run(system, 0.01, stop_time=5.0).data
    osp = write_osp(system, tmp_path / "osp", 0.01)
    by_osp = libcosim_run.run(str(osp), system, 0.01, 5.0, COMPARED)
    print("OSP", _agree(ours, by_osp, 1e-8))


def test_libcosim_reads_our_ssp_and_agrees(earth_loop, tmp_path):
    """libcosim's own SSP loader on our .ssp, with parameter bindings on both components (a wheel
    parameter, the controller's gain_scale and a mission point): within 1e-8 of gyrowheel's master
    reading the same file (measured 1e-13)."""
    system = read_ssp(earth_loop.ssp, tmp_path / "unpacked")
    system.components[0].start_values = {"M": 2.1}
    system.components[1].start_values = {"gain_scale": 1.2, "mission_rate_2": 0.4}
    bound = write_ssp(system, tmp_path / "bound.ssp")
    again = read_ssp(bound, tmp_path / "bound")
    assert again.components[0].start_values == {**loop_accuracy()["wheel"], "M": 2.1}
    ours = run(again, 0.01, stop_time=5.0).data
    plain = run(read_ssp(earth_loop.ssp, tmp_path / "plain"), 0.01, stop_time=5.0).data
    assert np.abs(ours["wheel.alpha"] - plain["wheel.alpha"]).max() > 1e-3  # the bindings matter
    by_ssp = libcosim_run.run(str(bound), again, 0.01, 5.0, COMPARED)
    print("SSP", _agree(ours, by_ssp, 1e-8))


def test_ecos_reads_our_ssp_and_agrees(earth_loop, tmp_path):
    """A third master: ecos (ecospy) runs the same .ssp, with bindings, at 10 ms: within 1e-8 of
    gyrowheel's master (measured 5e-14)."""
    system = read_ssp(earth_loop.ssp, tmp_path / "unpacked")
    system.components[1].start_values = {"gain_scale": 1.2}
    bound = write_ssp(system, tmp_path / "bound.ssp")
    ours = run(read_ssp(bound, tmp_path / "bound"), 0.01, stop_time=5.0).data
    by_ecos = ecos_run.run(str(bound), 0.01, 5.0, COMPARED, parameter_set=PARAMETER_SET)
    print("ecos", _agree(ours, by_ecos, 1e-8))


def test_a_state_start_value_is_not_an_ssp_parameter_binding(earth_loop, tmp_path):
    """libcosim applies SSP parameter sets only to parameters and inputs ("Non-input causality for
    variable wheel:beta", then ignored): binding the wheel's beta made its run start from the
    scene's lean and differ from ours (the 0.9 of the first pass). Such a file is refused, by the
    writer and by the reader."""
    system = read_ssp(earth_loop.ssp, tmp_path / "unpacked")
    system.components[0].start_values = {"beta": 1.5}
    with pytest.raises(SystemFileError, match=r"wheel\.beta: an SSP parameter binding sets a parameter or an input, "
                                              r"this is an output"):
        write_ssp(system, tmp_path / "state.ssp")
    ssd = (tmp_path / "unpacked" / "SystemStructure.ssd").read_text()
    binding = ('<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues><ssv:ParameterSet version="1.0" '
               'name="s"><ssv:Parameters><ssv:Parameter name="beta"><ssv:Real value="1.5"/></ssv:Parameter>'
               '</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>')
    head, tail = ssd.split('<ssd:Component name="wheel"', 1)
    first, rest = tail.split("</ssd:Connectors>", 1)
    if "xmlns:ssv" not in ssd:
        head = head.replace("<ssd:SystemStructureDescription", '<ssd:SystemStructureDescription '
                            'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"', 1)
    bad = tmp_path / "bad"
    shutil.copytree(tmp_path / "unpacked", bad)
    (bad / "SystemStructure.ssd").write_text(head + '<ssd:Component name="wheel"' + first + "</ssd:Connectors>"
                                             + binding + rest)
    archive = tmp_path / "bad.ssp"
    with zipfile.ZipFile(archive, "w") as zf:
        for f in bad.rglob("*"):
            zf.write(f, f.relative_to(bad).as_posix())
    with pytest.raises(SystemFileError, match=r"wheel\.beta"):
        read_ssp(archive, tmp_path / "bad_unpacked")


def test_cli_system_run(earth_loop, tmp_path):
    from gyrowheel.cli import main
    out = tmp_path / "run.csv"
    assert main(["system", "run", str(earth_loop.ssp), "--step", "0.01", "--stop-time", "1", "-o", str(out)]) == 0
    header = out.read_text().splitlines()[0]
    assert "wheel.beta" in header and "controller.tilt_cmd" in header
    assert main(["system", "run", str(tmp_path / "missing.ssp")]) == 2
    assert main(["system", "run", str(earth_loop.ssp), "--step", "0.003", "--stop-time", "1"]) == 2
