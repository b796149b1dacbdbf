"""The result table: one row per point (inputs, metrics, status, reason, wall time), on disk as it grows.

The file follows gyrowheel's one rule for outputs (gyrowheel.output_files): its path is made
absolute when the sweep is checked (a working directory changed while the sweep runs, as fmpy
does when an FMU's library fails to load, cannot move it) and it is rewritten whole, atomically
(a hidden sibling, then os.replace), at most every `interval` seconds (and never more often
than ten times the last write took) and once at the end, but never before a point has its row.
So an existing file at the path is left as it was by a sweep that fails or is stopped (Ctrl-C)
before any point finished; after that, whatever stops the sweep, the file is a complete,
readable table of this sweep's points finished by its last write. Parquet (pyarrow) or CSV,
chosen by the suffix.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import pandas as pd

from gyrowheel.arguments import path as as_path
from gyrowheel.output_files import check_output_file, replaced_atomically
from gyrowheel.studies.spec import SweepSpecError

FORMATS = (".parquet", ".csv")
TAIL = ("status", "reason", "wall_time")


def check_output_path(path: str | Path | None) -> Path | None:
    """The table's file: None, or the absolute path of a .parquet or .csv file to write.

    Raises SweepSpecError (`-o ...`) for a path without one of those suffixes, a path that is
    a directory, a device, a FIFO or a socket, or one whose directory does not exist
    (gyrowheel.output_files.check_output_file)."""
    if path is None:
        return None
    path = as_path(path, "-o", "a file path (.parquet or .csv)")
    if path.is_dir():
        raise SweepSpecError(f"-o {path}: is a directory; give a file name (.parquet or .csv)")
    if path.suffix.lower() not in FORMATS:
        raise SweepSpecError(f"-o {path}: unknown format {path.suffix or '(no suffix)'!r}; use .parquet or .csv")
    return check_output_file(path.absolute(), "-o", error=SweepSpecError, argument="output")


def _dtypes(frame: pd.DataFrame) -> pd.DataFrame:
    """Columns of True/False with gaps (failed points) as nullable booleans, not objects."""
    for col in frame.columns:
        if frame[col].dtype == object:
            present = frame[col].dropna()
            if len(present) and all(isinstance(v, (bool,)) or type(v).__name__ == "bool_" for v in present):
                frame[col] = frame[col].astype("boolean")
    return frame


def result_table(inputs: pd.DataFrame, rows: list[dict], columns: dict[str, str] | None = None) -> pd.DataFrame:
    """Join the inputs of the points done with their results, in point order.

    Columns: point, the inputs as given, the metric columns, status, reason, wall_time [s].
    columns: the metric columns known before anything ran, {column: 'bool' | 'text' |
    'number'} (MetricSet.columns): the table has them, in that order and of that type, whether
    or not any point succeeded (a failed point's cells are empty: NaN, <NA>, ''); columns a
    user function returned come after them.
    """
    known = dict(columns or {})
    if not rows:
        frame = pd.DataFrame({"point": pd.Series(dtype="int64"),
                              **{c: pd.Series(dtype=inputs[c].dtype) for c in inputs.columns},
                              **{c: pd.Series(dtype=_DTYPES[k]) for c, k in known.items()},
                              "status": pd.Series(dtype=object), "reason": pd.Series(dtype=object),
                              "wall_time": pd.Series(dtype="float64")})
        return frame
    results = pd.DataFrame(rows).set_index("point").sort_index()
    for column in known:
        if column not in results:  # no point gave it (every point failed)
            results[column] = pd.NA if known[column] == "bool" else "" if known[column] == "text" else math.nan
    metric_cols = list(known) + [c for c in results.columns if c not in TAIL and c not in known]
    frame = inputs.loc[results.index].join(results[metric_cols + list(TAIL)])
    for text in ("reason", *(c for c, k in known.items() if k == "text")):  # failed points: '', not missing
        if text in frame:
            frame[text] = frame[text].fillna("")
    for column in (c for c, k in known.items() if k == "bool"):
        if frame[column].isna().any():  # True/False with gaps (failed points): nullable booleans
            frame[column] = frame[column].astype("boolean")
    frame = _dtypes(frame.reset_index())
    return frame


_DTYPES = {"bool": "boolean", "text": object, "number": "float64"}


class TableWriter:
    """Collects rows; keeps `path` a complete table of the rows so far once there is one (see
    the module docstring). `path`: absolute (check_output_path), or None for no file."""

    def __init__(self, path: Path | None, inputs: pd.DataFrame, columns: dict[str, str] | None = None,
                 interval: float = 1.0):
        self.path, self.inputs, self.interval, self.columns = path, inputs, interval, columns
        self.rows: list[dict] = []
        self._last = time.monotonic()
        self._cost = 0.0
        self.written = 0

    def add(self, rows: list[dict]) -> None:
        self.rows.extend(rows)
        now = time.monotonic()
        if self.path is not None and now - self._last >= max(self.interval, 10 * self._cost):
            self.flush()

    def table(self) -> pd.DataFrame:
        return result_table(self.inputs, self.rows, self.columns)

    def flush(self, *, finished: bool = True) -> pd.DataFrame:
        """The table of the rows so far, written to `path` (when there is one) if the sweep
        `finished` (every point has its row) or has rows to write: a sweep stopped before its
        first row leaves the file as it was."""
        frame = self.table()
        if self.path is not None and (finished or self.rows):
            t0 = time.monotonic()
            write_table(frame, self.path)
            self._cost = time.monotonic() - t0
            self._last = time.monotonic()
            self.written = len(frame)
        return frame


def write_table(frame: pd.DataFrame, path: Path) -> None:
    """Write `frame` to `path` (.parquet or .csv) whole or not at all (replaced_atomically)."""
    with replaced_atomically(path, "-o", error=SweepSpecError, argument="output") as part:
        if path.suffix.lower() == ".parquet":
            frame.to_parquet(part, index=False, engine="pyarrow")
        else:
            frame.to_csv(part, index=False)


def read_table(path: str | Path) -> pd.DataFrame:
    """Read a sweep table written by gyrowheel sweep (Parquet or CSV)."""
    path = Path(path)
    if path.suffix.lower() == ".parquet":
        return pd.read_parquet(path)
    return _dtypes(pd.read_csv(path))  # True/False with gaps: nullable booleans, as the Parquet file has
