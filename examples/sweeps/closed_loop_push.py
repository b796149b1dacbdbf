"""`--derive` helper of the closed-loop Monte Carlo (examples/sweeps/monte_carlo.py --closed-loop).

    lean_deg = 0    the Gyrover starts upright (beta = 90 deg) and flies the mission
    lean_deg = -5   the mission's disturbance: a 5 deg lean with zero heading rate, as
                    examples/gyrover_control.py starts it (a yaw momentum the
                    controller holds with a tilt, docs/system.md)
"""
import math


def start(point, values):
    lean = math.radians(point["lean_deg"])
    return {"beta": math.pi / 2 + lean, "alpha_dot": 0.0}
