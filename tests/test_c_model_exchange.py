"""Model Exchange and directional derivatives of the generic C runtime (c_src/).

The C programs in tests/c act as Model Exchange importers:
  test_me.c        + toy_me.c          RK4 outer loop with importer-side event location
                                       (WARN and TERMINATE events), state/derivative variables,
                                       lazy outputs, FMU states in ME, error paths with their
                                       logged reasons;
  test_me_dirder.c + toy_me.c          directional derivatives vs the analytic Jacobian and
                                       central differences (rel 1e-6), in every mode that
                                       allows them, Co-Simulation included;
  test_me_nodir.c  + toy_oscillator.c  a model without `dir`: ME works, directional
                                       derivatives are "not provided".
Each is built with the project's strict flags, with ASan/UBSan, and run under valgrind
(the pattern of tests/test_c_runtime.py).  Everything is built in tmp_path.
"""

from __future__ import annotations

import re

import pytest

from c_programs import MODES, run_program

PROGRAMS = {"me": "me", "me_dirder": "me", "me_nodir": "oscillator"}  # driver -> toy model


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("driver", PROGRAMS)
def test_program(driver, mode, tmp_path):
    r = run_program(driver, PROGRAMS[driver], tmp_path, mode)
    if driver == "me_dirder" and mode == "strict":
        m = re.search(r"central differences: worst relative (\S+)", r.stderr)
        assert m and float(m.group(1)) < 1e-6, r.stderr
