"""The Gyrover closed loop, end to end: design, FMUs, .ssp, mission, failures, step study.

    python examples/gyrover_control.py --out results/system            # earth and moon
    python examples/gyrover_control.py --out results/system --study    # + communication-step study
    python examples/gyrover_control.py --out results/system3 --fmi 3   # both FMUs as FMI 3.0

For each world (examples/scenes/gyrover_mission_<world>.toml; the scene's start is the mission's
disturbance: rolling upright at 1.5 m/s with a 5 deg lean and zero heading rate):
1. linearise the wheel about upright rolling at speeds 0.1-3 m/s: open-loop eigenvalues and
   controllability (eigenvalues_<world>.csv); design the gain schedule (45 LQG designs on steady
   turns, controller/schedule.py) and write it (gains_<world>.json: what the controller FMU is
   built with);
2. check the linear closed loop against the co-simulated one from a small lean (1 ms step);
3. build wheel and controller FMUs and <world>_closed_loop.ssp (controller/closed_loop.py);
4. fly the mission with gyrowheel's master at a 10 ms step: settle, a 90 deg turn to the left,
   a figure eight (a full circle left, one right) on circles of the world's radius; write
   closed_loop_<world>.csv (every output, "<component>.<variable>"), closed_loop_<world>_wheel.csv
   (the wheel's outputs under their own names: what `gyrowheel animate` reads) and
   closed_loop_<world>.png; print the lean envelope, tracking error and actuator peaks;
5. show where it fails: speed too low, gains too high, a course too tight for the world;
6. (--study) tracking error, stability and wall time against the communication step.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from fmpy.util import write_csv  # noqa: E402
from scipy.linalg import expm  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
from gyrowheel.controller.closed_loop import build_closed_loop, schedule_for  # noqa: E402
from gyrowheel.controller.design import closed_loop_matrix, controllable_basis, plant_model, sampled_spectral_radius  # noqa: E402
from gyrowheel.controller.mission import COURSES, standard  # noqa: E402
from gyrowheel.controller.surface import mission_starts  # noqa: E402
from gyrowheel.cosim.master import MasterError, run  # noqa: E402
from gyrowheel.fmu_build import load_scene  # noqa: E402
from gyrowheel.fmu_build.builder import model_spec  # noqa: E402

SPEED = 1.5
STEPS = (0.001, 0.002, 0.005, 0.01, 0.02, 0.03, 0.05)  # docs/system.md: it breaks between 20 and 30 ms


def metrics(d: np.ndarray, stopped_by, t_from: float = 5.0) -> dict:
    """Lean envelope [deg], heading tracking error [deg], actuator peaks, time up [s]."""
    lean = np.degrees(d["wheel.beta"] - math.pi / 2)
    after = d["time"] >= t_from
    err = np.degrees(d["controller.heading_error"])
    speed = d["wheel.vx"] * np.cos(d["wheel.alpha"]) + d["wheel.vy"] * np.sin(d["wheel.alpha"])

    def over(x, f):
        return float(f(x[after])) if after.any() else float("nan")
    return {"up_s": float(d["time"][-1]), "fell": stopped_by is not None, "stopped_by": stopped_by,
            "lean_min": float(lean.min()), "lean_max": float(lean.max()),
            "heading_err_rms": over(err, lambda e: np.sqrt(np.mean(e**2))),
            "heading_err_max": over(np.abs(err), np.max),
            "speed_err_max": over(np.abs(speed - d["controller.speed_ref"]), np.max),
            "tilt_peak": float(np.degrees(np.abs(d["controller.tilt_cmd"]).max())),
            "tilt_rate_peak": float(np.degrees(np.abs(d["wheel.tilt_rate"]).max())),
            "tilt_torque_peak": float(np.abs(d["wheel.tilt_torque"]).max()),
            "drive_peak": float(np.abs(d["controller.drive_torque"]).max()),
            "saturated_s": float(np.sum(d["controller.saturated"][1:] * np.diff(d["time"])))}


def fmt(m: dict) -> str:
    state = f"FELL at {m['up_s']:.2f} s ({m['stopped_by']})" if m["fell"] else f"up {m['up_s']:.0f} s"
    return (f"{state}; lean {m['lean_min']:+.2f}..{m['lean_max']:+.2f} deg; heading error after 5 s rms "
            f"{m['heading_err_rms']:.2f} max {m['heading_err_max']:.2f} deg; speed error max "
            f"{m['speed_err_max']:.3f} m/s; peaks: tilt_cmd {m['tilt_peak']:.1f} deg, tilt rate "
            f"{m['tilt_rate_peak']:.0f} deg/s, tilt_torque {m['tilt_torque_peak']:.3f} N.m, drive_torque "
            f"{m['drive_peak']:.4f} N.m; saturated {m['saturated_s']:.2f} s")


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
    ax[0, 0].plot(d["wheel.x"][:1], d["wheel.y"][:1], "o", label="start")
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
    ax[1, 1].plot(t, np.degrees(d["controller.heading_error"]))
    ax[1, 1].set(ylabel="heading error [deg]")
    ax[1, 2].plot(t, d["controller.drive_torque"], label="drive_torque [N.m]")
    ax[1, 2].plot(t, d["wheel.vx"] * np.cos(d["wheel.alpha"]) + d["wheel.vy"] * np.sin(d["wheel.alpha"]) - d["controller.speed_ref"],
                  label="speed error [m/s]")
    ax[1, 2].set(ylabel="drive torque [N.m], speed error [m/s]")
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


def eigen_table(spec, schedule, path: Path) -> list[str]:
    """Open-loop eigenvalues, controllability and the centre design's closed loop against speed."""
    d = schedule.centre
    rows = ["speed_m_s,open_loop_max_real,open_loop_max_abs_imag,controllable_dim,closed_loop_max_real,"
            "sampled_10ms_spectral_radius"]
    for v in (0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0):
        lm = plant_model(spec, v)
        ev = np.linalg.eigvals(lm.A)
        cl = np.linalg.eigvals(closed_loop_matrix(d, lm))
        cl = cl[np.abs(cl) > 1e-7]  # the conserved direction stays at 0
        z = sampled_spectral_radius(d, 0.01, lm)
        rows.append(f"{v},{ev.real.max():.4g},{np.abs(ev.imag).max():.4g},{controllable_basis(lm.A, lm.B).shape[1]},"
                    f"{cl.real.max():.4g},{z:.6f}")
    path.write_text("\n".join(rows) + "\n")
    return rows


def linear_check(cl, out: Path, name: str) -> str:
    """A 0.5 deg lean (zero heading rate) in the co-simulated loop at 1 ms against the linear closed
    loop [plant; observer] of the centre design: lean and heading over 3 s, and a figure."""
    d = cl.schedule.centre
    lean0 = math.radians(-0.5)
    r = run(cl.system, 0.001, stop_time=3.0, start_values={
        "wheel": {"beta": math.pi / 2 + lean0, "alpha_dot": 0.0},
        "controller": {f"mission_rate_{k}": 0.0 for k in range(len(standard().points))}})
    Acl = closed_loop_matrix(d)
    n = len(d.x_names)
    z0 = np.zeros(2 * n)
    z0[d.x_names.index("beta")] = lean0  # the observer starts at the operating point: x_hat = 0
    t = r.data["time"]
    lin = np.array([expm(Acl * tk) @ z0 for tk in t])
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.5))
    worst = {}
    for a, state, col in ((ax[0], "beta", "wheel.beta"), (ax[1], "alpha", "wheel.alpha")):
        sim = r.data[col] - (math.pi / 2 if state == "beta" else 0.0)
        a.plot(t, np.degrees(sim), label="co-simulation (1 ms)")
        a.plot(t, np.degrees(lin[:, d.x_names.index(state)]), "--", label="linear closed loop")
        a.set(xlabel="t [s]", ylabel=f"{'lean' if state == 'beta' else 'heading'} [deg]")
        a.grid(True, alpha=0.3)
        worst[state] = float(np.abs(sim - lin[:, d.x_names.index(state)]).max() / abs(lean0))
    ax[0].legend()
    fig.suptitle(f"{name}: closed-loop eigenvalues, linear model against co-simulation")
    fig.tight_layout()
    fig.savefig(out / f"linear_check_{name}.png", dpi=90)
    plt.close(fig)
    return (f"largest difference over 3 s, relative to the 0.5 deg start: lean {worst['beta']:.3f}, "
            f"heading {worst['alpha']:.3f}")


def fly(cl, step: float, **start) -> tuple[object, dict]:
    """Run the system; a component that fails (fmi2Error) counts as a fall at the last step."""
    try:
        r = run(cl.system, step, start_values=start or None)
        return r, metrics(r.data, r.stopped_by)
    except MasterError as exc:
        return None, {"up_s": float("nan"), "fell": True, "stopped_by": f"error: {exc}"}


def world(name: str, out: Path, study: bool, fmi=None) -> dict:
    scene = load_scene(ROOT / "examples" / "scenes" / f"gyrover_mission_{name}.toml")
    spec = model_spec(scene)
    course = COURSES[name]
    mission = standard(SPEED, course["radius"], ramp=course["ramp"])
    schedule = schedule_for(spec, SPEED, mission, scene=scene.name)
    schedule.save(out / f"gains_{name}.json")
    for row in eigen_table(spec, schedule, out / f"eigenvalues_{name}.csv"):
        print(f"[{name}] {row}")
    d = schedule.centre
    print(f"[{name}] centre design: regulator slowest {max(e[0] for e in d.eig_regulator if abs(complex(*e)) > 1e-7):.3f}, "
          f"fastest |lambda| {max(abs(complex(*e)) for e in d.eig_regulator):.1f}; observer slowest "
          f"{max(e[0] for e in d.eig_observer):.3f}, fastest {max(abs(complex(*e)) for e in d.eig_observer):.1f} 1/s")
    cl = build_closed_loop(scene, out / name, mission, SPEED, schedule, fmi=fmi)
    print(f"[{name}] linear check: {linear_check(cl, out, name)}")
    r, m = fly(cl, 0.01)
    if r is None:
        raise SystemExit(f"gyrover_control.py: the {name} mission failed: {m['stopped_by']}")
    write_csv(str(out / f"closed_loop_{name}.csv"), r.data)
    wheel_csv(r.data, out / f"closed_loop_{name}_wheel.csv")
    plot(r.data, out / f"closed_loop_{name}.png", f"Gyrover closed loop on the {name}: 5 deg lean at 1.5 m/s, "
         f"90 deg turn and figure eight (radius {course['radius']:g} m), 10 ms step")
    print(f"[{name}] mission: {fmt(m)}; wall time {r.wall_time:.2f} s")
    results = {"mission": m}
    R = scene.wheel["R"]

    def at_speed(v):  # the wheel and the observer's estimate start at v; the mission holds v
        return (0.01, dict(wheel={"gamma_dot": v / R},
                           controller={**mission_starts(standard(v, course["radius"], ramp=course["ramp"])),
                                       "est_gamma_dot": v / R}))
    tight = course["radius"] / 3
    failures = {
        "speed 1.0 m/s (gains of 1.5 m/s)": at_speed(1.0),
        "speed 0.75 m/s": at_speed(0.75),
        "speed 0.5 m/s": at_speed(0.5),
        "gain_scale 100, 10 ms step": (0.01, dict(controller={"gain_scale": 100.0})),
        "gain_scale 1, 20 ms step": (0.02, {}),
        "gain_scale 3, 20 ms step": (0.02, dict(controller={"gain_scale": 3.0})),
        f"course too tight (radius {tight:g} m)": (0.01, dict(controller=mission_starts(
            standard(SPEED, tight, ramp=course["ramp"])))),
    }
    if name == "moon":
        failures["the earth's course (radius 3 m, 1 s ramps)"] = (0.01, dict(controller=mission_starts(
            standard(SPEED, 3.0, ramp=1.0))))
    for label, (step, starts) in failures.items():
        _, f = fly(cl, step, **starts)
        results[label] = f
        print(f"[{name}] {label}: " + (fmt(f) if "lean_min" in f else f"FAILED: {f['stopped_by']}"))
    if study:
        results["steps"] = step_study(name, cl, out)
    (out / f"summary_{name}.json").write_text(json.dumps(results, indent=1) + "\n")
    return results


def step_study(name, cl, out: Path) -> list:
    """Tracking error, stability and wall time against the communication step (with the linear
    prediction: the spectral radius of the sampled linear closed loop of the centre design)."""
    lines = ["| step [ms] | stays up | lean envelope [deg] | heading error rms / max [deg] | tilt_cmd peak [deg] | "
             "sampled linear loop, spectral radius | wall time [s] |", "|---:|---|---:|---:|---:|---:|---:|"]
    rows = []
    for h in STEPS:
        r, m = fly(cl, h)
        z = sampled_spectral_radius(cl.schedule.centre, h)
        wall = r.wall_time if r is not None else float("nan")
        rows.append({"step": h, **m, "spectral_radius": float(z), "wall": wall})
        up = "yes" if not m["fell"] else (f"no, fell at {m['up_s']:.2f} s" if "lean_min" in m else "no (component error)")
        env = f"{m['lean_min']:+.1f} .. {m['lean_max']:+.1f}" if "lean_min" in m else "-"
        err = f"{m['heading_err_rms']:.3g} / {m['heading_err_max']:.3g}" if "lean_min" in m else "-"
        lines.append(f"| {h * 1e3:g} | {up} | {env} | {err} | {m.get('tilt_peak', float('nan')):.3g} | {z:.5f} | {wall:.2f} |")
    (out / f"step_study_{name}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    hs = [row["step"] * 1e3 for row in rows]
    ok = [not row["fell"] for row in rows]
    ax[0].loglog([h for h, k in zip(hs, ok) if k], [row["heading_err_rms"] for row, k in zip(rows, ok) if k], "o-",
                 label="heading error rms [deg]")
    ax[0].loglog([h for h, k in zip(hs, ok) if k], [row["heading_err_max"] for row, k in zip(rows, ok) if k], "s-",
                 label="heading error max [deg]")
    for h, k in zip(hs, ok):
        if not k:
            ax[0].axvline(h, color="r", alpha=0.3)
    ax[0].set(xlabel="communication step [ms]", ylabel="heading error [deg]", title=f"{name}: tracking (red: fell)")
    ax[0].legend()
    ax[1].loglog(hs, [row["wall"] for row in rows], "o-")
    ax[1].set(xlabel="communication step [ms]", ylabel="wall time [s]", title=f"cost of the {cl.system.stop_time:g} s mission")
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / f"step_study_{name}.png", dpi=90)
    plt.close(fig)
    return rows


def fmi_versions(text: str):
    """--fmi: '3' for both FMUs, or 'wheel=3,controller=2' per component."""
    if "=" not in text:
        return int(text)
    return {c.strip(): int(v) for c, v in (item.split("=", 1) for item in text.split(","))}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results/system")
    parser.add_argument("--worlds", nargs="*", default=["earth", "moon"], choices=sorted(COURSES),
                        help="worlds with a mission scene and a course (default: earth moon)")
    parser.add_argument("--study", action="store_true", help="also the communication-step study")
    parser.add_argument("--fmi", type=fmi_versions, metavar="VERSION",
                        help="FMI version of both FMUs (2 or 3), or per component, e.g. wheel=3,controller=2 "
                             "(default: the scene's [build] fmi)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for w in args.worlds:
        world(w, out, args.study, args.fmi)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
