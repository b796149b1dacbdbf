"""The sweep's table on disk follows the one rule for outputs: complete and right, or not touched.

A relative -o names a file in the directory the sweep was started in, whatever the FMU does to
the working directory; a sweep that fails or is interrupted before any point finished leaves an
existing table byte for byte as it was; one that fails after some points leaves the table of
those points (as an interrupted one does) and raises its error."""
from __future__ import annotations

import socket
import zipfile
from pathlib import Path

import pytest

from gyrowheel.cli import main
from gyrowheel.studies import read_table, sweep

PREVIOUS = "point,M,survived,status,reason,wall_time\n0,7.0,True,ok,,0.5\n"  # another sweep's table


def _broken_copy(fmu: Path, to: Path) -> Path:
    """The FMU with its binary replaced by bytes that are no shared library."""
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(to, "w") as dst:
        for info in src.infolist():
            data = src.read(info.filename)
            dst.writestr(info, b"not a library" if info.filename.startswith("binaries/") else data)
    return to


def _refusing_address() -> str:
    """A localhost port that nothing listens on (connections are refused at once)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp://127.0.0.1:{s.getsockname()[1]}"


def test_relative_output_is_written_where_the_sweep_started(earth_fmu, tmp_path, monkeypatch, capsys):
    """An FMU whose binary does not load, run through the FMU (--no-ensemble: the ensemble path
    compiles the FMU's sources and never loads its binary): fmpy changes into the binary's
    directory and stays there; the table must still be ./t.csv, with both points as error rows,
    and the working directory must be the one the sweep started in."""
    monkeypatch.chdir(tmp_path)
    _broken_copy(earth_fmu, tmp_path / "broken.fmu")
    code = main(["sweep", "broken.fmu", "--grid", "M=1,2", "--stop-time", "0.1", "--workers", "0", "--no-progress",
                 "--no-ensemble", "-o", "t.csv"])
    assert code == 0 and capsys.readouterr().out.strip() == "wrote t.csv: 2 rows (2 failed)"
    assert Path.cwd() == tmp_path
    table = read_table(tmp_path / "t.csv")
    assert list(table["M"]) == [1.0, 2.0] and (table["status"] == "error").all()
    assert table["reason"].str.contains("cannot instantiate the unit").all(), table["reason"].tolist()


def test_a_sweep_that_cannot_start_leaves_an_existing_table_untouched(earth_fmu, tmp_path, capsys):
    """A scheduler address that refuses: exit 1, one line naming the address, and the table at -o
    is still the previous sweep's, byte for byte (it was replaced by an empty table)."""
    out = tmp_path / "t.csv"
    out.write_text(PREVIOUS)
    address = _refusing_address()
    code = main(["sweep", str(earth_fmu), "--grid", "M=1,2", "--stop-time", "0.1", "--scheduler", address,
                 "--no-progress", "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and err[-1].startswith("gyrowheel: error: ") and address in err[-1], err
    assert out.read_text() == PREVIOUS
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]  # no partial sibling left either


def test_a_failure_after_some_points_keeps_their_table(earth_fmu, tmp_path, monkeypatch):
    """The second batch raises (a defect, not a point's failure): the error propagates, and the
    table on disk holds this sweep's first point, not the previous table nor an empty one."""
    import gyrowheel.studies.execute as execute

    out = tmp_path / "t.csv"
    out.write_text(PREVIOUS)
    calls = []
    run_batch = execute.run_batch

    def second_fails(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise RuntimeError("batch 2 broke")
        return run_batch(*args, **kwargs)

    monkeypatch.setattr(execute, "run_batch", second_fails)
    with pytest.raises(RuntimeError, match="batch 2 broke"):
        sweep(earth_fmu, grid={"M": [1.5, 2.0, 2.5]}, stop_time=0.1, workers=0, batch_size=1, output=out)
    table = read_table(out)
    assert list(table["point"]) == [0] and list(table["M"]) == [1.5] and list(table["status"]) == ["ok"]


def test_output_path_is_absolute_from_the_start(tmp_path, monkeypatch):
    from gyrowheel.studies.output import check_output_path
    monkeypatch.chdir(tmp_path)
    assert check_output_path("t.parquet") == tmp_path / "t.parquet"
