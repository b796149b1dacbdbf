"""fmi3GetDirectionalDerivative, fmi3GetAdjointDerivative and the FMI 3.0 functions of what the
FMU does not have, in C: tests/c/test_fmi3_partials.c with toy_me.c, the FMI 3.0 runtime
(c_src/gw_fmu3.c) linked beside the FMI 2.0 runtime (c_src/gw_fmu.c) of the same model, so that
every directional derivative is checked against fmi2GetDirectionalDerivative's (and the
analytic Jacobian), adjoints against directional derivatives (v^T (J w) == (v^T J) w), and
every refusal and absent function against its logged reason and the Error state; the toy's
array variables (TOY_ME_ARRAYS) against the scalars they stand for.  Built with
the project's strict flags, with ASan/UBSan, and run under valgrind.
"""
from __future__ import annotations

import re
import subprocess

import pytest

from c_programs import C_SRC, MODE_FLAGS, MODES, STRICT, TESTS_C, run_built, unity_flags


@pytest.mark.parametrize("mode", MODES)
def test_fmi3_partials_and_absent_functions(mode, tmp_path):
    exe = tmp_path / "test_fmi3_partials"
    cmd = ["gcc", *STRICT, *MODE_FLAGS[mode], *unity_flags("me"), "-DTOY_ME_ARRAYS", str(C_SRC / "gw_fmu.c"),
           str(C_SRC / "gw_fmu3.c"), str(TESTS_C / "test_fmi3_partials.c"), "-lm", "-o", str(exe)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, f"{' '.join(cmd)}\n{r.stderr}"
    r = run_built(exe, mode)
    m = re.search(r"worst relative (\S+)", r.stderr)
    assert m and float(m.group(1)) <= 1e-15, r.stderr
