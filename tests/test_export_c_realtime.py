"""examples/realtime.c of `gyrowheel export-c`: the exported C in a fixed-step loop of 1 ms
periods, with the timings of every step (docs/c_api.md, "Real time: a fixed-step 1 kHz loop").

  test_realtime_example                     short: rk4 takes 4 evaluations a 1 ms step, conserves
                                            energy to 1e-10, is accurate to 1e-7; euler is not
                                            (the claims of docs/c_api.md, shortened)
  test_realtime_energy_balance_of_a_dissipative_scene[...]
                                            the drift reported is that of the balance energy +
                                            dissipated_energy - actuator_work: a friction scene's
                                            physical loss is not drift; without the energy
                                            effect's terms: NaN and the reason
  test_realtime_steps_out_of_range[...]     --steps beyond 10^9 refused at once, exit 2
  test_realtime_out_of_memory_says_so       timings that do not fit: a message, before the
                                            reference is computed
"""
from __future__ import annotations

import subprocess

import pytest

from conftest import SCENES
from export_c_helpers import STRICT, cc
from gyrowheel.fmu_build import load_scene
from gyrowheel.fmu_build.export_c import export_c


def results(stdout: str) -> dict[str, dict[str, float]]:
    out = {}
    for line in stdout.splitlines():
        if line.startswith("RESULT solver="):
            fields = dict(kv.split("=") for kv in line.split()[1:])
            solver = fields.pop("solver")
            out[solver] = {k: float(v) for k, v in fields.items()}
    return out


def test_realtime_example(earth_gcc):
    r = subprocess.run([str(earth_gcc["realtime"]), "--steps", "21000", "--compare"], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    res = results(r.stdout)
    assert set(res) == {"euler", "rk4", "dopri5", "dop853"}
    rk4 = res["rk4"]
    assert rk4["steps"] == 21000 and rk4["terminated"] == 0
    assert 3.999 < rk4["rhs_per_step"] <= 4.0  # one RK4 step per 1 ms period, always
    assert rk4["energy_drift"] < 1e-10 and rk4["err_20"] < 1e-7
    assert res["euler"]["terminated"] == 1 or res["euler"]["err_20"] > 1e-2  # not accurate enough
    assert res["dopri5"]["rhs_per_step"] >= 6.0 and res["dop853"]["rhs_per_step"] >= 12.0
    for solver in res.values():
        assert 0 < solver["wall_p50_us"] <= solver["wall_p999_us"] <= solver["wall_max_us"]
        assert 0 < solver["cpu_p50_us"] <= solver["cpu_p999_us"] <= solver["cpu_max_us"]


@pytest.mark.parametrize("energy_effect", [True, False], ids=["with-energy-effect", "without"])
def test_realtime_energy_balance_of_a_dissipative_scene(tmp_path, energy_effect):
    """examples/realtime.c's energy drift is that of the balance energy + dissipated_energy -
    actuator_work (docs/effects.md), constant in an exact run. With rolling resistance and pivot
    friction the raw energy falls by design (8% in 5 s here): taken as drift, its 7.9e-2 would
    blame RK4 for the physics. With the energy effect the balance holds to RK4's accuracy;
    without it the drift cannot be measured and the example says why (NaN)."""
    text = (SCENES / "paper_earth_friction.toml").read_text() + ("\n[effects.energy]\n" if energy_effect else "")
    scene = tmp_path / "friction.toml"
    scene.write_text(text)
    out = tmp_path / "friction"
    export_c(load_scene(scene), out, check=False)
    exe = tmp_path / "realtime"
    diagnostics = cc("gcc", *STRICT, "-O2", f"-I{out}", out / "examples" / "realtime.c",
                     out / "paper_earth_friction.c", "-lm", "-o", exe).stderr
    assert diagnostics == ""
    r = subprocess.run([str(exe), "--steps", "5000"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    fields = dict(kv.split("=") for kv in next(line for line in r.stdout.splitlines()
                                              if line.startswith("RESULT solver=")).split()[1:])
    assert fields["solver"] == "rk4" and fields["steps"] == "5000" and fields["terminated"] == "0"
    if energy_effect:
        assert 0.0 < float(fields["energy_drift"]) < 1e-9, fields["energy_drift"]
        assert "not measured" not in r.stdout
    else:
        assert fields["energy_drift"] == "nan"
        assert "energy drift not measured: the scene dissipates energy but has no dissipated_energy output " \
               "(add [effects.energy])" in r.stdout


@pytest.mark.parametrize("steps", ["9223372036854775807", "99999999999999999999", "1000000001", "0"])
def test_realtime_steps_out_of_range(earth_gcc, steps):
    """--steps beyond what a run can hold (16 bytes of timings a step) is refused at once, exit 2
    with the range: at 2^63 - 1 the size of the timings' allocation would wrap, at 1e11 a 1e8 s
    reference would be computed for hours before the allocation failed; 0 steps time nothing."""
    r = subprocess.run([str(earth_gcc["realtime"]), "--steps", steps], capture_output=True, text=True, timeout=30)
    assert r.returncode == 2 and "--steps needs an integer in [1, 1e9]" in r.stderr, r.stderr


def test_realtime_out_of_memory_says_so(earth_gcc):
    """Timings that do not fit in memory: a message naming the steps and the size, exit 1, before
    the reference is computed (ulimit -v 300 MB; 10^8 steps need 1.6 GB)."""
    r = subprocess.run(f"ulimit -v 300000; exec {earth_gcc['realtime']} --steps 100000000", shell=True,
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "out of memory for 100000000 steps (1613 MB of timings and reference)" in r.stderr, r.stderr
