"""The sweep's and the animation's errors in the words of the Python API, and back.

The engines (gyrowheel.studies, gyrowheel.animation) word their errors in the command line's
flags: `--grid 'beta_deg=60:89': expected ...`, `--fps must be in (0, 120]`, which is what
`gyrowheel sweep` and `gyrowheel animate` print. gyrowheel.sweep and gyrowheel.animate take
arguments, not flags: `reworded` turns such an error into the same error naming the argument
(`grid['beta_deg'] = '60:89': expected ...`, `fps must be in (0, 120]`), raised from the
engine's own, and `command_line_text` gives the command line the engine's words back.
"""
from __future__ import annotations

import contextlib
import re
from collections.abc import Mapping

from gyrowheel.errors import GyrowheelError

# flag -> argument of gyrowheel.sweep
SWEEP = {"--grid": "grid", "--random": "random", "--samples": "samples", "--seed": "seed", "--set": "fixed",
         "--derive": "derive", "--stop-time": "stop_time", "--output-interval": "output_interval",
         "--solver": "solver", "--rel-tol": "rel_tol", "--abs-tol": "abs_tol", "--max-step": "max_step",
         "--metrics": "metrics", "--metric-function": "metric_functions", "-o": "output", "--plot": "plot",
         "--plot-metric": "plot_metric", "--workers": "workers", "--scheduler": "scheduler",
         "--batch-size": "batch_size"}
# flag -> argument of gyrowheel.animate
ANIMATE = {"--fps": "fps", "--speed": "speed", "--size": "size", "--trail": "trail", "--start": "start",
           "--stop": "stop", "--R": "R", "--fmu": "fmu", "--component": "component", "-o": "output"}
# phrases that read wrong word by word
PHRASES = {"is both swept and fixed with --set": "is both swept and given in fixed",
           "(from --R)": "(given as R)", "pass --R or --fmu": "give R or fmu"}

FLAG = re.compile(r"(?<![\w-])(--[A-Za-z][\w-]*|-o)(?![\w-])")
SET_NAME = re.compile(r"(?<![\w-])--set ([^\s:,)']+)")
ITEM = re.compile(r"(?<![\w-])--(grid|random) '([^'=]+)=([^']*)'")
API_ITEM = re.compile(r"^(grid|random) '([^']*)'")  # the API forms' own messages: grid 'M': ...


def reword(text: str, flags: Mapping[str, str], by_name: tuple[str, ...] = ()) -> tuple[str, str | None]:
    """(text with every flag of `flags` replaced by its argument, the argument the text begins
    with or None). by_name: the arguments given as {name: spec} mappings (grid, random): their
    items are named as grid['NAME'] = 'SPEC', and NAME= leaves the forms the message lists."""
    first, own = FLAG.match(text), API_ITEM.match(text)
    argument = flags.get(first.group(1)) if first else own.group(1) if own else None
    for phrase, words in PHRASES.items():
        text = text.replace(phrase, words)
    text = API_ITEM.sub(lambda m: f"{m.group(1)}[{m.group(2)!r}]", text)
    keyed = any(m.group(1) in by_name for m in ITEM.finditer(text))
    text = ITEM.sub(lambda m: f"{m.group(1)}[{m.group(2)!r}] = {m.group(3)!r}" if m.group(1) in by_name
                    else f"{m.group(1)} {m.group(2) + '=' + m.group(3)!r}", text)
    if keyed:  # the forms a {name: spec} entry takes: the spec alone
        text = text.replace("expected NAME=SPEC", "expected a non-empty spec").replace("NAME=", "")
    if "--set" in flags:
        text = SET_NAME.sub(lambda m: f"{flags['--set']}[{m.group(1)!r}]", text)
    text = FLAG.sub(lambda m: flags.get(m.group(1), m.group(1)), text)
    return text, argument


@contextlib.contextmanager
def reworded(flags: Mapping[str, str], errors: tuple[type[GyrowheelError], ...], by_name: tuple[str, ...] = ()):
    """Re-raise what the block raises of `errors` as the same error (same class) reworded by
    `reword`, from the original; its `argument` is the one the text begins with, if any; its
    engine_text the original text."""
    try:
        yield
    except errors as exc:
        text, argument = reword(str(exc), flags, by_name)
        new = type(exc)(text, argument=argument or exc.argument)
        new.engine_text = str(exc)
        raise new from exc


def command_line_text(exc: BaseException) -> str:
    """The error in the command line's words: for an error `reworded` made, the engine's text."""
    return getattr(exc, "engine_text", None) or str(exc)
