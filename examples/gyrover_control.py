"""The Gyrover closed loop, end to end: design, FMUs, .ssp, mission, failures, step study.

    python examples/gyrover_control.py --out results/system            # earth and moon, 60 s
    python examples/gyrover_control.py --out results/system --study    # + communication-step study

For each world (examples/scenes/gyrover_mission_<world>.toml):
1. linearise the wheel about upright rolling at 1.5 m/s, report open-loop eigenvalues against
   speed (eigenvalues_<world>.csv) and design the LQR + Kalman compensator; write the gains
   (gains_<world>.json: what the controller FMU is built with);
2. build wheel and controller FMUs and <world>_closed_loop.ssp (controller/closed_loop.py);
3. run the mission with gyrowheel's master at a 10 ms step from a 5 deg lean disturbance;
   write closed_loop_<world>.csv (every output, "<component>.<variable>"),
   closed_loop_<world>_wheel.csv (the wheel's outputs under their own names: the CSV
   `gyrowheel animate` reads) and closed_loop_<world>.png; print the lean envelope, tracking
   error and actuator peaks;
4. show where it fails: speed too low, gains too high, the literal lean disturbance (zero yaw
   rate, so nonzero yaw momentum), a figure eight;
5. (--study) tracking error, stability and wall time against the communication step.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from fmpy.util import write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from controller.closed_loop import build_closed_loop  # noqa: E402
from controller.design import closed_loop_matrix, design, plant_model, zero_yaw_momentum_rate  # noqa: E402
from controller.mission import figure_eight, standard  # noqa: E402
from cosim.master import run  # noqa: E402
from fmu_build import load_scene  # noqa: E402
from fmu_build.builder import model_spec  # noqa: E402

SPEED = 1.5
LEAN0 = math.radians(-5.0)  # beta0 = 85 deg
STEPS = (0.001, 0.002, 0.005, 0.01, 0.02, 0.05)


def metrics(d: np.ndarray, stopped_by, t_from: float = 5.0) -> dict:
    """Lean envelope [deg], heading tracking error [deg], actuator peaks, time up [s]."""
    lean = np.degrees(d["wheel.beta"] - math.pi / 2)
    after = d["time"] >= t_from
    err = np.degrees(d["controller.heading_error"])
    return {"up_s": float(d["time"][-1]), "fell": stopped_by is not None,
            "lean_min": float(lean.min()), "lean_max": float(lean.max()),
            "lean_after_max": float(np.abs(lean[after]).max()) if after.any() else float("nan"),
            "heading_err_rms": float(np.sqrt(np.mean(err[after] ** 2))) if after.any() else float("nan"),
            "heading_err_max": float(np.abs(err[after]).max()) if after.any() else float("nan"),
            "speed_err_max": float(np.abs(d["wheel.vx"] * np.cos(d["wheel.alpha"]) + d["wheel.vy"] * np.sin(d["wheel.alpha"])
                                          - d["controller.speed_ref"])[after].max()) if after.any() else float("nan"),
            "tilt_peak": float(np.degrees(np.abs(d["controller.tilt_cmd"]).max())),
            "drive_peak": float(np.abs(d["controller.drive_torque"]).max())}


def fmt(m: dict) -> str:
    state = f"FELL at {m['up_s']:.2f} s" if m["fell"] else f"up {m['up_s']:.0f} s"
    return (f"{state}; lean {m['lean_min']:+.2f}..{m['lean_max']:+.2f} deg (after 5 s |lean| <= "
            f"{m['lean_after_max']:.3f} deg); heading error rms {m['heading_err_rms']:.2f} max "
            f"{m['heading_err_max']:.2f} deg; speed error max {m['speed_err_max']:.3f} m/s; peaks: tilt_cmd "
            f"{m['tilt_peak']:.1f} deg, drive_torque {m['drive_peak']:.4f} N.m")


def wheel_csv(d: np.ndarray, path: Path) -> None:
    """The wheel's outputs under their own names (like `gyrowheel simulate`), plus the commands."""
    names = ["time"] + [n.split(".", 1)[1] for n in d.dtype.names if n.startswith("wheel.")]
    out = np.zeros(len(d), dtype=[(n, np.float64) for n in names + ["tilt_cmd", "drive_torque"]])
    out["time"] = d["time"]
    for n in names[1:]:
        out[n] = d[f"wheel.{n}"]
    out["tilt_cmd"], out["drive_torque"] = d["controller.tilt_cmd"], d["controller.drive_torque"]
    write_csv(str(path), out)


def plot(d: np.ndarray, path: Path, title: str) -> None:
    fig, ax = plt.subplots(2, 3, figsize=(14, 7))
    ax[0, 0].plot(d["wheel.x"], d["wheel.y"])
    ax[0, 0].set_aspect("equal", adjustable="datalim")
    ax[0, 0].set(xlabel="x [m]", ylabel="y [m]", title="path")
    t = d["time"]
    ax[0, 1].plot(t, np.degrees(d["wheel.alpha"]), label="heading")
    ax[0, 1].plot(t, np.degrees(d["controller.heading_ref"]), "--", label="reference")
    ax[0, 1].set(ylabel="heading [deg]")
    ax[0, 2].plot(t, np.degrees(d["wheel.beta"] - math.pi / 2))
    ax[0, 2].set(ylabel="lean beta - 90 [deg]")
    ax[1, 0].plot(t, np.degrees(d["wheel.tilt"]), label="tilt")
    ax[1, 0].plot(t, np.degrees(d["controller.tilt_cmd"]), "--", label="tilt_cmd")
    ax[1, 0].set(ylabel="flywheel tilt [deg]")
    ax[1, 1].plot(t, d["controller.drive_torque"])
    ax[1, 1].set(ylabel="drive_torque [N.m]")
    ax[1, 2].plot(t, d["wheel.vx"] * np.cos(d["wheel.alpha"]) + d["wheel.vy"] * np.sin(d["wheel.alpha"]), label="speed")
    ax[1, 2].plot(t, d["controller.speed_ref"], "--", label="reference")
    ax[1, 2].set(ylabel="speed [m/s]")
    for a in ax.flat:
        a.grid(True, alpha=0.3)
        if a is not ax[0, 0]:
            a.set_xlabel("t [s]")
        if a.get_legend_handles_labels()[0]:
            a.legend()
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def eigen_table(spec, d, path: Path) -> None:
    """Open-loop eigenvalues against speed, and the closed loop of the fixed gains there."""
    rows = ["speed_m_s,open_loop_max_real,open_loop_max_imag,closed_loop_max_real"]
    for v in (0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0):
        lm = plant_model(spec, v)
        ev = np.linalg.eigvals(lm.A)
        cl = np.linalg.eigvals(closed_loop_matrix(d, lm))
        cl = cl[np.abs(cl) > 1e-9]  # the two conserved directions stay at 0
        rows.append(f"{v},{ev.real.max():.4g},{np.abs(ev.imag).max():.4g},{cl.real.max():.4g}")
    path.write_text("\n".join(rows) + "\n")


def world(name: str, out: Path, study: bool) -> None:
    scene = load_scene(ROOT / "examples" / "scenes" / f"gyrover_mission_{name}.toml")
    spec = model_spec(scene)
    d = design(spec, SPEED, scene=scene.name)
    d.save(out / f"gains_{name}.json")
    eigen_table(spec, d, out / f"eigenvalues_{name}.csv")
    cl = build_closed_loop(scene, out / name, standard(SPEED), SPEED, d)
    disturbed = {"wheel": {"alpha_dot": zero_yaw_momentum_rate(d, LEAN0)}}
    r = run(cl.system, 0.01, start_values=disturbed)
    write_csv(str(out / f"closed_loop_{name}.csv"), r.data)
    wheel_csv(r.data, out / f"closed_loop_{name}_wheel.csv")
    plot(r.data, out / f"closed_loop_{name}.png", f"Gyrover closed loop on the {name}: 5 deg lean, 1.5 m/s, 10 ms step")
    print(f"[{name}] mission: {fmt(metrics(r.data, r.stopped_by))}")
    print(f"[{name}] regulator eigenvalues (largest real part): {max(e[0] for e in d.eig_regulator if abs(e[0]) > 1e-9 or abs(e[1]) > 1e-9):.3f} 1/s; "
          f"observer: {max(e[0] for e in d.eig_observer):.3f} 1/s; wall time {r.wall_time:.2f} s")
    failures = {
        "speed too low (0.5 m/s, gains of 1.5 m/s)": dict(start_values={"wheel": {**disturbed["wheel"], "gamma_dot": 0.5 / 0.17},
                                                                  "controller": {f"mission_speed_{k}": 0.5 for k in range(11)}}),
        "gains too high (gain_scale 20)": dict(start_values={**disturbed, "controller": {"gain_scale": 20.0}}),
        "literal lean disturbance (alpha_dot0 = 0: yaw momentum)": dict(start_values={}),
    }
    for label, kw in failures.items():
        f = run(cl.system, 0.01, **kw)
        print(f"[{name}] {label}: {fmt(metrics(f.data, f.stopped_by))}")
    eight = build_closed_loop(scene, out / f"{name}_eight", figure_eight(SPEED), SPEED, d)
    f = run(eight.system, 0.01, start_values=disturbed)
    print(f"[{name}] figure eight (radius 3 m): {fmt(metrics(f.data, f.stopped_by))}")
    if study:
        step_study(name, cl, disturbed, out)


def step_study(name, cl, disturbed, out: Path) -> None:
    """Tracking error, stability and wall time against the communication step."""
    lines = ["| step [ms] | stays up | lean after 5 s, max [deg] | heading error rms [deg] | tilt_cmd peak [deg] | wall time [s] |",
             "|---:|---|---:|---:|---:|---:|"]
    rows = []
    for h in STEPS:
        r = run(cl.system, h, start_values=disturbed)
        m = metrics(r.data, r.stopped_by)
        rows.append((h, m, r.wall_time))
        lines.append(f"| {h * 1e3:g} | {'no, fell at %.2f s' % m['up_s'] if m['fell'] else 'yes'} | "
                     f"{m['lean_after_max']:.3g} | {m['heading_err_rms']:.3g} | {m['tilt_peak']:.3g} | {r.wall_time:.2f} |")
    (out / f"step_study_{name}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    hs = [h * 1e3 for h, _, _ in rows]
    ax[0].loglog(hs, [max(m["heading_err_rms"], 1e-6) if not m["fell"] else np.nan for _, m, _ in rows], "o-", label="heading error rms [deg]")
    ax[0].loglog(hs, [max(m["lean_after_max"], 1e-6) if not m["fell"] else np.nan for _, m, _ in rows], "s-", label="max |lean| after 5 s [deg]")
    for h, m, _ in rows:
        if m["fell"]:
            ax[0].axvline(h * 1e3, color="r", alpha=0.3)
    ax[0].set(xlabel="communication step [ms]", title="accuracy (red: fell)")
    ax[0].legend()
    ax[1].loglog(hs, [w for _, _, w in rows], "o-")
    ax[1].set(xlabel="communication step [ms]", ylabel="wall time [s]", title="cost of 60 s")
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / f"step_study_{name}.png", dpi=90)
    plt.close(fig)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results/system")
    parser.add_argument("--worlds", nargs="*", default=["earth", "moon"])
    parser.add_argument("--study", action="store_true", help="also the communication-step study")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for w in args.worlds:
        world(w, out, args.study)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
