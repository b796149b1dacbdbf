"""The paper's section 4: the unactuated wheel on earth, Mars and the moon for 20 s.

Builds one FMU per scene (examples/scenes/paper_*.toml), simulates each in
Co-Simulation with fmpy, writes the trajectories as CSV and one figure in the
spirit of the paper's Figs. 7-9, and prints what happened.

    python examples/paper_demo.py --out results [--png FIGURE]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from fmpy.util import write_csv

from gyrowheel.fmu_build import build_fmu, load_scene
from gyrowheel.studies.analysis import fit_circle, relative_energy_drift
from gyrowheel.plotting import plot_trajectories
from gyrowheel.simulation import run

HERE = Path(__file__).resolve().parent
SCENES = {"earth": "paper_earth.toml", "Mars": "paper_mars.toml", "moon": "paper_moon.toml"}


def summarise(name: str, r: np.ndarray, seconds: float) -> str:
    beta = np.degrees(r["beta"])
    radius = fit_circle(r["x"], r["y"])[2]
    drift = relative_energy_drift(r["energy"])
    fell = bool(r["fallen"][-1])
    end = f"fell flat at t = {r['time'][-1]:.3f} s" if fell else f"still rolling at t = {r['time'][-1]:.1f} s"
    return (f"{name:<6} lean {beta.min():6.1f} .. {beta.max():5.1f} deg, path radius {radius:5.2f} m, "
            f"energy drift {drift:.1e}, {end}  ({seconds * 1e3:.0f} ms)")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results", help="output directory")
    parser.add_argument("--png", help="the figure (default: OUT/paper_trajectories.png; "
                        "docs/img/paper_trajectories.png is this figure)")
    args = parser.parse_args()
    out = Path(args.out)
    (out / "fmus").mkdir(parents=True, exist_ok=True)
    results = {}
    for name, scene_file in SCENES.items():
        scene = load_scene(HERE / "scenes" / scene_file)
        fmu = build_fmu(scene, out / "fmus" / f"{scene.name}.fmu").fmu
        t0 = time.perf_counter()
        r = run(fmu)
        seconds = time.perf_counter() - t0
        write_csv(str(out / f"{scene.name}.csv"), r)
        results[name] = r
        print(summarise(name, r, seconds))
    png = Path(args.png) if args.png else out / "paper_trajectories.png"
    png.parent.mkdir(parents=True, exist_ok=True)  # the library writes only into directories that exist
    fig = plot_trajectories(results, png,
                            title="Gyrover wheel, beta0 = 80 deg, gamma_dot0 = 6 rad/s (Nandy & Xu, Figs. 7-9)")
    print(f"wrote {', '.join(str(out / (load_scene(HERE / 'scenes' / s).name + '.csv')) for s in SCENES.values())}")
    print(f"wrote {fig}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
