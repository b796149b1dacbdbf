"""FMI 3.0 Model Exchange and FMU states of the C runtime, against its FMI 2.0 layer.

tests/c/test_fmi3_me.c is linked with BOTH unity files (c_src/gw_fmu.c and c_src/gw_fmu3.c,
each with the same toy model) and drives them as a Model Exchange importer (explicit Euler,
crossings located by bisection):
  toy_me.c         the terminating event "hit": terminateSimulation and what follows it,
                   non-finite derivatives (fmi3Discard);
  toy_stickslip.c  update events (stick/slip mode switches): valuesOfContinuousStatesChanged
                   and the states after each jump.
Each run through FMI 3.0 is bit-identical to the one through FMI 2.0; FMU states round-trip
(continuing after a restore is bit-identical); corrupted and foreign states and illegal calls
are refused with their reasons.  Built with the project's strict flags, with ASan/UBSan, and
run under valgrind (the pattern of tests/test_c_model_exchange.py), in tmp_path.
"""

from __future__ import annotations

import re
import subprocess

import pytest

from c_programs import MODE_FLAGS, MODES, STRICT, TESTS_C, UNITY, UNITY3, run_built, unity_flags

TOYS = ("me", "stickslip")


def toy_token(toy: str) -> str:
    m = re.search(r'\.token = "([^"]+)"', (TESTS_C / f"toy_{toy}.c").read_text())
    assert m, toy
    return m.group(1)


def build(toy: str, mode: str, out) -> str:
    exe = out / f"test_fmi3_me_{toy}"
    cmd = ["gcc", *STRICT, *MODE_FLAGS[mode], *unity_flags(toy), f"-DTOY_{toy.upper()}",
           f'-DTOY_TOKEN="{toy_token(toy)}"', str(UNITY), str(UNITY3), str(TESTS_C / "test_fmi3_me.c"),
           "-lm", "-o", str(exe)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, f"compile failed:\n{' '.join(cmd)}\n{r.stdout}{r.stderr}"
    return exe


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("toy", TOYS)
def test_fmi3_model_exchange(toy, mode, tmp_path):
    r = run_built(build(toy, mode, tmp_path), mode)
    assert "FMI 3.0 against FMI 2.0:" in r.stderr and ", bit-identical" in r.stderr, r.stderr
    assert "continuation bit-identical" in r.stderr, r.stderr
    assert ("pending update restored and applied alike" in r.stderr) == (toy == "stickslip"), r.stderr

