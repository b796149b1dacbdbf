"""Peers of the work-precision benchmark that integrate the base wheel in their own form.

- heyoka (PyPI `heyoka`, an adaptive Taylor method compiled with LLVM), one trajectory and
  batch mode (N trajectories advanced together, time per trajectory), on the minimal closed
  form of the wheel (benchmarks/minimal_wheel.h written as heyoka expressions);
- a plain C DOP853 around the same minimal hand-written RHS (benchmarks/plain_dop853.c);
- the high-precision reference: heyoka in 80-bit long double (tolerance 1e-19) on the same form.

The minimal form is written by hand here, for the benchmark only; `check_minimal` compares it
with the FMU's generated right-hand side at random states before anything is timed.  Shapes:
states are (8,) arrays (x, y, alpha, beta, gamma, alpha_dot, beta_dot, gamma_dot); `params` is
(M, R, k_diam, k_axial, g).
"""
from __future__ import annotations

import ctypes
import subprocess
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
C_SRC = HERE.parent / "c_src"


def minimal_rhs_numpy(x: np.ndarray, params) -> np.ndarray:
    """The minimal closed form (minimal_wheel.h) in numpy, for the check against the FMU."""
    _, R, kd, ka, g = params
    sa, ca, sb, cb = np.sin(x[2]), np.cos(x[2]), np.sin(x[3]), np.cos(x[3])
    ad, bd, gd = x[5], x[6], x[7]
    wn = gd + ad * cb
    add = bd * (ka * wn - 2 * kd * ad * cb) / (kd * sb)
    return np.array([R * (ca * wn - bd * sa * sb), R * (sa * wn + bd * ca * sb), ad, bd, gd, add,
                     -(sb * ad * ((1 + ka) * wn - kd * ad * cb) + g / R * cb) / (1 + kd),
                     (1 + 1 / (1 + ka)) * ad * bd * sb - add * cb])


def check_minimal(ode, params, p_fmu, u, rng_seed: int = 11, n: int = 20) -> float:
    """Largest relative difference between the minimal form and the model's `ode` at random states."""
    rng = np.random.default_rng(rng_seed)
    worst = 0.0
    for _ in range(n):
        x = rng.uniform(-2.0, 2.0, 8)
        x[3] = rng.uniform(0.2, np.pi - 0.2)
        a = np.array(ode(0.0, x, u, p_fmu)).ravel()
        b = minimal_rhs_numpy(x, params)
        worst = max(worst, float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(a))))))
    return worst


def _heyoka_system(params, fp=float):
    import heyoka as hy
    _, R, kd, ka, g = (fp(v) for v in params)
    one, two = fp(1), fp(2)
    x, y, a, b, c, ad, bd, gd = hy.make_vars("x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot",
                                             "gamma_dot")
    sa, ca, sb, cb = hy.sin(a), hy.cos(a), hy.sin(b), hy.cos(b)
    wn = gd + ad * cb
    add = bd * (ka * wn - two * kd * ad * cb) / (kd * sb)
    return [(x, R * (ca * wn - bd * sa * sb)), (y, R * (sa * wn + bd * ca * sb)), (a, ad), (b, bd), (c, gd),
            (ad, add), (bd, -(sb * ad * ((one + ka) * wn - kd * ad * cb) + g / R * cb) / (one + kd)),
            (gd, (one + one / (one + ka)) * ad * bd * sb - add * cb)]


def reference(x0: np.ndarray, params, stop: float) -> np.ndarray:
    """State at `stop` by heyoka in 80-bit long double at tolerance 1e-19 (rounded to double)."""
    import heyoka as hy
    ld = np.longdouble
    ta = hy.taylor_adaptive(_heyoka_system(params, ld), np.asarray(x0, dtype=ld), tol=ld(1e-19), fp_type=ld)
    ta.propagate_until(ld(stop))
    return np.asarray(ta.state, dtype=float)


class Heyoka:
    """heyoka on the minimal form: compile once per tolerance, then time propagate_until alone."""

    def __init__(self, params, x0: np.ndarray, stop: float):
        self.params, self.x0, self.stop = params, np.asarray(x0, dtype=float), stop
        self.compiled: dict = {}  # (tol, batch size) -> integrator: JIT-compiled once

    def single(self, tol: float, repeat: int) -> tuple[float, np.ndarray, int, int]:
        """One trajectory with taylor_adaptive, timed as a user calls it on the integrator it
        holds: set the time and the state, propagate_until, read the state (the JIT compilation,
        once per tolerance, not timed).  Returns (seconds, best of repeat; the final state (8,);
        the steps taken; the Taylor order)."""
        import heyoka as hy
        ta = self.compiled.get((tol, 1))
        if ta is None:
            ta = self.compiled[tol, 1] = hy.taylor_adaptive(_heyoka_system(self.params), self.x0, tol=tol)
        best, steps, x = float("inf"), 0, None
        for _ in range(repeat):
            t0 = time.thread_time()
            ta.time, ta.state[:] = 0.0, self.x0
            outcome = ta.propagate_until(self.stop)
            x = np.array(ta.state)
            best = min(best, time.thread_time() - t0)
            steps = int(outcome[3])
        return best, x, steps, int(ta.order)

    def batch(self, tol: float, n: int, repeat: int) -> tuple[float, np.ndarray]:
        """Time per trajectory of a batch of n copies of x0 (heyoka's SIMD batch mode)."""
        import heyoka as hy
        start = np.tile(self.x0[:, None], (1, n))
        ta = self.compiled.get((tol, n))
        if ta is None:
            ta = self.compiled[tol, n] = hy.taylor_adaptive_batch(_heyoka_system(self.params), start, tol=tol)
        best = float("inf")
        for _ in range(repeat):
            ta.set_time(0.0)
            ta.state[:] = start
            t0 = time.thread_time()
            ta.propagate_until(self.stop)
            best = min(best, time.thread_time() - t0)
        return best / n, np.array(ta.state[:, 0])


class PlainDop853:
    """The plain C DOP853 around the minimal RHS (benchmarks/plain_dop853.c), through ctypes."""

    def __init__(self, work: Path, compiler: str = "cc", flags=("-O2", "-fno-math-errno")):
        lib = work / "plain_dop853.so"
        subprocess.run([compiler, "-std=c99", *flags, "-shared", "-fPIC", f"-I{C_SRC}", f"-I{HERE}",
                        str(HERE / "plain_dop853.c"), "-o", str(lib), "-lm"], check=True)
        self.lib = ctypes.CDLL(str(lib))
        d = ctypes.POINTER(ctypes.c_double)
        self.lib.plain_dop853.argtypes = [d, d, ctypes.c_double, ctypes.c_double, ctypes.c_double,
                                          ctypes.c_double, ctypes.POINTER(ctypes.c_long)]
        self.stats = (ctypes.c_long * 3)()

    def run(self, params, x0: np.ndarray, stop: float, rtol: float, atol: float, repeat: int):
        p = (ctypes.c_double * 5)(*params)
        best, out = float("inf"), None
        for _ in range(repeat):
            x = (ctypes.c_double * 8)(*x0)
            t0 = time.thread_time()
            rc = self.lib.plain_dop853(p, x, 0.0, stop, rtol, atol, self.stats)
            best = min(best, time.thread_time() - t0)
            if rc != 0:
                raise RuntimeError(f"plain DOP853 failed (rtol {rtol:g})")
            out = np.array(x[:])
        return best, out
