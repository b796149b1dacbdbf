"""The unit of every FMI variable against its physical dimension (docs/interface.md: positions m,
angles rad, their rates m/s and rad/s, a derivative's unit its state's per second).

The references are not the code's: a table of what each state is (below, from docs/interface.md
and docs/effects.md), the equations themselves (a state whose derivative is another state, such
as z_centre' = z_dot, fixes that state's unit to the first's per second) and the SI base units of
modelDescription.xml's <UnitDefinitions> (der(v) has v's exponents with one more 1/s). Across
scenes with every effect, both formulations, the body speeds, and every example scene; model
specifications only, nothing compiled.
"""
from __future__ import annotations

from pathlib import Path

import casadi as ca
import pytest

from gyrowheel.fmu_build.builder import model_spec
from gyrowheel.fmu_build.model_description import UNITS
from gyrowheel.fmu_build.scene import load_scene, parse_scene
from gyrowheel.fmu_build.variables import build_table
from gyrowheel.model.build import build_model

SCENES = Path(__file__).parent.parent / "examples" / "scenes"
EVERY_EFFECT = """[effects.gravity]
[effects.slope]
[effects.gyrover]
[effects.rolling_resistance]
[effects.spin_friction]
[effects.air_drag]
[effects.contact_forces]
{contact}
[effects.energy]
"""
SLIDE_AND_FLY = 'on_slip = "slide"\non_lift_off = "fly"'

# what each state is (docs/interface.md, docs/effects.md): its unit
STATE_UNITS = {
    "x": "m", "y": "m", "z_centre": "m",  # positions
    "alpha": "rad", "beta": "rad", "gamma": "rad", "theta_p": "rad", "tilt": "rad",  # angles
    "alpha_dot": "rad/s", "beta_dot": "rad/s", "gamma_dot": "rad/s", "theta_p_dot": "rad/s", "tilt_rate": "rad/s",
    "omega_l": "rad/s", "omega_m": "rad/s", "omega_n": "rad/s",  # body angular velocity
    "x_dot": "m/s", "y_dot": "m/s", "z_dot": "m/s",  # velocities
    "dissipated_energy": "J", "actuator_work": "J", "last_impulse": "N.s",
    "rolling_mode": "1", "pivot_mode": "1", "contact_state": "1", "slip_dir_x": "1", "slip_dir_y": "1",
}
# outputs named for what they are
OUTPUT_UNITS = {"z": "m", "height": "m", "contact_x": "m", "contact_y": "m", "vx": "m/s", "vy": "m/s", "vz": "m/s",
                "slip_long": "m/s", "slip_lat": "m/s", "energy": "J", "kinetic_energy": "J", "potential_energy": "J",
                "dissipated_power": "W", "F_n": "N", "F_long": "N", "F_lat": "N", "impact_impulse": "N.s"}


def _base(unit: str) -> dict[str, int]:
    """SI base exponents of a unit of modelDescription.xml ({} for 1 or none)."""
    if unit in ("", "1"):
        return {}
    assert unit in UNITS, f"unit {unit!r} has no definition"
    return dict(UNITS[unit][0])


def _per_second(base: dict[str, int]) -> dict[str, int]:
    out = dict(base)
    out["s"] = out.get("s", 0) - 1
    return {k: e for k, e in out.items() if e}


def _specs():
    """(label, spec, experiment) of the scenes checked."""
    out = []
    for label, text in (("every effect, sliding and flight", EVERY_EFFECT.format(contact=SLIDE_AND_FLY)),
                        ("every effect, multipliers", '[model]\nformulation = "multipliers"\n'
                         + EVERY_EFFECT.format(contact=""))):
        scene = parse_scene(text, "units.toml")
        out.append((label, model_spec(scene), scene.experiment))
    for path in sorted(SCENES.glob("*.toml")):
        scene = load_scene(path)
        out.append((path.stem, model_spec(scene), scene.experiment))
    return out


@pytest.fixture(scope="module")
def specs():
    return _specs()


def _check_states(spec) -> None:
    assert len(spec.x_units) == len(spec.x_names)
    for name, unit in zip(spec.x_names, spec.x_units):
        assert STATE_UNITS.get(name) == unit, f"state {name}: {unit!r}, expected {STATE_UNITS.get(name)!r}"
    # the equations: x_i' = x_j makes x_j's unit x_i's per second
    for i, name in enumerate(spec.x_names):
        for j in range(spec.x.numel()):
            if ca.is_equal(ca.simplify(spec.ode[i]), spec.x[j]):
                assert _base(spec.x_units[j]) == _per_second(_base(spec.x_units[i])), (name, spec.x_names[j])


def test_every_variable_has_the_unit_of_its_dimension(specs):
    for label, spec, exp in specs:
        _check_states(spec)
        table = build_table(spec, exp)
        by_vr = {v.vr: v for v in table}
        state_unit = dict(zip(spec.x_names, spec.x_units))
        for v in table:
            unit = v.quantity.unit
            _base(unit)  # defined
            if v.derivative_of is not None:  # der(v): v's unit per second
                of = by_vr[v.derivative_of]
                assert _base(unit) == _per_second(_base(of.quantity.unit)), (label, v.name, unit, of.quantity.unit)
            elif v.name in state_unit:
                assert unit == state_unit[v.name], (label, v.name, unit)
            elif v.name in OUTPUT_UNITS:
                assert unit == OUTPUT_UNITS[v.name], (label, v.name, unit)
            elif v.name.endswith("_torque"):
                assert unit == "N.m", (label, v.name, unit)


def test_the_flight_states_have_their_units(specs):
    """The units reported wrong before: z_dot m/s, der(z_dot) m/s2, z_centre m, der(z_centre) m/s,
    last_impulse N.s (der N)."""
    spec, exp = next((s, e) for label, s, e in specs if label == "drop_bounce")
    units = {v.name: v.quantity.unit for v in build_table(spec, exp)}
    assert {k: units[k] for k in ("z_dot", "der(z_dot)", "z_centre", "der(z_centre)", "last_impulse",
                                   "der(last_impulse)")} == {"z_dot": "m/s", "der(z_dot)": "m/s2", "z_centre": "m",
                                                              "der(z_centre)": "m/s", "last_impulse": "N.s",
                                                              "der(last_impulse)": "N"}


def test_body_speeds_have_angular_rate_units():
    spec = build_model(effects={"gravity": {}, "energy": {}}, speeds="body")
    _check_states(spec)
    assert spec.x_units[spec.x_names.index("omega_l")] == "rad/s"
