"""What the scene reader refuses of values with a known range, of angles in degrees, and how it
says so (docs/scenes.md, "Rules: what is refused").

Every start value and parameter with a range is refused when the scene is read (exit 2 from
`gyrowheel build`, the field named), not first by the FMU at initialisation; the ranges are the
model's own declarations (Quantity.minimum, .maximum) and the FMU's combined checks (k_axial
against k_diam, the start lean against beta_min, vz against height), so the reader and the FMU
cannot disagree. An effect's angle parameter takes <name>_deg as [initial] and [wheel] angles do,
and as `gyrowheel simulate --set` does. Every refusal is one complete sentence.
"""
from __future__ import annotations

import itertools
import math
import re
import subprocess
import sys

import pytest

import gyrowheel
from gyrowheel.fmu_build.scene import SceneError, parse_scene
from gyrowheel.model.build import SPEED_REFUSAL, build_model
from gyrowheel.model.effects import CATALOGUE
from gyrowheel.model.spec import SPEED_OF_LIGHT
from test_docs_claims import DOCS, _refusal_rows

FLY = '[effects.gravity]\n[effects.contact_forces]\non_slip = "slide"\non_lift_off = "fly"\n'


def _refused(text: str) -> str:
    with pytest.raises(SceneError) as err:
        parse_scene(text, "s.toml")
    return str(err.value)


@pytest.mark.parametrize("initial, message", [
    ("height = -0.1", "s.toml: [initial] height: must be >= 0, got -0.1"),
    ("vz = 1.0", "s.toml: [initial] vz: must be 0 unless height > 0 (in contact the centre's vertical velocity "
                 "follows the lean rate), got 1.0 with height 0.0"),
    ("vz = 1.0\nheight = 0.0", "s.toml: [initial] vz: must be 0 unless height > 0"),
])
def test_flight_start_values_out_of_range_are_refused_when_read(initial, message):
    assert _refused(FLY + "[initial]\n" + initial + "\n").startswith(message)
    assert parse_scene(FLY + "[initial]\nheight = 0.2\nvz = -1.0\n").initial == {"height": 0.2, "vz": -1.0}


def test_every_limited_start_value_and_parameter_is_refused_when_read():
    """Each quantity of the catalogue with a minimum or maximum, just outside it: the reader names
    the table and the key and says the limit."""
    options = {"contact_forces": 'on_slip = "slide"\non_lift_off = "fly"\n', "rolling_resistance": 'law = "smoothed"\n',
               "spin_friction": 'law = "smoothed"\n'}
    checked = 0
    for name, cls in CATALOGUE.items():
        head = "[effects.gravity]\n" + (f"[effects.{name}]\n" if name != "gravity" else "")
        table = f"[effects.{name}]\n" + options.get(name, "")
        for q in cls.parameters():
            for limit, bad, word in ((q.minimum, -1.0, ">="), (q.maximum, 1.0, "<=")):
                if limit is None:
                    continue
                value = limit + bad * max(1.0, abs(limit))
                text = "[effects.gravity]\n" * (name != "gravity") + table + f"{q.name} = {value!r}\n"
                assert _refused(text).startswith(f"s.toml: [effects.{name}] {q.name}: must be {word} {limit:g}, got")
                checked += 1
        for q in cls.starts():
            for limit, bad, word in ((q.minimum, -1.0, ">="), (q.maximum, 1.0, "<=")):
                if limit is None:
                    continue
                text = head + options.get(name, "") + f"[initial]\n{q.name} = {limit + bad!r}\n"
                said = SPEED_REFUSAL if abs(limit) == SPEED_OF_LIGHT else f"must be {word} {limit:g}"
                assert _refused(text).startswith(f"s.toml: [initial] {q.name}: {said}, got")
                checked += 1
    assert checked >= 15  # every >= 0 of the effects, slope_angle's two, restitution's two, height


@pytest.mark.parametrize("text, message", [
    ("[wheel]\nk_axial = 0.9\n", "s.toml: [wheel] k_axial: must be <= 2 k_diam (I_axial <= 2 I_diam for any rigid "
                                 "body), got 0.9 with k_diam 0.25"),
    ("[wheel]\nk_axial = 1.2\nk_diam = 1.0\n", "s.toml: [wheel] k_axial: must be <= 1 (a ring, all mass at radius R, "
                                               "is the limit), got 1.2"),
    ("[wheel]\nbeta_min_deg = 10\n[initial]\nbeta_deg = 5\n", "s.toml: [initial] beta_deg: must lie between beta_min "
                                                              "and pi - beta_min"),
    ("[wheel]\nbeta_min_deg = 10\n[initial]\nbeta_deg = 175\n", "s.toml: [initial] beta_deg: must lie between beta_min"),
])
def test_combined_ranges_are_refused_when_read(text, message):
    """The FMU's checks of more than one value, made by the reader too (model/build.py)."""
    assert _refused(text).startswith(message)


def test_the_reported_scene_fails_at_build_with_exit_2(tmp_path):
    """drop_bounce.toml with height = -0.1: `gyrowheel build` refuses it before anything is built."""
    scene = tmp_path / "drop.toml"
    text = (DOCS.parent / "examples" / "scenes" / "drop_bounce.toml").read_text()
    scene.write_text(text.replace("height = 0.1", "height = -0.1"))
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "build", str(scene), "-o", str(tmp_path / "d.fmu")],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr == f"gyrowheel: error: {scene}: [initial] height: must be >= 0, got -0.1\n"
    assert not (tmp_path / "d.fmu").exists()


def test_effect_angles_take_degrees():
    """slope_angle_deg (and every effect parameter in rad) as in [initial] and [wheel], and as
    `--set slope_angle_deg=...` (gyrowheel.simulation._angle_name: any variable of unit rad)."""
    scene = parse_scene("[effects.gravity]\n[effects.slope]\nslope_angle_deg = 5\nslope_direction_deg = 90\n")
    assert scene.effects["slope"] == {"slope_angle": math.radians(5), "slope_direction": math.radians(90)}
    assert _refused("[effects.gravity]\n[effects.slope]\nslope_angle_deg = 100\n") == \
        f"s.toml: [effects.slope] slope_angle_deg: must be <= 1.5, got {math.radians(100)!r} " \
        "(rad; given as slope_angle_deg = 100.0 deg)"
    assert _refused("[effects.gravity]\n[initial]\nbeta_deg = 200\n") == (
        "s.toml: [initial] beta_deg: must lie in (0, pi) (0 and pi are lying flat), "
        f"got {math.radians(200)!r} (rad; given as beta_deg = 200.0 deg)")
    assert _refused("[effects.gravity]\n[effects.slope]\nslope_angle = 0.1\nslope_angle_deg = 5\n") == \
        "s.toml: [effects.slope] slope_angle_deg: slope_angle given twice (in rad and in deg)"
    angles = [(name, q.name) for name, cls in CATALOGUE.items() for q in cls.parameters() if q.unit == "rad"]
    assert angles  # every one of them
    for name, key in angles:
        parse_scene(f"[effects.gravity]\n[effects.{name}]\n{key}_deg = 1.0\n")
    assert "slope_angle_deg" in _refused("[effects.gravity]\n[effects.slope]\nslope = 1\n")  # listed as valid


def test_set_takes_the_same_angle_names(example_build):
    from fmpy import read_model_description

    from gyrowheel.simulation import coerce_start_values
    fmu = example_build("slope_hold").fmu
    rad = [v.name for v in read_model_description(str(fmu)).modelVariables
           if v.unit == "rad" and v.causality == "parameter"]
    assert "slope_angle" in rad
    values = coerce_start_values(fmu, {f"{n}_deg": "2.5" for n in rad})
    assert values == {n: math.radians(2.5) for n in rad}
    with pytest.raises(gyrowheel.ArgumentError) as refused:  # the FMU checks in rad; named as given
        gyrowheel.simulate(fmu, start_values={"slope_angle_deg": 100}, stop_time=0.01)
    assert str(refused.value) == ("start_values: the FMU refused the start values: slope_angle must be <= 1.5; "
                                  f"slope_angle given as slope_angle_deg = 100 ({math.radians(100)!r} rad)")


DANGLING = re.compile(r"\b(it|or|and|the|a|an|to|of|with|set|remove|than|from|by|as|in|on|at|be|is)$")


def _complete(message: str) -> bool:
    """One sentence that does not stop mid-way: no dangling last word, brackets and quotes closed."""
    text = message.rstrip()
    bare = re.sub(r"'[^']*'", "", text)  # a quoted ']' or '(' is no bracket
    return (not DANGLING.search(text) and not text.endswith((":", ";", ",")) and bare.count("(") == bare.count(")")
            and bare.count("[") == bare.count("]") and bare.count('"') % 2 == 0)


def _conflict_messages() -> list[str]:
    """Every option conflict of every effect: each choice combination with each parameter present."""
    out = []
    for name, cls in CATALOGUE.items():
        choices = cls.choices()
        for combo in itertools.product(*choices.values()):
            chosen = dict(zip(choices, combo))
            for q in [None, *cls.parameters()]:
                options = {**chosen, **({q.name: q.start if q.maximum is None else q.maximum} if q else {})}
                conflict = cls.option_conflict(options)
                if conflict:
                    out.append(f"[effects.{name}] {conflict[0]}: {conflict[1]}")
    return out


def test_every_refusal_is_a_complete_sentence():
    """The reader's refusals (docs/scenes.md's table, this file's) and every option conflict of the
    catalogue: none is cut off ('remove it or set it')."""
    messages = [message for _, message in _refusal_rows()] + _conflict_messages()
    messages += [_refused(FLY + "[initial]\nvz = 1.0\n"), _refused("[wheel]\nk_axial = 0.9\n"),
                 _refused('[effects.gravity]\n[effects.contact_forces]\non_slip = "slide"\nrestitution = 0.5\n')]
    assert len(messages) > 60
    cut = [m for m in messages if not _complete(m)]
    assert not cut


def test_restitution_without_flight_says_what_to_set():
    assert _refused('[effects.gravity]\n[effects.contact_forces]\non_slip = "slide"\nrestitution = 0.5\n') == (
        "s.toml: [effects.contact_forces] restitution: is the touchdown's restitution of on_lift_off = \"fly\"; "
        "remove it or set on_lift_off = \"fly\" (with on_slip = \"slide\")")


def test_body_speeds_are_a_model_argument_not_a_scene_key():
    """docs/effects.md: speeds = "body" is build_model's argument (no scene key), refused with "fly"."""
    with pytest.raises(ValueError, match=r'"fly" needs speeds = "angle_rates"'):
        build_model(effects={"gravity": {}, "contact_forces": {"on_slip": "slide", "on_lift_off": "fly"}},
                    speeds="body")
    assert "unknown key" in _refused('[model]\nspeeds = "body"\n')
    text = (DOCS / "effects.md").read_text()
    at = text.index('speeds="body"')
    assert "build_model" in text[at - 60:at] and "no scene key" in text[at - 300:at]
