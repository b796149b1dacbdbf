"""The Gyrover's closed loop on ice: hard braking in a turn, and turns, at mu = 0.1 .. 0.3 and dry.

    python examples/gyrover_ice.py --out results/ice
    python examples/gyrover_ice.py --out results/ice --mu 0.1 0.15 0.2 0.3

1. builds the earth closed loop of docs/system.md (its controller FMU, designed on the rolling
   wheel, and the rolling wheel FMU: the dry ground) and the wheel of
   examples/scenes/gyrover_ice.toml (the same Gyrover with on_slip = "slide", contact modes
   rolling and sliding; mu and mu_k are its parameters);
2. flies controller/surface.py's brake_and_turn mission (settle at 1.5 m/s; brake to 1.2 m/s
   over 1 s, the drive saturated; turn left at 0.5 rad/s; accelerate back to 1.5 m/s in a right
   turn at 0.5 rad/s), and two harder brakes: to 1.0 m/s over 4 s and over 1 s (the dry loop
   loses the last) at a 10 ms step on the dry ground (rolling wheel; and the sliding wheel at mu = 0.8)
   and on each mu (mu_k = 0.8 mu);
3. prints and writes (ice_summary.json, ice_<mu>.csv, ice.png) per surface: whether the loop held
   or where it was lost, the slip episodes, the largest slip speed, the lean envelope, the speed
   reached, and the physics checks (|F_t| = mu_k F_n while sliding, energy + dissipated -
   actuator work constant).
"""
from __future__ import annotations

import argparse
import json
import math
from dataclasses import asdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from fmpy.util import write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
from gyrowheel.controller.closed_loop import build_closed_loop  # noqa: E402
from gyrowheel.controller.mission import course  # noqa: E402
from gyrowheel.controller.surface import brake_and_turn, contact_report, mission_starts, surface_system  # noqa: E402
from gyrowheel.cosim.master import MasterError, run  # noqa: E402
from gyrowheel.fmu_build import load_scene  # noqa: E402
from gyrowheel.fmu_build.builder import build_fmu  # noqa: E402

STEP = 0.01
MU_K_RATIO = 0.8


def fly(system, mission, wheel_starts: dict):
    """One run of the mission; (data or None, stopped_by or the error)."""
    try:
        r = run(system, STEP, start_values={"wheel": wheel_starts, "controller": mission_starts(mission)})
        return r.data, r.stopped_by
    except MasterError as exc:
        return None, f"error: {exc}"


def plot(runs: dict, path: Path, mission) -> None:
    fig, ax = plt.subplots(2, 3, figsize=(15, 7.5))
    for i, (label, d) in enumerate(runs.items()):
        t, c = d["time"], f"C{i}"
        ax[0, 0].plot(d["wheel.x"], d["wheel.y"], c, label=label)
        ax[0, 1].plot(t, np.degrees(d["wheel.beta"] - math.pi / 2), c, label=label)
        ax[0, 2].plot(t, d["wheel.vx"] * np.cos(d["wheel.alpha"]) + d["wheel.vy"] * np.sin(d["wheel.alpha"]), c, label=label)
        if "wheel.slip_long" in d.dtype.names:
            ax[1, 0].plot(t, np.hypot(d["wheel.slip_long"], d["wheel.slip_lat"]), c, label=label)
            ax[1, 1].plot(t, np.hypot(d["wheel.F_long"], d["wheel.F_lat"]) / d["wheel.F_n"], c, label=label)
        ax[1, 2].plot(t, np.degrees(d["wheel.alpha"]), c, label=label)
    t = np.linspace(0, mission.duration + 5, 500)
    heading, _, speed = mission.evaluate(t)
    ax[0, 2].plot(t, speed, "k--", label="reference")
    ax[1, 2].plot(t, np.degrees(heading), "k--", label="reference")
    ax[0, 0].set_aspect("equal", adjustable="datalim")
    ax[0, 0].set(xlabel="x [m]", ylabel="y [m]", title="path")
    ax[0, 1].set(ylabel="lean beta - 90 [deg]")
    ax[0, 2].set(ylabel="speed along the heading [m/s]")
    ax[1, 0].set(ylabel="slip speed |v_slip| [m/s]")
    ax[1, 1].set(ylabel="friction use |F_t| / F_n")
    ax[1, 2].set(ylabel="heading [deg]")
    for a in ax.flat:
        a.grid(True, alpha=0.3)
        if a is not ax[0, 0]:
            a.set_xlabel("t [s]")
    ax[0, 0].legend(fontsize=8)
    fig.suptitle("Gyrover closed loop: hard braking, left turn, accelerating right turn; dry ground and ice (10 ms step)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results/ice")
    parser.add_argument("--mu", type=float, nargs="*", default=[0.1, 0.15, 0.2, 0.3],
                        help="static friction coefficients of the surfaces (mu_k = 0.8 mu)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    loop = build_closed_loop(load_scene(ROOT / "examples" / "scenes" / "gyrover_mission_earth.toml"), out / "earth",
                             course("earth"))
    ice = build_fmu(load_scene(ROOT / "examples" / "scenes" / "gyrover_ice.toml"), out / "gyrover_ice.fmu").fmu
    missions = {"brake 1.5 -> 1.2 m/s in 1 s": brake_and_turn(),
                "brake 1.5 -> 1.0 m/s in 4 s": brake_and_turn(braked=1.0, brake=4.0),
                "brake 1.5 -> 1.0 m/s in 1 s": brake_and_turn(braked=1.0, brake=1.0)}
    stop = 25.0
    surfaces = {"dry (rolling wheel)": (surface_system(loop.wheel_fmu, loop.controller_fmu, stop), {}, None)}
    for mu in [0.8] + list(args.mu):
        label = "dry (mu 0.8)" if mu == 0.8 else f"ice mu {mu:g}"
        surfaces[label] = (surface_system(ice, loop.controller_fmu, stop), {"mu": mu, "mu_k": MU_K_RATIO * mu}, mu)
    summary = {}
    for k, (name, mission) in enumerate(missions.items()):
        summary[name], runs = {}, {}
        print(f"== {name}, then a left turn and an accelerating right turn at 0.5 rad/s")
        for label, (system, starts, mu) in surfaces.items():
            data, stopped = fly(system, mission, starts)
            if data is None:
                summary[name][label] = {"error": stopped}
                print(f"{label}: FAILED: {stopped}")
                continue
            runs[label] = data
            lean = np.degrees(data["wheel.beta"] - math.pi / 2)
            actuators = (f"tilt_cmd peak {np.degrees(np.abs(data['controller.tilt_cmd'])).max():.1f} deg, "
                         f"drive peak {np.abs(data['controller.drive_torque']).max():.4f} N m")
            if mu is None:
                state = f"LOST at {data['time'][-1]:.2f} s ({stopped})" if stopped else f"up {data['time'][-1]:.0f} s"
                print(f"{label}: {state}; lean {lean.min():+.2f}..{lean.max():+.2f} deg; {actuators}")
                summary[name][label] = {"up_s": float(data["time"][-1]), "stopped_by": stopped,
                                        "lean_min": float(lean.min()), "lean_max": float(lean.max())}
                continue
            rep = contact_report(data, stopped, MU_K_RATIO * mu)
            summary[name][label] = asdict(rep)
            print(f"{label}: {rep.line()}; {actuators}; |F_t| = mu_k F_n to {rep.friction_law_error:.1e}, "
                  f"energy balance {rep.energy_drift:.1e}")
            if k == 0:
                write_csv(str(out / f"ice_{mu:g}.csv"), data)
        if k == 0:
            plot(runs, out / "ice.png", mission)
    (out / "ice_summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
