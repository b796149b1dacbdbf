"""Where an FMU build's time goes, with the build cache (GYROWHEEL_BUILD_CACHE) as the tests use it.

For each scene, at the test suite's -O1 (GYROWHEEL_OPTIMISE): the FMI 2 build without the cache,
then in a new empty cache the FMI 2 build (nothing cached yet), the FMI 3 build (the same
gw_funcs.c: its generation a hit, the compile of the other unity file a miss), and the FMI 2
build again in another directory (both hits).
Per build, seconds: the generated C (codegen.generate_functions), the host's compile
(compile_shared, a hit's: the preprocessing of the key and the copy) and the whole build.

    python benchmarks/build_phases.py gyrover_ice drop_bounce
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from gyrowheel.fmu_build import build_cache, build_fmu, builder, load_scene
from gyrowheel.fmu_build.compiler import OPTIMISE_ENV

ROOT = Path(__file__).resolve().parent.parent


def timed(module, name: str, seconds: list[float]):
    """module.name wrapped to add its run time to `seconds`."""
    fn = getattr(module, name)

    def wrapper(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            seconds.append(time.perf_counter() - t0)
    setattr(module, name, wrapper)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="+", help="names of examples/scenes/<name>.toml")
    ap.add_argument("--level", default="-O1", help="optimisation level (GYROWHEEL_OPTIMISE), default -O1")
    args = ap.parse_args()
    codegen_s: list[float] = []
    compile_s: list[float] = []
    timed(builder, "generate_functions", codegen_s)
    timed(builder, "compile_shared", compile_s)
    os.environ[OPTIMISE_ENV] = args.level
    print(f"{'scene':<16} {'build':<18} {'codegen s':>9} {'compile s':>9} {'total s':>8}")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenes:
            scene = load_scene(ROOT / "examples" / "scenes" / f"{name}.toml")
            for label, fmi in (("fmi 2, no cache", 2), ("fmi 2, cold", 2), ("fmi 3", 3), ("fmi 2 elsewhere", 2)):
                if label.endswith("no cache"):
                    os.environ.pop(build_cache.ENV, None)
                else:
                    os.environ[build_cache.ENV] = str(Path(tmp) / name / "cache")
                out = Path(tmp) / name / label.replace(" ", "_").replace(",", "")
                out.mkdir(parents=True)
                codegen_s.clear()
                compile_s.clear()
                t0 = time.perf_counter()
                build_fmu(scene, out / f"{name}.fmu", build_dir=out / "build", fmi=fmi)
                total = time.perf_counter() - t0
                print(f"{name:<16} {label:<18} {sum(codegen_s):9.2f} {sum(compile_s):9.2f} {total:8.2f}", flush=True)


if __name__ == "__main__":
    main()
