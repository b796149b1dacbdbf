"""The Gyrover's closed loop on a slippery surface: a braking-and-turning mission, the wheel built
with sliding contact (on_slip = "slide") paired with a controller built for rolling, and what the
run shows about the contact (slip episodes, slip speed, lean, friction law, energy balance).

The controller is the one of docs/system.md, unchanged: it was designed on the rolling wheel and
knows nothing of the surface. Only the wheel FMU differs (examples/scenes/gyrover_ice.toml); its
mu and mu_k are FMU parameters, so one build flies every surface (docs/system.md, "On ice").
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gyrowheel.controller.closed_loop import closed_loop_system
from gyrowheel.controller.mission import Mission
from gyrowheel.cosim.system import SystemDescription

SLIDING = 1  # contact_mode while sliding (model/contact_modes.py)


def brake_and_turn(speed: float = 1.5, braked: float = 1.2, brake: float = 1.0, rate: float = 0.5,
                   end: float = 25.0) -> Mission:
    """Settle at `speed` [m/s] for 4 s; brake to `braked` over `brake` s on the straight (the
    drive saturates: at the defaults the hardest stop the rolling loop survives, docs/system.md
    "On ice"); roll 1 s; turn left at `rate` [rad/s] (1 s ramps, 2 s held); straighten, roll 1 s;
    accelerate back to `speed` while turning right at `rate` (1 s ramps, 2 s held); straight to
    `end` [s]. Eleven points, as controller/mission.py's standard mission has, so a controller
    built for that one flies this one through its mission_* parameters (mission_starts).
    Raises ValueError for a brake that is not > 0 or an end before the last turn."""
    if not brake > 0:
        raise ValueError(f"brake must be > 0 s, got {brake:g}")
    e = 4.0 + brake
    if end <= e + 10.0:
        raise ValueError(f"end must be after the last turn ({e + 10.0:g} s), got {end:g}")
    pts = [(0.0, 0.0, speed), (4.0, 0.0, speed), (e, 0.0, braked), (e + 1, 0.0, braked), (e + 2, rate, braked),
           (e + 4, rate, braked), (e + 5, 0.0, braked), (e + 6, 0.0, braked), (e + 7, -rate, speed),
           (e + 9, -rate, speed), (e + 10, 0.0, speed)]
    return Mission(f"brake_and_turn_{speed:g}_{braked:g}_{brake:g}s", pts)


def mission_starts(mission: Mission) -> dict[str, float]:
    """The controller FMU's mission_* start values for `mission` (controller/compensator.py)."""
    return {k: v for i, (t, r, s) in enumerate(mission.points)
            for k, v in ((f"mission_t_{i}", t), (f"mission_rate_{i}", r), (f"mission_speed_{i}", s))}


def surface_system(wheel_fmu: str | Path, controller_fmu: str | Path, stop_time: float = 25.0) -> SystemDescription:
    """The closed loop of a wheel FMU (built from a scene with on_slip = "slide", or any Gyrover
    wheel with the measured outputs) and a controller FMU (controller/closed_loop.py)."""
    return closed_loop_system("gyrover_surface", Path(wheel_fmu), Path(controller_fmu), stop_time)


@dataclass
class ContactReport:
    """What a closed-loop run on a surface shows, from its recorded outputs (one row per
    communication step). Times in s, speeds in m/s, angles in deg, energies in J."""

    up_s: float  # time of the last row
    stopped_by: str | None  # component that ended the run (the controller's `lost`, a wheel's fall)
    slip_episodes: int  # maximal runs of rows in the sliding mode
    sliding_s: float  # time spent sliding (rows x step)
    first_slip_s: float  # nan without one
    slip_speed_max: float  # |(slip_long, slip_lat)|
    lean_min: float
    lean_max: float
    friction_law_error: float  # max | |F_t| - mu_k F_n | / (mu_k F_n) over sliding rows (0 without)
    friction_use_max_rolling: float  # max |F_t| / F_n over rolling rows
    energy_drift: float  # max |E + E_diss - W_act - (same at 0)| / max(E)
    speed_min: float  # along the heading
    finite: bool  # no NaN or inf in any output

    def line(self) -> str:
        state = (f"LOST at {self.up_s:.2f} s ({self.stopped_by})" if self.stopped_by
                 else f"up {self.up_s:.0f} s")
        first = f"first at {self.first_slip_s:.2f} s, " if self.slip_episodes else ""
        return (f"{state}; {self.slip_episodes} slip episodes ({first}{self.sliding_s:.2f} s sliding), "
                f"slip speed max {self.slip_speed_max:.3f} m/s; lean {self.lean_min:+.2f}..{self.lean_max:+.2f} deg; "
                f"speed min {self.speed_min:.3f} m/s; friction use max while rolling {self.friction_use_max_rolling:.3f}")


def contact_report(data: np.ndarray, stopped_by: str | None, mu_k: float) -> ContactReport:
    """ContactReport of a run's data (cosim.master.RunResult.data: time, wheel.<output>, ...).
    mu_k: the kinetic coefficient the wheel ran with. Needs the wheel's outputs contact_mode,
    slip_long, slip_lat, F_n, F_long, F_lat, beta, alpha, vx, vy, energy, dissipated_energy,
    actuator_work (a scene with contact_forces on_slip = "slide" and energy)."""
    w = {n.split(".", 1)[1]: data[n] for n in data.dtype.names if n.startswith("wheel.")}
    t = data["time"]
    sliding = np.rint(w["contact_mode"]) == SLIDING
    edges = np.diff(np.concatenate(([0], sliding.astype(int), [0])))
    episodes = int(np.sum(edges == 1))
    step = float(t[1] - t[0]) if len(t) > 1 else 0.0
    slip = np.hypot(w["slip_long"], w["slip_lat"])
    f_t = np.hypot(w["F_long"], w["F_lat"])
    law = np.abs(f_t[sliding] - mu_k * w["F_n"][sliding]) / (mu_k * w["F_n"][sliding]) if sliding.any() else np.zeros(1)
    rolling = ~sliding
    use = f_t[rolling] / w["F_n"][rolling] if rolling.any() else np.zeros(1)
    balance = w["energy"] + w["dissipated_energy"] - w["actuator_work"]
    lean = np.degrees(w["beta"] - math.pi / 2)
    speed = w["vx"] * np.cos(w["alpha"]) + w["vy"] * np.sin(w["alpha"])
    finite = all(np.isfinite(data[n]).all() for n in data.dtype.names)
    return ContactReport(
        up_s=float(t[-1]), stopped_by=stopped_by, slip_episodes=episodes, sliding_s=float(sliding.sum() * step),
        first_slip_s=float(t[sliding][0]) if sliding.any() else float("nan"),
        slip_speed_max=float(slip.max()), lean_min=float(lean.min()), lean_max=float(lean.max()),
        friction_law_error=float(law.max()), friction_use_max_rolling=float(use.max()),
        energy_drift=float(np.abs(balance - balance[0]).max() / np.abs(w["energy"]).max()),
        speed_min=float(speed.min()), finite=bool(finite))
