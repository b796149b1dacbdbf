"""A scene's FMU contains, computes and exposes only the effects the scene names.

Checked on the artefacts themselves: the variables of modelDescription.xml, and the
generated C (the CasADi functions and model_desc.c), not just the model's metadata.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest
from fmpy import read_model_description

from gyrowheel.fmu_build import build_fmu, parse_scene

STATES = ("x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot", "gamma_dot")
BASE_VARIABLES = {
    "M", "R", "k_diam", "k_axial", "beta_min", "g", "solver", "rel_tol", "abs_tol", "max_step",
    "max_internal_steps",  # the budget of internal steps of one fmi2DoStep (docs/fmi.md)
    *STATES, "z", "vx", "vy", "energy", "fallen",
} | {f"der({s})" for s in STATES}  # state derivatives, for Model Exchange
EFFECT_VARIABLES = {  # what each effect adds, by name (docs/effects.md)
    "slope": {"slope_angle", "slope_direction"},
    # the stiction laws (default): a mode state each (local) and its switch event's flag, no smoothing
    "rolling_resistance": {"c_rr", "rolling_resistance_torque", "lifted_off", "rolling_mode", "der(rolling_mode)",
                           "rolling_switched"},
    "spin_friction": {"c_pivot", "d_pivot", "pivot_torque", "lifted_off", "pivot_mode", "der(pivot_mode)",
                      "pivot_switched"},
    "air_drag": {"rho_air", "cd_area", "c_lin", "cm_spin", "drag_force"},
    "contact_forces": {"mu", "F_n", "F_long", "F_lat", "friction_use", "lifted_off", "slipping"},
    "energy": {"kinetic_energy", "potential_energy", "contact_x", "contact_y"},
    "gyrover": {"m_fly", "L_pend", "I_fly_axial", "I_fly_diam", "flywheel_rate", "tilt_omega", "tilt_zeta",
                "tilt_cmd", "drive_torque", "theta_p", "theta_p_dot", "tilt", "tilt_rate", "tilt_torque",
                "flywheel_torque", "flywheel_momentum",
                "der(theta_p)", "der(theta_p_dot)", "der(tilt)", "der(tilt_rate)"},
}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    root = tmp_path_factory.mktemp("only")
    cache = {}

    def _built(*effects: str) -> tuple[set[str], Path]:
        """Effects by name; "name:law" chooses a law (rolling_resistance:smoothed)."""
        key = tuple(sorted(effects))
        if key not in cache:
            name = "_".join(("w",) + key).replace(":", "_")
            text = f'[model]\nname = "{name}"\n[effects.gravity]\n' + "".join(
                f"[effects.{e}]\n" if ":" not in e else "[effects.{}]\nlaw = \"{}\"\n".format(*e.split(":"))
                for e in effects)
            result = build_fmu(parse_scene(text, f"{name}.toml"), root / f"{name}.fmu", build_dir=root / name)
            names = {v.name for v in read_model_description(str(result.fmu)).modelVariables}
            cache[key] = (names, result.sources)
        return cache[key]
    return _built


def _ode_body(sources: Path) -> str:
    """The C body of the CasADi function behind gw_ode."""
    text = (sources / "gw_funcs.c").read_text()
    callee = re.search(r"int gw_ode\(const casadi_real\*\* arg.*?\{\s*return (casadi_f\d+)\(", text, re.S).group(1)
    start = text.index(f"static int {callee}(")
    return text[start: text.index("\n}\n", start)]


def test_base_wheel_exposes_exactly_the_interface(built):
    names, _ = built()
    assert names == BASE_VARIABLES


@pytest.mark.parametrize("effect", sorted(EFFECT_VARIABLES))
def test_each_effect_adds_exactly_its_variables(built, effect):
    names, sources = built(effect)
    extra = EFFECT_VARIABLES[effect]
    assert names == BASE_VARIABLES | extra  # energy alone: nothing dissipates or drives, no dissipated_*
    desc = (sources / "model_desc.c").read_text()
    for other, their in EFFECT_VARIABLES.items():
        if other != effect:
            for var in their - extra - {"lifted_off"}:
                assert f'"{var}"' not in desc, (effect, var)


def test_energy_reports_what_the_other_effects_bring(built):
    names, _ = built("energy", "rolling_resistance", "gyrover")
    assert {"dissipated_energy", "dissipated_power", "actuator_work", "actuator_power"} <= names


def test_the_right_hand_side_contains_only_named_effects(built):
    """Outputs-only effects leave the generated RHS identical; force laws appear only where named."""
    _, base = built()
    base_ode = _ode_body(base)
    for outputs_only in ("contact_forces", "energy"):
        assert _ode_body(built(outputs_only)[1]) == base_ode, outputs_only
    assert "tanh(" not in base_ode and "tanh(" not in (base / "gw_funcs.c").read_text()
    for law in ("rolling_resistance", "spin_friction"):
        assert "tanh(" not in _ode_body(built(law)[1]), law  # true stiction: no regularisation
        assert "tanh(" in _ode_body(built(law + ":smoothed")[1]), law  # the regularised Coulomb laws
    assert len(_ode_body(built("air_drag")[1])) > len(base_ode)
    assert "tanh(" not in _ode_body(built("air_drag")[1])


def test_a_lunar_coasting_study_pays_for_no_drag(built):
    names, sources = built("rolling_resistance", "contact_forces")
    assert not names & (EFFECT_VARIABLES["air_drag"] | EFFECT_VARIABLES["gyrover"])
    header = (sources / "model_desc.c").read_text()
    assert ".nu = 0" in header  # no inputs: nothing of the Gyrover actuation


def test_mode_machinery_only_for_the_stiction_laws(built):
    """The state update function, update events and mode states exist only where a scene names a
    stiction law; the smoothed laws and every other effect have none (no upd in the C at all)."""
    for effects in [(), ("contact_forces",), ("rolling_resistance:smoothed",), ("spin_friction:smoothed",),
                    ("air_drag", "energy")]:
        names, sources = built(*effects)
        assert "gw_upd" not in (sources / "gw_funcs.c").read_text(), effects
        desc = (sources / "model_desc.c").read_text()
        assert ".upd = {0, 0}" in desc and "GW_EVENT_UPDATE" not in desc, effects
        assert not any(n.endswith("_mode") for n in names), effects
    for law, mode in (("rolling_resistance", "rolling_mode"), ("spin_friction", "pivot_mode")):
        names, sources = built(law)
        assert "gw_upd" in (sources / "gw_funcs.c").read_text()
        desc = (sources / "model_desc.c").read_text()
        assert ".upd = {gw_upd, gw_upd_work}" in desc and desc.count("GW_EVENT_UPDATE") == 1
        assert mode in names
