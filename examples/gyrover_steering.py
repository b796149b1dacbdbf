"""Steer the Gyrover by tilting its flywheel (scene examples/scenes/gyrover_steering.toml).

The tilt (Xu & Ou's beta_a) turns the flywheel's spin axis about the assembly's fore-aft axis m_p,
from the axle towards the pendulum link: its angular momentum H_f tips out of the horizontal. The
yaw momentum of the whole Gyrover stays (nearly) what it was, so the wheel leans the other way
until the vertical components cancel, H_f sin(tilt) + (H_w + H_f) sin(lean) = 0 (H_w = I_axial
gamma_dot, the wheel's spin momentum), and the lean turns it steadily, as a leaning rolling
wheel does: a held tilt is a steady turn (docs/effects.md, gyrover).

The FMU's input tilt_cmd follows a profile: straight for 1 s, a slow tilt to -0.3 rad (with the
flywheel co-rotating with the wheel, the wheel leans left and turns left), slowly over to +0.3 rad
(leans and turns right), then back to zero. The script writes the trajectory and a figure of the
path, heading, lean and tilt, and prints each held tilt's lean against the momentum prediction.

    python examples/gyrover_steering.py --out results
"""
from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from fmpy import simulate_fmu  # noqa: E402
from fmpy.util import write_csv  # noqa: E402

from gyrowheel.fmu_build import build_fmu, load_scene  # noqa: E402

HERE = Path(__file__).resolve().parent
# (time, tilt_cmd): slow ramps, so that the open-loop tilt excites little wobble
PROFILE = [(0.0, 0.0), (1.0, 0.0), (4.0, -0.3), (8.0, -0.3), (14.0, 0.3), (18.0, 0.3), (21.0, 0.0), (24.0, 0.0)]


def tilt_profile() -> np.ndarray:
    """tilt_cmd(t) as fmpy's input signal (linear between the points); no drive torque."""
    return np.array([(t, tilt, 0.0) for t, tilt in PROFILE],
                    dtype=[("time", np.float64), ("tilt_cmd", np.float64), ("drive_torque", np.float64)])


def plot(r: np.ndarray, path: Path) -> None:
    """Write the figure: path [m], heading, lean and the tilt with its command [deg] against time [s]."""
    fig = figure(r)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def figure(r: np.ndarray):
    """The matplotlib Figure plot writes; r: fmpy's result with x, y, alpha, beta, tilt, tilt_cmd."""
    fig, ax = plt.subplots(2, 2, figsize=(10, 7))
    ax[0, 0].plot(r["x"], r["y"])
    ax[0, 0].set_aspect("equal", adjustable="datalim")
    ax[0, 0].set_xlabel("x [m]")
    ax[0, 0].set_ylabel("y [m]")
    ax[0, 0].set_title("path")
    for a, name, label in ((ax[0, 1], "alpha", "heading alpha [deg]"), (ax[1, 0], "beta", "lean beta [deg]"),
                           (ax[1, 1], "tilt", "flywheel tilt [deg]")):
        a.plot(r["time"], np.degrees(r[name]), label=name)
        a.set_xlabel("t [s]")
        a.set_ylabel(label)
    ax[1, 1].plot(r["time"], np.degrees(r["tilt_cmd"]), "--", label="tilt_cmd")
    ax[1, 1].legend(loc="best")
    for a in ax.flat:
        a.grid(True, alpha=0.3)
    fig.suptitle("Gyrover: flywheel tilt steers the wheel")
    fig.tight_layout()
    return fig


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fmu = build_fmu(load_scene(HERE / "scenes" / "gyrover_steering.toml"), out / "gyrover_steering.fmu").fmu
    r = simulate_fmu(str(fmu), stop_time=PROFILE[-1][0], input=tilt_profile(),
                     output=["x", "y", "alpha", "beta", "tilt", "tilt_cmd", "gamma_dot", "flywheel_momentum",
                             "energy", "actuator_work"])
    write_csv(str(out / "gyrover_steering.csv"), r)
    plot(r, out / "gyrover_steering.png")
    scene = load_scene(HERE / "scenes" / "gyrover_steering.toml")
    I_axial = scene.wheel["k_axial"] * scene.wheel["M"] * scene.wheel["R"] ** 2
    for t0, t1, side in ((5.0, 8.0, "left"), (15.0, 18.0, "right")):
        held = (r["time"] >= t0) & (r["time"] < t1)
        rate = np.polyfit(r["time"][held], r["alpha"][held], 1)[0]
        H_w, H_f = I_axial * r["gamma_dot"][held].mean(), r["flywheel_momentum"][held].mean()
        tilt = r["tilt"][held].mean()
        predicted = -np.arcsin(H_f * np.sin(tilt) / (H_w + H_f))
        print(f"tilt held at {np.degrees(tilt):+.1f} deg ({t0:g}-{t1:g} s): mean lean "
              f"{np.degrees(r['beta'][held].mean() - np.pi / 2):+.2f} deg (the spin momenta alone predict "
              f"{np.degrees(predicted):+.2f}), steady turn {np.degrees(rate):+.1f} deg/s to the {side}")
    print(f"wrote {out / 'gyrover_steering.csv'} and {out / 'gyrover_steering.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
