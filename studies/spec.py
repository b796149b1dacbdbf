"""The points of a sweep: grids and random samples, parsed and laid out as a table.

    --grid NAME=START:STOP:N        N evenly spaced values, both ends included (numpy.linspace)
    --grid NAME=START:STOP:N:log    N values evenly spaced in log (numpy.geomspace), START, STOP > 0
    --grid NAME=V1,V2,...           the listed values (numbers, or names: presets such as g=earth,
                                    enumeration items such as solver=rk4,dopri5)
    --random NAME=normal:MU:SIGMA   --samples draws from N(MU, SIGMA^2)
    --random NAME=uniform:A:B       --samples draws from U[A, B)

Grids multiply (the first one varies slowest, as in nested loops); the random samples are drawn
once with numpy's default_rng(seed), variable after variable in the order given, and the same
samples are crossed with every grid point (common random numbers: grid points differ only by
their grid values). The table keeps the names and values exactly as given (beta_deg stays in
degrees); conversion to FMU values happens in gyrowheel.studies.plan.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from gyrowheel.arguments import shown, whole
from gyrowheel.errors import ArgumentTypeError, SweepSpecError  # with gyrowheel's other errors: importable without pandas

DISTRIBUTIONS = {"normal": ("mu", "sigma"), "uniform": ("a", "b")}
MAX_POINTS = 10**7  # a typo such as 1:2:100000 x 1:2:100000 is refused, not allowed to fill the memory


@dataclass(frozen=True)
class Axis:
    """One grid axis: a name and its values (floats, or strings for presets/enumeration items)."""

    name: str
    values: tuple


@dataclass(frozen=True)
class RandomVariable:
    """One random input: distribution name and its two parameters."""

    name: str
    distribution: str
    a: float
    b: float

    def draw(self, rng: np.random.Generator, n: int) -> np.ndarray:
        if self.distribution == "normal":
            return rng.normal(self.a, self.b, n)
        return rng.uniform(self.a, self.b, n)


def _number(text: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise SweepSpecError(f"{where}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise SweepSpecError(f"{where}: {text!r} is not finite")
    return value


def _finite(value: float, where: str) -> float:
    """A value of a grid must be a number: NaN would read as "not set" and inf is no state."""
    if not math.isfinite(value):
        raise SweepSpecError(f"{where}: {value!r} is not finite")
    return value


def _split(item: str, flag: str) -> tuple[str, str]:
    if "=" not in item:
        raise SweepSpecError(f"{flag} {item!r}: expected NAME=SPEC")
    name, spec = (s.strip() for s in item.split("=", 1))
    if not name or not spec:
        raise SweepSpecError(f"{flag} {item!r}: expected NAME=SPEC")
    return name, spec


def parse_grid(item: str) -> Axis:
    """'beta_deg=60:89:30' -> Axis('beta_deg', 30 values); see the module docstring for the forms."""
    name, spec = _split(item, "--grid")
    where = f"--grid {item!r}"
    if ":" in spec:
        parts = spec.split(":")
        log = len(parts) == 4 and parts[3].strip() == "log"
        if len(parts) != 3 and not log:
            raise SweepSpecError(f"{where}: expected NAME=START:STOP:N, NAME=START:STOP:N:log or NAME=V1,V2,...")
        start, stop = _number(parts[0], where), _number(parts[1], where)
        try:
            n = int(parts[2])
        except ValueError:
            raise SweepSpecError(f"{where}: the number of values {parts[2]!r} is not an integer") from None
        if n < 1:
            raise SweepSpecError(f"{where}: the number of values must be >= 1, got {n}")
        if n > MAX_POINTS:  # before numpy makes the axis: 60:89:1000000000 would fill the memory
            raise SweepSpecError(f"{where}: {n} values, more than the {MAX_POINTS} points of one sweep "
                                 "(the table and the plan are held in memory); split it into several sweeps")
        if log:
            if start <= 0 or stop <= 0:
                raise SweepSpecError(f"{where}: a log grid needs START > 0 and STOP > 0")
            values = np.geomspace(start, stop, n)
        else:
            values = np.linspace(start, stop, n)
        return Axis(name, tuple(float(v) for v in values))
    values = []
    for text in spec.split(","):
        text = text.strip()
        if not text:
            raise SweepSpecError(f"{where}: empty value in the list")
        try:
            value = float(text)
        except ValueError:
            values.append(text)  # a preset or enumeration item, checked against the FMU later
            continue
        values.append(_finite(value, where))
    return Axis(name, tuple(values))


def parse_random(item: str) -> RandomVariable:
    """'M=normal:2:0.1' or 'M=uniform:1.6:2.4' -> RandomVariable."""
    name, spec = _split(item, "--random")
    where = f"--random {item!r}"
    parts = spec.split(":")
    if len(parts) != 3 or parts[0] not in DISTRIBUTIONS:
        raise SweepSpecError(f"{where}: expected NAME=normal:MU:SIGMA or NAME=uniform:A:B")
    a, b = _number(parts[1], where), _number(parts[2], where)
    if parts[0] == "normal" and b < 0:
        raise SweepSpecError(f"{where}: sigma must be >= 0, got {b:g}")
    if parts[0] == "uniform" and not b > a:
        raise SweepSpecError(f"{where}: uniform:A:B needs B > A")
    return RandomVariable(name, parts[0], a, b)


def as_axis(name: str, spec) -> Axis:
    """API form: a spec string ('0:20:41'), a number, or a sequence of values."""
    if isinstance(spec, str):
        return parse_grid(f"{name}={spec}")
    where = f"grid {name!r}"
    if isinstance(spec, (int, float)):
        return Axis(name, (_finite(float(spec), where),))
    if isinstance(spec, (Sequence, np.ndarray)) and len(spec):
        return Axis(name, tuple(v if isinstance(v, str) else _finite(float(v), where) for v in spec))
    raise SweepSpecError(f"grid {name!r}: expected 'START:STOP:N', a number or a non-empty sequence, got {spec!r}")


def as_random(name: str, spec) -> RandomVariable:
    """API form: 'normal:2:0.1' or a tuple ('normal', 2, 0.1)."""
    if isinstance(spec, str):
        return parse_random(f"{name}={spec}")
    if isinstance(spec, Sequence) and len(spec) == 3:
        return parse_random(f"{name}={spec[0]}:{spec[1]}:{spec[2]}")
    raise SweepSpecError(f"random {name!r}: expected 'normal:MU:SIGMA', 'uniform:A:B' or a 3-tuple, got {spec!r}")


def point_table(grid: Sequence[Axis] = (), random: Sequence[RandomVariable] = (), samples: int | None = None,
                seed: int = 0) -> pd.DataFrame:
    """The sweep's inputs, one row per point, columns named as given (index: point number).

    Shape: (prod(len(axis.values)) * samples, len(grid) + len(random)). Raises SweepSpecError for
    a name given twice, random variables without --samples, a seed or sample count that is not a
    whole number (>= 0, >= 1), or nothing to sweep.
    """
    names = [a.name for a in grid] + [r.name for r in random]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise SweepSpecError(f"{', '.join(dup)} given more than once (in --grid/--random)")
    # (numpy's own message for a bad seed named no field)
    seed = whole(seed, "--seed", minimum=0, what="a whole number >= 0 (numpy's default_rng)", error=SweepSpecError)
    if random and not samples:
        raise SweepSpecError("--random needs --samples N (N >= 1)")
    if samples is not None:
        samples = whole(samples, "--samples", minimum=1, error=SweepSpecError)
    if samples is not None and not random:  # it would repeat every grid point N times, identically
        raise SweepSpecError(f"--samples {samples} without --random: there is nothing to draw; give "
                             "--random NAME=DIST, or leave --samples out")
    if not grid and not samples:
        raise SweepSpecError("nothing to sweep: give --grid and/or --random with --samples")
    n_samples = samples or 1
    n_grid = math.prod(len(a.values) for a in grid)
    if n_grid * n_samples > MAX_POINTS:
        raise SweepSpecError(f"{n_grid * n_samples} points: more than {MAX_POINTS} in one sweep (the table and "
                             "the plan are held in memory); split it into several sweeps")
    rng = np.random.default_rng(seed)
    draws = {r.name: r.draw(rng, samples) for r in random}
    point = np.arange(n_grid * n_samples)
    columns, inner = {}, n_samples
    for axis in reversed(grid):  # nested loops: the last axis varies fastest (after the samples)
        values = np.array(axis.values, dtype=float if all(isinstance(v, float) for v in axis.values) else object)
        columns[axis.name] = values[(point // inner) % len(values)]
        inner *= len(values)
    for name, v in draws.items():  # common random numbers: the same samples at every grid point
        columns[name] = np.tile(v, n_grid)
    table = pd.DataFrame({name: columns[name] for name in names}, columns=names)
    table.index.name = "point"
    return table


def items_of(given, flag: str, expected: str) -> list:
    """The items of a repeatable option given as a list (or tuple): a single string is refused,
    not read as a list of characters (`--grid 'b': expected NAME=SPEC`); so is any other type.
    expected: what the option takes, for the message ("a mapping or a list of 'NAME=SPEC'
    strings")."""
    if isinstance(given, str) or not isinstance(given, (Sequence, np.ndarray)):
        raise ArgumentTypeError(f"{flag}: expected {expected}, got {shown(given)}")
    return list(given)


def parse_assignments(items: Sequence[str] | Mapping[str, object] | None, flag: str = "--set") -> dict[str, object]:
    """NAME=VALUE strings (or a mapping) -> {name: float or str}. A name given twice is refused."""
    if items is None:
        return {}
    if isinstance(items, Mapping):
        return dict(items)
    out: dict[str, object] = {}
    texts: dict[str, str] = {}
    for item in items_of(items, flag, "a mapping or a list of 'NAME=VALUE' strings"):
        if not isinstance(item, str):
            raise SweepSpecError(f"{flag} {item!r}: expected NAME=VALUE")
        name, text = _split(item, flag)
        if name in texts:
            raise SweepSpecError(f"{flag} {name}: given twice, as {name}={texts[name]} and {name}={text}")
        texts[name] = text
        try:
            out[name] = float(text)
        except ValueError:
            out[name] = text
    return out
