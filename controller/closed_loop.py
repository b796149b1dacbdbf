"""The Gyrover closed loop as a system: wheel FMU + controller FMU + SSP / OSP files.

build_closed_loop(scene) builds the wheel from its scene (the same path as `gyrowheel build`),
designs the controller on the scene's own model (controller/design.py) unless a design is
given, builds the controller FMU through the general path (model/system.py ->
fmu_build.builder.build_spec_fmu) and writes <name>.ssp. Connections are by name:
wheel outputs alpha, alpha_dot, beta, beta_dot, vx, vy, tilt -> controller inputs;
controller outputs tilt_cmd, drive_torque -> wheel inputs.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from controller.compensator import EXPERIMENT, controller_spec
from controller.design import Design, design
from controller.mission import Mission, standard
from cosim.system import Component, SystemDescription, connect_by_name, write_ssp
from fmu_build.builder import build_fmu, build_spec_fmu, model_spec
from fmu_build.scene import Scene

MEASURED = ("alpha", "alpha_dot", "beta", "beta_dot", "vx", "vy", "tilt")
COMMANDS = ("tilt_cmd", "drive_torque")


@dataclass
class ClosedLoop:
    system: SystemDescription
    design: Design
    wheel_fmu: Path
    controller_fmu: Path
    ssp: Path


def closed_loop_system(name: str, wheel_fmu: Path, controller_fmu: Path, stop_time: float = 60.0) -> SystemDescription:
    return SystemDescription(name, [Component("wheel", wheel_fmu), Component("controller", controller_fmu)],
                             connect_by_name("wheel", list(MEASURED), "controller")
                             + connect_by_name("controller", list(COMMANDS), "wheel"), stop_time=stop_time)


def build_controller_fmu(d: Design, mission: Mission, output: Path, name: str = "gyrover_controller") -> Path:
    """The controller FMU of a design (gains and mission as parameter start values)."""
    import json
    source = json.dumps({"design": d.scene, "speed": d.speed, "g": d.g, "mission": mission.points}, indent=1)
    return build_spec_fmu(controller_spec(d, mission, name), output, EXPERIMENT, source=source).fmu


def build_closed_loop(scene: Scene, out_dir: str | Path, mission: Mission | None = None, speed: float = 1.5,
                      d: Design | None = None, stop_time: float = 60.0) -> ClosedLoop:
    """Wheel and controller FMUs and the .ssp of the closed loop, in out_dir."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    mission = mission or standard(speed)
    d = d or design(model_spec(scene), speed, scene=scene.name)
    wheel = build_fmu(scene, out_dir / f"{scene.name}.fmu").fmu
    ctrl = build_controller_fmu(d, mission, out_dir / f"{scene.name}_controller.fmu",
                                name=f"{scene.name}_controller")
    system = closed_loop_system(f"{scene.name}_closed_loop", wheel, ctrl, stop_time)
    ssp = write_ssp(system, out_dir / f"{scene.name}_closed_loop.ssp")
    return ClosedLoop(system, d, wheel, ctrl, ssp)
