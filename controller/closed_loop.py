"""The Gyrover closed loop as a system: wheel FMU + controller FMU + SSP / OSP files.

build_closed_loop(scene) builds the wheel from its scene (the same path as `gyrowheel build`),
designs the gain-scheduled controller on the scene's own model (controller/schedule.py) unless a
schedule is given, builds the controller FMU through the general path (model/system.py ->
gyrowheel.fmu_build.builder.build_spec_fmu) and writes <name>.ssp; each FMU as FMI 2.0 or 3.0
(build_closed_loop's fmi). Connections are by name:
wheel outputs alpha, alpha_dot, beta, beta_dot, vx, vy, tilt -> controller inputs;
controller outputs tilt_cmd, drive_torque -> wheel inputs.
"""
from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from gyrowheel.controller.compensator import EXPERIMENT, controller_spec
from gyrowheel.controller.mission import Mission, standard
from gyrowheel.controller.schedule import Schedule, design_schedule, uniform
from gyrowheel.cosim.system import Component, SystemDescription, connect_by_name
from gyrowheel.cosim.ssp import write_ssp
from gyrowheel.errors import ArgumentError
from gyrowheel.fmu_build.builder import build_fmu, build_spec_fmu, check_fmi, model_spec
from gyrowheel.fmu_build.scene import Scene
from gyrowheel.model.spec import ModelSpec

MEASURED = ("alpha", "alpha_dot", "beta", "beta_dot", "vx", "vy", "tilt")
COMMANDS = ("tilt_cmd", "drive_torque")


@dataclass
class ClosedLoop:
    system: SystemDescription
    schedule: Schedule
    wheel_fmu: Path
    controller_fmu: Path
    ssp: Path

    @property
    def design(self):
        """The design at straight upright rolling (the schedule's centre)."""
        return self.schedule.centre


def closed_loop_system(name: str, wheel_fmu: Path, controller_fmu: Path, stop_time: float = 60.0) -> SystemDescription:
    return SystemDescription(name, [Component("wheel", wheel_fmu), Component("controller", controller_fmu)],
                             connect_by_name("wheel", list(MEASURED), "controller")
                             + connect_by_name("controller", list(COMMANDS), "wheel"), stop_time=stop_time)


def schedule_for(spec: ModelSpec, speed: float, mission: Mission, scene: str = "", rate_points: int = 5,
                 tilt_points: int = 9, **kw) -> Schedule:
    """The gain schedule a mission needs: heading rates up to 1.25 times the mission's largest
    (at least 0.1 rad/s), tilts over the gimbal's range (+-0.8 rad, a little beyond the 45 deg stop)."""
    rate_max = max(0.1, 1.25 * max(abs(p[1]) for p in mission.points))
    return design_schedule(spec, speed, uniform(rate_max, rate_points), uniform(0.8, tilt_points), scene=scene, **kw)


def build_controller_fmu(schedule: Schedule, mission: Mission, wheel: ModelSpec, output: Path,
                         name: str = "gyrover_controller", platforms=None, fmi: int = 2) -> Path:
    """The controller FMU of a schedule (gains built in, mission as parameter start values);
    platforms: the platforms it carries binaries for (build_spec_fmu; None: the host only);
    fmi: its FMI version, 2 or 3."""
    source = json.dumps({"design": schedule.scene, "speed": schedule.speed, "g": schedule.g, "rates": schedule.rates,
                         "tilts": schedule.tilts, "mission": mission.points}, indent=1)
    return build_spec_fmu(controller_spec(schedule, mission, wheel, name=name), output, EXPERIMENT, source=source,
                          platforms=platforms, fmi=fmi).fmu


def component_versions(fmi, default: int) -> dict[str, int]:
    """{"wheel": version, "controller": version} of build_closed_loop's fmi (see there)."""
    if fmi is None:
        return {"wheel": default, "controller": default}
    if not isinstance(fmi, Mapping):
        return dict.fromkeys(("wheel", "controller"), check_fmi(fmi))
    unknown = sorted(set(fmi) - {"wheel", "controller"})
    if unknown:
        raise ArgumentError(f"fmi: {unknown[0]!r} is not a component of the closed loop (wheel, controller)",
                            argument="fmi")
    return {c: check_fmi(fmi[c]) if c in fmi else default for c in ("wheel", "controller")}


def build_closed_loop(scene: Scene, out_dir: str | Path, mission: Mission | None = None, speed: float = 1.5,
                      schedule: Schedule | None = None, stop_time: float | None = None,
                      platforms=None, fmi: int | Mapping[str, int] | None = None) -> ClosedLoop:
    """Wheel and controller FMUs and the .ssp of the closed loop, in out_dir (stop time: the
    mission's duration unless given); both FMUs carry binaries for `platforms` (build_fmu:
    None: the scene's [build] platforms, else the host only). fmi: the FMI version of both
    FMUs (2 or 3), or per component ({"wheel": 3, "controller": 2}; one left out: the scene's);
    None: the scene's [build] fmi for both. The .ssp refers to each FMU by its file
    (resources/<component>.fmu) whatever its version. Raises ArgumentError for an fmi that is
    not 2 or 3 or names another component."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    mission = mission or standard(speed)
    spec = model_spec(scene)
    schedule = schedule or schedule_for(spec, speed, mission, scene=scene.name)
    platforms = scene.platforms if platforms is None else platforms
    versions = component_versions(fmi, scene.fmi)
    wheel = build_fmu(scene, out_dir / f"{scene.name}.fmu", platforms=platforms, fmi=versions["wheel"]).fmu
    ctrl = build_controller_fmu(schedule, mission, spec, out_dir / f"{scene.name}_controller.fmu",
                                name=f"{scene.name}_controller", platforms=platforms, fmi=versions["controller"])
    system = closed_loop_system(f"{scene.name}_closed_loop", wheel, ctrl, stop_time or mission.duration)
    ssp = write_ssp(system, out_dir / f"{scene.name}_closed_loop.ssp")
    return ClosedLoop(system, schedule, wheel, ctrl, ssp)
