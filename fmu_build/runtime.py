"""Where the C runtime (c_src/, package data `gyrowheel.c_src`) and the vendored data files are.

Found with importlib.resources, so a wheel, an editable install and a checkout behave the same,
from any working directory.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path


def package_dir(package: str) -> Path:
    """The directory of an installed gyrowheel package's data files.

    Raises FileNotFoundError when the package is not on the file system (gyrowheel is installed
    unpacked by pip; a zipped install cannot compile FMUs)."""
    path = Path(str(resources.files(package)))
    if not path.is_dir():
        raise FileNotFoundError(f"{package}: its files are not a directory ({path}); "
                                "reinstall gyrowheel with pip")
    return path


RUNTIME_DIR = package_dir("gyrowheel.c_src")
EXPORT_DIR = RUNTIME_DIR / "export"


def runtime_sources() -> list[Path]:
    """Every file of the C runtime, .c then .h, sorted by name (copied into an FMU's sources/)."""
    return sorted(RUNTIME_DIR.glob("*.c")) + sorted(RUNTIME_DIR.glob("*.h"))
