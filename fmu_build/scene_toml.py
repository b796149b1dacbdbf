"""A checked Scene written as the scene file that reads back as it (docs/scenes.md, "Scenes as
Python objects"): check_scene ships it as the FMU's source when a Scene was made or changed in
Python."""
from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gyrowheel.fmu_build.scene import Scene


def _toml_string(text: str) -> str:
    """A TOML basic string: the quote, the backslash and control characters (but tab) escaped."""
    def char(c: str) -> str:
        if c in '"\\':
            return "\\" + c
        if (ord(c) < 32 and c != "\t") or ord(c) == 127:
            return f"\\u{ord(c):04x}"
        return c
    return '"' + "".join(map(char, text)) + '"'


def _toml_value(value) -> str:
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return repr(value)  # an int, or a finite float: Python's repr is a TOML float read back exactly


def scene_toml(scene: Scene) -> str:
    """The scene file of a checked Scene (check_scene): TOML whose parse_scene gives the same
    scene (angles in rad, presets as their numbers). Source: docs/scenes.md."""
    lines = ["# written by gyrowheel from a Scene object", "[model]"]
    lines += [f"{key} = {_toml_value(getattr(scene, key))}" for key in ("name", "description", "formulation")]

    def table(name: str, values: dict) -> None:
        lines.extend(["", f"[{name}]"] + [f"{key} = {_toml_value(value)}" for key, value in values.items()])

    table("wheel", scene.wheel)
    for effect, options in scene.effects.items():
        table(f"effects.{effect}", options)
    table("initial", scene.initial)
    table("experiment", {k: v for k, v in dataclasses.asdict(scene.experiment).items()
                         if v is not None})  # max_step None: its default, left to follow the run
    if scene.outputs is not None:
        table("outputs", {"keep": scene.outputs})
    build = {**({} if scene.platforms is None else {"platforms": scene.platforms}),
             **({} if scene.fmi == 2 else {"fmi": scene.fmi}),
             **({} if scene.arrays else {"arrays": False}),
             **({} if scene.taylor is None else {"taylor": scene.taylor})}
    if build:
        table("build", build)
    return "\n".join(lines) + "\n"
