"""The CI entry point is a shell script nothing else runs: check it parses and calls `make test`.

A broken .ci/run fails CI in two seconds before any test runs (a text replacement that splices a
Makefile recipe into its comments is enough), so the suite guards it.
"""
import pathlib
import subprocess

ROOT = pathlib.Path(__file__).resolve().parents[1]
CI_RUN = ROOT / ".ci" / "run"


def test_ci_run_is_valid_bash():
    done = subprocess.run(["bash", "-n", str(CI_RUN)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_ci_run_ends_with_make_test():
    lines = [ln.strip() for ln in CI_RUN.read_text().splitlines() if ln.strip()
             and not ln.strip().startswith("#")]
    assert lines[-1] == "make test"
    assert lines[0] == "set -euo pipefail"


def test_readme_names_the_ci_test_command():
    readme = (ROOT / "README.md").read_text()
    assert "make test" in readme[:600] and "make demo" in readme[:600]
