"""Other importers: fmpy's rebuild from sources/, libcosim and ecospy (real co-simulation masters)."""
from __future__ import annotations

import shutil

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.build import build_platform_binary

from conftest import STATES


def test_rebuilt_from_sources_runs_and_agrees(earth_fmu, tmp_path):
    """fmpy compiles the FMU's own sources/ with CMake; the rebuilt binary gives the same result."""
    unzipdir = extract(str(earth_fmu), str(tmp_path / "unzipped"))
    ident = read_model_description(str(earth_fmu)).coSimulation.modelIdentifier
    shutil.rmtree(f"{unzipdir}/binaries")
    (tmp_path / "cmake").mkdir()
    build_platform_binary(unzipdir, build_dir=str(tmp_path / "cmake"))
    assert (tmp_path / "unzipped" / "binaries" / "linux64" / f"{ident}.so").is_file()
    rebuilt = simulate_fmu(unzipdir, stop_time=2.0, output_interval=0.1)
    original = simulate_fmu(str(earth_fmu), stop_time=2.0, output_interval=0.1)
    for n in STATES:
        np.testing.assert_allclose(rebuilt[n], original[n], rtol=1e-9, atol=1e-11)


def test_runs_under_libcosim(earth_fmu):
    """libcosim steps the FMU with integer-nanosecond communication steps."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    md = read_model_description(str(earth_fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    execution = CosimExecution.from_step_size(step_size=int(1e7))  # 10 ms
    slave = CosimLocalSlave(fmu_path=str(earth_fmu), instance_name="wheel")
    index = execution.add_local_slave(local_slave=slave)
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer=observer)
    assert execution.real_initial_value(index, vr["g"], 3.721)
    assert execution.simulate_until(target_time=int(2e9))
    values = observer.last_real_values(index, [vr[n] for n in STATES])
    reference = simulate_fmu(str(earth_fmu), stop_time=2.0, output_interval=0.01, start_values={"g": 3.721})
    np.testing.assert_allclose(values, [reference[n][-1] for n in STATES], rtol=1e-8, atol=1e-10)
    assert execution.status().current_time == int(2e9)


def _spinless_wheel_in_ecos(fmu, capfd) -> tuple[list[float], str]:
    """ecospy steps the wheel, spin set to 0 by a parameter set, at 10 ms to 2 s (through its fall);
    the states at the end and what ecospy printed (the FMU's messages: ecospy's debug level)."""
    from ecospy import EcosLib, EcosSimulation, EcosSimulationStructure

    EcosLib.set_log_level("debug")
    try:
        with EcosSimulationStructure() as structure:
            structure.add_model("wheel", str(fmu))
            structure.add_parameter_set("nospin", {"wheel::gamma_dot": 0.0})
            with EcosSimulation(structure=structure, step_size=0.01) as sim:
                sim.init(parameter_set="nospin")
                sim.step_until(2.0)
                assert sim.get_time() == pytest.approx(2.0, abs=0.011)
                values = [sim.get_real(f"wheel::{n}") for n in STATES]
                assert sim.get_bool("wheel::fallen")
                sim.terminate()
    finally:
        EcosLib.set_log_level("warn")
    return values, capfd.readouterr().out


def test_runs_under_ecospy_to_the_fall_and_ends_cleanly(earth_fmu, capfd):
    """ecospy 0.7.2 (a second real master): the spinless wheel falls at t = 0.4335 s; ecospy ignores
    fmi2Discard and steps on to 2 s. The FMU answers every further step with fmi2Discard, keeps the
    state at the fall, logs the refusal once (counted, "repeated 154 more times") and terminates
    cleanly, not fmi2Error at the first further step and then one "illegal call in state Error"
    line per step."""
    values, out = _spinless_wheel_in_ecos(earth_fmu, capfd)
    reference = simulate_fmu(str(earth_fmu), stop_time=2.0, start_values={"gamma_dot": 0.0})
    assert reference["time"][-1] == pytest.approx(0.4335, abs=1e-3)
    np.testing.assert_allclose(values, [reference[n][-1] for n in STATES], rtol=1e-9, atol=1e-10)
    beta_min = float(next(v.start for v in read_model_description(str(earth_fmu)).modelVariables
                          if v.name == "beta_min"))
    assert values[STATES.index("beta")] == pytest.approx(beta_min, abs=1e-9)
    assert "fmi2Error" not in out and "illegal call" not in out
    assert out.count("no further step is computed") == 1
    assert "(the previous message was repeated 154 more times)" in out


def test_fmu_manipulation_toolbox_reads_and_repacks(earth_fmu, tmp_path):
    """fmu-manipulation-toolbox 2.0 lists the interface; a repacked FMU (its descriptor rewritten
    by the toolbox) still runs in fmpy with the same result."""
    import csv

    from fmu_manipulation_toolbox.operations import FMU, OperationSaveNamesToCSV, OperationStripTopLevel

    names = tmp_path / "names.csv"
    with FMU(str(earth_fmu)) as fmu:
        fmu.apply_operation(OperationSaveNamesToCSV(str(names)))
        fmu.apply_operation(OperationStripTopLevel())
        fmu.repack(str(tmp_path / "repacked.fmu"))
    rows = {r["name"]: r for r in csv.DictReader(names.open(), delimiter=";", quotechar="'")}
    md = read_model_description(str(earth_fmu))
    assert set(rows) == {v.name for v in md.modelVariables}
    assert rows["solver"]["scalarType"] == "Enumeration" and rows["g"]["causality"] == "parameter"
    a = simulate_fmu(str(earth_fmu), stop_time=1.0, output=STATES)
    b = simulate_fmu(str(tmp_path / "repacked.fmu"), stop_time=1.0, output=STATES)
    assert all(a[n][-1] == b[n][-1] for n in STATES)


def test_ecospy_runs_the_fmi3_wheel_through_the_fall(example_build, capfd):
    """ecospy 0.7.2 loads FMI 3.0 Co-Simulation FMUs (through fmi4c): the spinless FMI 3.0 wheel
    falls at t = 0.4335 s; ecos reads neither terminateSimulation nor lastSuccessfulTime and steps
    on to 2 s. The FMU answers every further fmi3DoStep with fmi3Discard, keeps the state at the
    fall and logs the refusal once (repeats counted). That state is gyrowheel's master's last row
    (which ends at lastSuccessfulTime) to 1e-9: ecos sums its steps into its time (2 s ends at
    1.9900000000000015), the master takes t0 + k h, so the located fall differs by about 5e-14 s
    and the falling beta_dot (-9.5 rad/s) by about 2.5e-12 rad/s."""
    from gyrowheel.cosim.master import run
    from gyrowheel.cosim.system import Component, SystemDescription

    fmu = example_build("paper_earth", fmi=3).fmu
    values, out = _spinless_wheel_in_ecos(fmu, capfd)
    ours = run(SystemDescription("alone", [Component("wheel", fmu)], [], stop_time=2.0), 0.01,
               start_values={"wheel": {"gamma_dot": 0.0}})
    assert ours.stopped_by == "wheel" and ours.data["time"][-1] == pytest.approx(0.4335, abs=1e-3)
    np.testing.assert_allclose(values, [ours.data[f"wheel.{n}"][-1] for n in STATES], rtol=1e-9, atol=1e-10)
    assert "Error" not in out and "illegal call" not in out
    assert out.count("fmi3DoStep: the simulation terminated at") == 1
    assert "(the previous message was repeated 154 more times)" in out
