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


# each FMI version's unity file: the one translation unit of its FMUs (c_src/gw_fmu.c, gw_fmu3.c)
UNITY_SOURCES = {2: "gw_fmu.c", 3: "gw_fmu3.c"}


def fmi_version_of(name: str) -> int | None:
    """The FMI version whose layer the runtime file `name` belongs to (its unity file,
    gw_fmi<version>*.c/.h), or None for a file of the core every version shares."""
    for version, unity in UNITY_SOURCES.items():
        if name == unity or name.startswith(f"gw_fmi{version}"):
            return version
    return None


def runtime_sources(fmi: int | None = None) -> list[Path]:
    """The files of the C runtime, .c then .h, sorted by name: every one, or with `fmi` (2 or 3)
    those an FMU of that FMI version carries in sources/: the core and its own layer, never the
    other version's (fmi_version_of)."""
    files = sorted(RUNTIME_DIR.glob("*.c")) + sorted(RUNTIME_DIR.glob("*.h"))
    return files if fmi is None else [f for f in files if fmi_version_of(f.name) in (None, fmi)]
