"""Defects the review of `gyrowheel export-c` (issue 12) found, each a test that failed before
its fix (docs/c_api.md):

  test_capi_review                  tests/c/test_capi_review.c: every error reaches the logger
                                    once; euler/rk4 refuse steps the time grid cannot resolve
                                    (t = 1e15) instead of one silent 0.5 s step, and still take
                                    one step per 1 ms period at t = 1e9 s; an advance beyond
                                    1e9 steps of max_step refused at once by DOPRI5 (it ran for
                                    hours), DOP853 and RODAS4
  test_docs_figures                 the state size and allocation count docs/c_api.md quotes are
                                    the export's
"""
from __future__ import annotations

import re
import subprocess

import pytest

from c_programs import TESTS_C
from conftest import ROOT
from export_c_helpers import STRICT, cc


@pytest.fixture(scope="module")
def review_run(earth, earth_gcc, tmp_path_factory) -> dict[str, int]:
    """tests/c/test_capi_review.c built strictly against the export and run; its figures."""
    exe = tmp_path_factory.mktemp("review") / "test_capi_review"
    diagnostics = cc("gcc", *STRICT, "-O2", f"-I{earth}", f"-I{TESTS_C}", TESTS_C / "test_capi_review.c",
                     earth_gcc["obj"], "-lm", "-o", exe).stderr
    assert diagnostics == ""
    r = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and re.search(r"test_capi_review: \d+ checks, 0 failures", r.stderr), r.stderr
    return {k: int(v) for k, v in (line.split() for line in r.stdout.splitlines())}


def test_capi_review(review_run):
    assert set(review_run) == {"state_size", "blocks"}


def test_docs_figures(review_run):
    text = (ROOT / "docs" / "c_api.md").read_text()
    size, blocks = review_run["state_size"], review_run["blocks"]
    assert f"(`state_size` bytes: {size} for paper_earth)" in text
    assert f"buffer of {size - 1} bytes, a state needs {size} (paper_earth_state_size)" in text
    assert f"({blocks} blocks for paper_earth)" in text
