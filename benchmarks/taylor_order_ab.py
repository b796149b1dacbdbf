"""The order rule of solver taylor, measured: time to reach each error for several rules.

Builds each scenario's FMU once (taylor=True), then recompiles its own sources into variants:
  now       the sources as they are
  REV       with --base REV (a git revision or a checkout directory, either layout:
            benchmarks/ref_tree.py): REV's gw_solver_taylor.c and gw_solver.h in their place,
            and the Taylor kernel of REV's generator (gw_taylor_model.h as REV writes it, REV's
            gw_taylor_ops.h and gw_taylor.c): the step rule and the kernel before a change, in
            the same run
  +k        the same sources with -DGW_TAYLOR_EXTRA_ORDER=k (a fixed k orders above p0)
and times every variant at every (rel_tol, abs_tol) interleaved (one fmi2DoStep through fmpy,
thread CPU time, best of --repeat), with heyoka on the same graph as the peer (the references and
the graph translation of taylor_vs_heyoka.py).  Prints per variant: order, steps and error per
rel_tol, and the cheapest time to each target error with its ratio to heyoka's.  Timings on a
loaded machine are noisy; the ratios come from one run.

    python benchmarks/taylor_order_ab.py [--scenarios paper near_flat long] [--extra 0 2 4]
                                         [--base main] [--repeat 7]
"""
from __future__ import annotations

import argparse
import re
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from fmi_slave import FmuRunner, solver_counts  # noqa: E402
from ref_tree import RefTree  # noqa: E402
from taylor_vs_heyoka import SameGraph, rows_against_heyoka  # noqa: E402
from work_precision import SCENARIOS  # noqa: E402

from gyrowheel.fmu_build import build_fmu, parse_scene  # noqa: E402
from gyrowheel.fmu_build.codegen import taylor_ode  # noqa: E402
from gyrowheel.fmu_build.compiler import UNITY_SOURCE, compile_shared  # noqa: E402

TARGETS = (1e-4, 1e-7, 1e-10, 1e-12)
TOLS = [10.0 ** -k for k in range(3, 15)]
TAYLOR = 6


def variant(fmu: Path, work: Path, name: str, flags: list[str], base: RefTree | None, built=None) -> Path:
    """The FMU with its binary recompiled from its own sources (plus `flags`, or the solver files
    and the kernel of the version `base`), zipped as work/<name>.fmu."""
    from fmpy import extract
    from taylor_kernel_bench import baseline_source
    d = Path(extract(str(fmu), unzipdir=str(work / name)))
    src = d / "sources"
    if base:
        for f in ("gw_solver_taylor.c", "gw_solver.h"):
            shutil.copy(base.file(f"c_src/{f}"), src / f)
        kernel = work / f"{name}_kernel"
        baseline_source(base, taylor_ode(built.spec.functions()), built.spec.name, kernel)
        for f in ("gw_taylor_model.h", "gw_taylor_ops.h", "gw_taylor.c"):
            shutil.copy(kernel / f, src / f)
        # model_desc.c's work size n_var and constants n_cst: the larger of this tree's and REV's
        # kernel's (a REV with more nodes wrote past this tree's work array: a heap corruption)
        head = (kernel / "gw_taylor_model.h").read_text()
        nx = int(re.search(r"#define GW_TL_NX (\d+)", head)[1])
        need = nx + int(re.search(r"#define GW_TL_NVAR \(GW_TL_NX \+ (\d+) \+ 1\)", head)[1]) + 1
        desc = (src / "model_desc.c").read_text()
        ncst = int(re.search(r"#define GW_TL_NCST (\d+)", head)[1])
        desc = re.sub(r"(\.taylor = \{gw_tl1_jet, gw_tl1_cst, )(\d+), (\d+)",
                      lambda m: f"{m[1]}{max(int(m[2]), need)}, {max(int(m[3]), ncst)}", desc)
        (src / "model_desc.c").write_text(desc)
    so = next((d / "binaries").rglob("*.so"))
    compile_shared(src / UNITY_SOURCE, [src], so, extra_flags=flags)
    out = work / f"{name}.fmu"
    shutil.make_archive(str(out.with_suffix("")), "zip", d)
    out.with_suffix(".zip").rename(out)
    return out


def run(name: str, work: Path, variants: dict[str, tuple[list[str], RefTree | None]], repeat: int) -> list[str]:
    text, stop = SCENARIOS[name]
    built = build_fmu(parse_scene(f'[model]\nname = "ab_{name}"\n' + text, f"{name}.toml"),
                      work / f"{name}.fmu", build_dir=work / name, taylor=True)
    g = SameGraph(built, stop)
    names, ref = g.names, g.ref

    fmus = {v: variant(built.fmu, work / name, f"{name}_{re.sub(r'[^0-9A-Za-z_.-]', 'x', v)}", fl, b, built)
            for v, (fl, b) in variants.items()}
    runners = {v: FmuRunner(path) for v, path in fmus.items()}
    pts: dict[str, list] = {v: [] for v in fmus}
    pts["heyoka"] = []
    info: dict[str, list[str]] = {v: [] for v in fmus}
    first = next(iter(fmus))
    same = {v: 0 for v in fmus}  # settings whose final states equal the first variant's bit for bit
    for tol in TOLS:
        for atol in (tol * 1e-2, tol):
            secs = {v: float("inf") for v in fmus}
            vals = {}
            for _ in range(repeat):  # interleaved: every variant once per round
                for v, r in runners.items():
                    vals[v] = r.one_step(stop, names, solver=TAYLOR, rel_tol=tol, abs_tol=atol, max_step=stop)
                    secs[v] = min(secs[v], r.last_seconds)
            for v in fmus:
                same[v] += vals[v] == vals[first]
                err = float(np.max(np.abs(np.array(vals[v]) - ref)))
                pts[v].append((secs[v], err))
                if atol == tol * 1e-2:
                    c = solver_counts(fmus[v], stop, solver=TAYLOR, rel_tol=tol, abs_tol=atol, max_step=stop)
                    info[v].append(f"{tol:.0e}: {c['accepted']} steps, err {err:.1e}, "
                                   f"{secs[v] * 1e3:.3g} ms")
        pts["heyoka"].append(g.time_heyoka(tol, stop, repeat)[:2])
    for r in runners.values():
        r.free()
    lines = [f"### {name} ({stop:g} s)", "", "| rule | " + " | ".join(f"err <= {t:g}" for t in TARGETS)
             + " | floor |", "|---|" + "---|" * (len(TARGETS) + 1)]
    lines += rows_against_heyoka(pts, TARGETS)
    lines.append("")
    lines += [f"{v}: final states bit for bit those of {first} at {same[v]} of {2 * len(TOLS)} settings"
              for v in fmus if v != first]
    for v, rows_ in info.items():
        lines.append(f"{v} (abs_tol = rel_tol/100): " + "; ".join(rows_))
    return lines + [""]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", nargs="*", default=["paper", "near_flat"],
                        choices=["paper", "long", "near_flat"])
    parser.add_argument("--extra", nargs="*", type=int, default=[], help="fixed extra orders to time")
    parser.add_argument("--base", help="git revision or checkout directory whose gw_solver_taylor.c / "
                        "gw_solver.h and Taylor kernel are the REV row")
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="gw-taylor-ab-") as tmp:
        variants: dict[str, tuple[list[str], RefTree | None]] = {"now": ([], None)}
        if args.base:
            variants[args.base] = ([], RefTree(args.base, Path(tmp)))
        for k in args.extra:
            variants[f"+{k}"] = ([f"-DGW_TAYLOR_EXTRA_ORDER={k}"], None)
        for name in args.scenarios:
            print("\n".join(run(name, Path(tmp), variants, args.repeat)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
