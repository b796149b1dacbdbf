"""Another version of gyrowheel to measure against: a checkout directory or a git ref, either layout.

The A/B benchmarks (dop853_ab.py, ensemble_scaling.py, taylor_kernel_bench.py, taylor_order_ab.py)
run code of another version inside that version's own tree. The project has had two layouts:
  package    one namespace, gyrowheel: pyproject.toml's [tool.setuptools.package-dir] maps the
             folders (gyrowheel/, model/, fmu_build/, taylor/, studies/, ...) to gyrowheel,
             gyrowheel.model, gyrowheel.fmu_build, ... (`from gyrowheel.fmu_build import build_fmu`)
  top-level  model/, fmu_build/, controller/, cosim/ are top-level packages (`from fmu_build
             import build_fmu`; the Taylor generator is fmu_build/taylor_*.py, the ensemble
             fmu_build/ensemble.py, the studies fmu_build/sweep/)
RefTree finds the layout in the tree, names a module of the package layout as that tree has it
(module()), and runs code with that tree's project importable and nothing of this checkout's:
in a subprocess (python()), or in this process (load()). In the package layout the tree is made
importable through a directory of symbolic links that lays the folders out as their package
names (the tree itself is never written to).
"""
from __future__ import annotations

import importlib
import io
import os
import re
import subprocess
import sys
import tarfile
import tempfile
import tomllib
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parent.parent

# modules whose top-level-layout name is not the package layout's without "gyrowheel."
TOP_LEVEL_NAMES = {
    "gyrowheel.taylor.kernel_c": "fmu_build.taylor_c",
    "gyrowheel.taylor.graph": "fmu_build.taylor_graph",
    "gyrowheel.taylor.rewrite": "fmu_build.taylor_rewrite",
    "gyrowheel.taylor.events": "fmu_build.taylor_events",
    "gyrowheel.taylor.ensemble": "fmu_build.ensemble",
    "gyrowheel.studies": "fmu_build.sweep",
    "gyrowheel.animation": "fmu_build.animate",
}

# run first in a subprocess: this environment's editable install of gyrowheel (setuptools' finder
# and path hook) must not answer for a module the tree lacks
ISOLATE = ("import sys\n"
           "sys.meta_path[:] = [f for f in sys.meta_path if not getattr(f, '__module__', '').startswith('__editable__')]\n"
           "sys.path_hooks[:] = [h for h in sys.path_hooks if not getattr(h, '__module__', '').startswith('__editable__')]\n"
           "sys.path_importer_cache.clear()\n")


class RefTree:
    """The tree of another version: `ref` is a directory holding a checkout (its pyproject.toml),
    or a git ref of this repository (exported with git archive into `tmp`). Raises SystemExit
    naming ref when it is neither, or when the tree has neither layout."""

    def __init__(self, ref: str, tmp: Path):
        self.ref = ref
        Path(tmp).mkdir(parents=True, exist_ok=True)
        if (Path(ref) / "pyproject.toml").is_file():
            self.root = Path(ref).resolve()
        else:
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", ref], capture_output=True)
            if archive.returncode != 0:
                raise SystemExit(f"{ref!r} is neither a directory nor a git ref of {ROOT}: "
                                 f"{archive.stderr.decode(errors='replace').strip()}")
            self.root = Path(tempfile.mkdtemp(prefix="ref-" + re.sub(r"[^\w.-]", "_", ref) + "-", dir=tmp))
            with tarfile.open(fileobj=io.BytesIO(archive.stdout)) as t:
                t.extractall(self.root, filter="data")
        mapping = self._package_dir()
        if "gyrowheel" in mapping:
            self.layout = "package"
            self.path = self._view(mapping, Path(tempfile.mkdtemp(prefix="view-", dir=tmp)))
            self.packages = {"gyrowheel"}
        elif (self.root / "fmu_build" / "__init__.py").is_file():
            self.layout = "top-level"
            self.path = self.root
            self.packages = {d.name for d in self.root.iterdir() if (d / "__init__.py").is_file()}
        else:
            raise SystemExit(f"{ref!r} ({self.root}): neither layout of gyrowheel (no package-dir "
                             "entry 'gyrowheel' in pyproject.toml, no fmu_build/__init__.py)")

    def _package_dir(self) -> dict[str, str]:
        try:
            data = tomllib.loads((self.root / "pyproject.toml").read_text())
        except (OSError, tomllib.TOMLDecodeError):
            return {}
        return dict(data.get("tool", {}).get("setuptools", {}).get("package-dir", {}))

    def _view(self, mapping: dict[str, str], view: Path) -> Path:
        """A directory where every package of `mapping` (name -> folder of the tree) is a folder of
        symbolic links to its files, at the path its name gives (gyrowheel.model: gyrowheel/model)."""
        for name, folder in sorted(mapping.items(), key=lambda item: item[0].count(".")):
            if not name:
                raise SystemExit(f"{self.ref!r}: package-dir maps the root package ''; not supported here")
            dest = view.joinpath(*name.split("."))
            if dest.is_symlink():  # a folder of the parent package's: this package's own folder instead
                dest.unlink()
            dest.mkdir(parents=True)
            for entry in (self.root / folder).iterdir():
                if entry.name != "__pycache__":
                    (dest / entry.name).symlink_to(entry, target_is_directory=entry.is_dir())
        return view

    def module(self, name: str) -> str:
        """The tree's name of the module named `name` in the package layout (e.g.
        gyrowheel.taylor.ensemble: fmu_build.ensemble in the top-level layout)."""
        if self.layout == "package":
            return name
        for new, old in sorted(TOP_LEVEL_NAMES.items(), key=lambda item: -len(item[0])):
            if name == new or name.startswith(new + "."):
                return old + name[len(new):]
        if not name.startswith("gyrowheel."):
            raise ValueError(f"{name!r} is not a module of gyrowheel")
        return name[len("gyrowheel."):]

    def file(self, path: str) -> Path:
        """A file of the tree by its path in the repository (e.g. c_src/gw_taylor.c)."""
        return self.root / path

    def python(self, code: str, *args: str) -> None:
        """Run `code` (python -c) with argv[1:] = args, the tree's project importable and nothing of
        this checkout's. Raises subprocess.CalledProcessError if it fails."""
        subprocess.run([sys.executable, "-c", ISOLATE + code, *args], check=True, cwd=self.path,
                       env={**os.environ, "PYTHONPATH": str(self.path), "PYTHONDONTWRITEBYTECODE": "1"})

    def load(self, name: str) -> ModuleType:
        """Import the module named `name` (package layout) from the tree into this process.

        Its imports, and theirs, are the tree's modules; afterwards sys.modules is as before (this
        checkout's gyrowheel stays gyrowheel), the loaded module keeps its own. A function of it
        that imports a project module only when called would get this checkout's: run such code
        with python() instead. Raises ImportError if the tree has no such module."""
        def ours(key: str) -> bool:
            return key.split(".")[0] in self.packages

        saved = {k: sys.modules.pop(k) for k in [k for k in sys.modules if ours(k)]}
        state = sys.meta_path[:], sys.path_hooks[:], sys.dont_write_bytecode
        sys.meta_path[:] = [f for f in sys.meta_path if not getattr(f, "__module__", "").startswith("__editable__")]
        sys.path_hooks[:] = [h for h in sys.path_hooks if not getattr(h, "__module__", "").startswith("__editable__")]
        sys.path.insert(0, str(self.path))
        sys.path_importer_cache.clear()
        sys.dont_write_bytecode = True
        try:
            mod = importlib.import_module(self.module(name))
        finally:
            for k in [k for k in sys.modules if ours(k)]:
                del sys.modules[k]
            sys.modules.update(saved)
            sys.meta_path[:], sys.path_hooks[:], sys.dont_write_bytecode = state
            sys.path.remove(str(self.path))
            sys.path_importer_cache.clear()
        if not Path(mod.__file__).is_relative_to(self.path):
            raise ImportError(f"{name}: {mod.__file__} is not in {self.path}")
        return mod
