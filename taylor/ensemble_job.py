"""The checks of an ensemble run's job (gyrowheel.taylor.ensemble.Ensemble.run) before the C
library sees it: the time span, the tolerances, max_step and the grid, each refused naming the
field (the library itself can only answer "bad job")."""
from __future__ import annotations

import math

import numpy as np

from gyrowheel import arguments
from gyrowheel.errors import ArgumentError
from gyrowheel.fmu_build.scene import TOLERANCE_RANGES

NO_GRID = np.zeros(0)
NO_GRID.flags.writeable = False


def numbers(v):
    """v as an array of numbers, ValueError otherwise (np.asarray(v, float) made None a NaN, and
    True a 1: a Boolean is no number here, as arguments.number refuses it)."""
    a = np.asarray(v)
    if a.dtype.kind == "O" and not any(x is None or isinstance(x, bool) for x in a.flat):  # numbers as objects
        return a.astype(float)  # (ValueError from a string among them)
    if a.dtype.kind not in "iuf":
        raise ValueError(v)  # the callers name the field
    return a


def check_job(t_start, t_end, rel_tol, abs_tol, max_step, grid) -> np.ndarray:
    """The job's numbers checked before the C library sees them (it can only say "bad job"):
    an ArgumentError naming the field, an ArgumentTypeError for one that is no number ('10', a
    string, is refused as every gyrowheel function refuses it: gyrowheel.arguments.number).
    Returns the grid as a contiguous float array (empty: grid None, no grid); a grid not 1-D
    is refused (ArgumentError naming its shape), not flattened, and so is an empty one.  Each
    error's `argument` names the field (None only for t_start and t_end both not finite).
    rel_tol and abs_tol outside the FMU's ranges (fmu_build.scene.TOLERANCE_RANGES) are refused
    here, once, rather than by every trajectory's instance.  (math.isfinite on the scalars:
    numpy's took 2 us of a small run.)"""
    def number(name, v):
        return arguments.number(v, name, finite=False)
    t0, t1, rtol = number("t_start", t_start), number("t_end", t_end), number("rel_tol", rel_tol)
    if not math.isfinite(t0) or not math.isfinite(t1):
        culprit = None if not (math.isfinite(t0) or math.isfinite(t1)) else "t_end" if math.isfinite(t0) else "t_start"
        raise ArgumentError(f"t_start and t_end must be finite, got {t0!r} and {t1!r}", argument=culprit)
    if not t1 > t0:
        raise ArgumentError(f"t_end = {t1!r} must be greater than t_start = {t0!r}", argument="t_end")
    if not (math.isfinite(rtol) and rtol > 0):
        raise ArgumentError(f"rel_tol must be a finite number > 0, got {rtol!r}", argument="rel_tol")
    lo, hi = TOLERANCE_RANGES["rel_tol"]
    if not lo <= rtol <= hi:  # the instances' own range: one error, not one per trajectory
        raise ArgumentError(f"rel_tol must be within [{lo!r}, {hi:g}] (10 eps to 1), got {rtol!r}",
                            argument="rel_tol")
    if abs_tol is not None:
        atol = number("abs_tol", abs_tol)
        if not (math.isfinite(atol) and atol >= 0):
            raise ArgumentError(f"abs_tol must be a finite number >= 0, got {atol!r}", argument="abs_tol")
        lo, hi = TOLERANCE_RANGES["abs_tol"]
        if atol != 0 and not lo <= atol <= hi:  # the instances' own range, once for the job
            raise ArgumentError(f"abs_tol must be 0 (rel_tol / 100) or within [{lo:g}, {hi:g}], got {atol!r}",
                                argument="abs_tol")
    if max_step is not None:
        hmax = number("max_step", max_step)
        if not (math.isfinite(hmax) and hmax > 0):
            raise ArgumentError(f"max_step must be a finite number > 0, got {hmax!r}", argument="max_step")
    if grid is None:
        return NO_GRID
    try:
        a = numbers(grid)
    except ValueError:
        raise ArgumentError(f"grid must be a sequence of communication points (numbers, s), got {grid!r}",
                            argument="grid") from None
    if a.ndim != 1:  # a nested list or a scalar: refused, not flattened
        raise ArgumentError(f"grid must be 1-D, a sequence of communication points (numbers, s), got shape "
                            f"{a.shape}", argument="grid")
    g = np.ascontiguousarray(a, dtype=float)
    if not g.size:  # no point at all, not even t_end: not the same as no grid
        raise ArgumentError(f"grid must hold the communication points up to t_end = {t1!r} (the last equal to it), "
                            "got none; leave grid out (None) for a run straight to t_end", argument="grid")
    if not np.all(np.isfinite(g)):
        raise ArgumentError("grid: communication points must be finite", argument="grid")
    if not (g[0] > t0 and np.all(np.diff(g) > 0)):
        raise ArgumentError(f"grid: communication points must increase strictly after t_start = {t0!r}",
                            argument="grid")
    if g[-1] != t1:
        raise ArgumentError(f"grid: the last communication point {float(g[-1])!r} must equal t_end = {t1!r}",
                            argument="grid")
    return g
