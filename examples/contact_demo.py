"""The contact modes: the wheel sliding on ice and dropped to bounce (docs/effects.md, "Sliding",
"Flight").

Builds the FMUs of examples/scenes/ice_slide.toml and drop_bounce.toml with gyrowheel.build,
runs each to its scene's stop time with gyrowheel.simulate (Co-Simulation), writes the results
as CSV and one figure: centre height, slip speed and contact_mode (the FMU's Enumeration
ContactMode: rolling, sliding, flight) against time; prints each run's mode switches and how
well energy + dissipated_energy is kept.

    python examples/contact_demo.py --out results/contact [--png FIGURE]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import gyrowheel  # noqa: E402

HERE = Path(__file__).resolve().parent
SCENES = ("ice_slide", "drop_bounce")


def switches(r: np.ndarray, items: dict[str, int]) -> list[tuple[float, str]]:
    """[(time, mode)]: the mode at the start, then at each recorded point where it changed
    (times to the output interval; the FMU locates each switch exactly inside its step)."""
    names = {value: name for name, value in items.items()}
    mode = r["contact_mode"]
    changed = [0] + [i for i in range(1, len(mode)) if mode[i] != mode[i - 1]]
    return [(float(r["time"][i]), names[int(mode[i])]) for i in changed]


def summarise(name: str, r: np.ndarray, items: dict[str, int], seconds: float) -> str:
    balance = r["energy"] + r["dissipated_energy"]
    drift = float(np.max(np.abs(balance - balance[0])) / abs(balance[0]))
    modes = ", ".join(f"{mode} from {t:.3f} s" for t, mode in switches(r, items))
    return (f"{name:<12} {modes}; dissipated {r['dissipated_energy'][-1]:.4f} J, "
            f"energy + dissipated kept to {drift:.1e}  ({seconds:.1f} s)")


def slip_speed(r: np.ndarray) -> np.ndarray:
    """|v_slip| (m/s): the contact point's slip, 0 while rolling and in flight."""
    return np.hypot(r["slip_long"], r["slip_lat"])


def figure(results: dict[str, np.ndarray], items: dict[str, dict[str, int]], png: Path) -> Path:
    """Centre height z (and, in a scene with flight, the rim's height above the ground), slip speed
    and contact mode against time, one column per scene."""
    fig, axes = plt.subplots(3, len(results), figsize=(5.2 * len(results), 8.5), squeeze=False, sharex="col")
    for col, (name, r) in enumerate(results.items()):
        t = r["time"]
        ax = axes[0, col]
        ax.plot(t, r["z"], lw=1.0, label="centre z")
        if "height" in r.dtype.names:
            ax.plot(t, r["height"], lw=1.0, ls="--", label="lowest rim point")
        ax.set_ylabel("height [m]")
        ax.set_title(name)
        ax.legend(fontsize=7)
        axes[1, col].plot(t, slip_speed(r), lw=1.0)
        axes[1, col].set_ylabel("slip speed [m/s]")
        ax = axes[2, col]
        ax.step(t, r["contact_mode"], where="post", lw=1.0)
        ax.set_yticks(list(items[name].values()), list(items[name]))
        ax.set_ylim(-0.3, max(items[name].values()) + 0.3)
        ax.set_ylabel("contact_mode")
        ax.set_xlabel("t [s]")
        for a in axes[:, col]:
            a.grid(True, alpha=0.3)
    fig.suptitle("contact modes: sliding on ice, dropped and bouncing to rest")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)
    return png


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results/contact", help="output directory")
    parser.add_argument("--png", help="the figure (default: OUT/contact_modes.png)")
    args = parser.parse_args()
    out = Path(args.out)
    (out / "fmus").mkdir(parents=True, exist_ok=True)  # the library writes only into directories that exist
    results, items = {}, {}
    for name in SCENES:
        built = gyrowheel.build(HERE / "scenes" / f"{name}.toml", out / "fmus" / f"{name}.fmu")
        items[name] = gyrowheel.info(built.fmu).variable("contact_mode").items
        t0 = time.perf_counter()
        results[name] = gyrowheel.simulate(built.fmu, output=out / f"{name}.csv")
        print(summarise(name, results[name], items[name], time.perf_counter() - t0))
    png = Path(args.png) if args.png else out / "contact_modes.png"
    png.parent.mkdir(parents=True, exist_ok=True)
    print(f"wrote {', '.join(str(out / f'{name}.csv') for name in SCENES)}")
    print(f"wrote {figure(results, items, png)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
