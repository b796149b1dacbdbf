"""The seeded fmi2 call-sequence fuzzer (tests/fuzz/fmi2_fuzz.py), a short run: 300 sequences of
60 calls on paper_earth, Co-Simulation and Model Exchange, with every invariant checked (no
non-finite value written, every non-OK status logged, fmi2Discard only where allowed, every call
outside FMI 2.0.4's state tables refused with fmi2Error naming the state, terminate / reset /
re-initialise / free always work). The run is short but not blind: against a runtime that writes
arrays despite fmi2Error, leaves fmi2Discard of the status functions unlogged and refuses
fmi2Terminate after an error it reported 971 violations; against one that accepts fmi2DoStep in
Initialization Mode, a second fmi2EnterInitializationMode, fmi2ExitInitializationMode in
StepComplete or fmi2SetupExperiment in StepComplete, 217, 114, 758 and 343. The long run and its ASan+UBSan build:
docs/fmi.md, "Fuzzing"."""
from __future__ import annotations

from fuzz.fmi2_fuzz import fuzz


def test_short_seeded_fuzz_run_keeps_every_invariant(earth_fmu):
    report = fuzz(earth_fmu, sequences=300, calls=60, seed=0)
    print(report.summary())
    assert report.sequences == 300 and report.calls > 10_000
    assert report.statuses.get(2, 0) > 0 and report.statuses.get(3, 0) > 0  # it does go astray
    assert report.violations == [], "\n".join(report.violations[:20])
