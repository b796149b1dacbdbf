"""The one rule for output files: complete and right, or not touched (gyrowheel/output_files.py)."""
from __future__ import annotations

import os

import pytest

from gyrowheel.errors import ArgumentError
from gyrowheel.output_files import check_output_file, replaced_atomically


def test_a_whole_write_replaces_the_file_and_leaves_no_sibling(tmp_path):
    out = tmp_path / "run.csv"
    out.write_text("old\n")
    with replaced_atomically(out, "output") as part:
        assert part.parent == tmp_path and part.suffix == ".csv" and part != out
        part.write_text("new\n")
    assert out.read_text() == "new\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv"]


@pytest.mark.parametrize("stop", [RuntimeError("writer failed"), KeyboardInterrupt()])
def test_a_failed_or_interrupted_write_leaves_the_old_file(tmp_path, stop):
    out = tmp_path / "run.gif"
    out.write_bytes(b"previous")
    with pytest.raises(type(stop)):
        with replaced_atomically(out, "output") as part:
            part.write_bytes(b"half")
            raise stop
    assert out.read_bytes() == b"previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.gif"]


def test_a_write_that_writes_nothing_is_an_error_and_touches_nothing(tmp_path):
    with pytest.raises(ArgumentError, match="nothing was written"):
        with replaced_atomically(tmp_path / "x.png", "plot"):
            pass
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux)")
def test_a_device_is_refused_and_stays_a_device():
    with pytest.raises(ArgumentError, match=r"^output /dev/full: exists and is not a regular file"):
        check_output_file("/dev/full", "output")
    assert not os.path.isfile("/dev/full")


def test_a_directory_and_a_missing_directory_are_refused_naming_the_argument(tmp_path):
    with pytest.raises(ArgumentError, match="is a directory") as exc:
        check_output_file(tmp_path, "output")
    assert exc.value.argument == "output"
    with pytest.raises(ArgumentError, match="does not exist") as exc:
        check_output_file(tmp_path / "no" / "x.fmu", "-o")
    assert exc.value.argument is None


def test_a_symbolic_link_is_followed(tmp_path):
    real = tmp_path / "real.csv"
    real.write_text("old\n")
    link = tmp_path / "link.csv"
    link.symlink_to(real)
    with replaced_atomically(link, "output") as part:
        part.write_text("new\n")
    assert link.is_symlink() and real.read_text() == "new\n"
