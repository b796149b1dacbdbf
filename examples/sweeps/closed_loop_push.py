"""`--derive` helper of the closed-loop Monte Carlo (examples/sweeps/monte_carlo.py --closed-loop).

    lean_deg = 0    the Gyrover starts upright (beta = 90 deg) and flies the mission
    lean_deg = -5   the mission's disturbance: a 5 deg lean with the heading rate that gives the
                    NOMINAL wheel zero yaw momentum (controller.design.zero_yaw_momentum_rate), as
                    examples/gyrover_control.py starts it; a wheel whose mass or inertia differ
                    keeps a residual yaw momentum that no internal actuator can remove (docs/system.md)
"""
import math
from functools import lru_cache
from pathlib import Path

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "gyrover_mission_earth.toml"


@lru_cache(maxsize=None)
def _push_rate(lean: float) -> float:
    from controller.design import design, zero_yaw_momentum_rate
    from fmu_build import load_scene
    from fmu_build.builder import model_spec

    return zero_yaw_momentum_rate(design(model_spec(load_scene(SCENE)), 1.5, scene="gyrover_earth"), lean)


def start(point, values):
    lean = math.radians(point["lean_deg"])
    return {"beta": math.pi / 2 + lean, "alpha_dot": _push_rate(lean) if lean else 0.0}
