"""The seeded fmi3 call-sequence fuzzer (tests/fuzz/fmi3_fuzz.py), a short run: sequences of 60
calls on the FMI 3 FMUs of paper_earth (the fall, a terminating event) and slope_hold (stiction, an
update event: early return and Event Mode in Co-Simulation), both interfaces, every invariant
checked (tests/fuzz/fuzz_common.py). The long run under ASan+UBSan: docs/fmi.md, "Fuzzing"."""
from __future__ import annotations

import pytest

from fuzz.fmi3_fuzz import fuzz


@pytest.mark.parametrize("scene,sequences,event", [("paper_earth", 300, "terminateSimulation"),
                                                  ("slope_hold", 150, "eventHandlingNeeded")])
def test_short_seeded_fmi3_fuzz_run_keeps_every_invariant(fmi3_fmu, scene, sequences, event):
    report = fuzz(fmi3_fmu(scene), sequences=sequences, calls=60, seed=0)
    print(report.totals())
    print(report.summary())
    assert report.sequences == sequences and report.calls > 40 * sequences
    assert report.statuses.get(3, 0) > 0  # it does go astray
    assert report.seen.get(event, 0) > 0 and report.seen.get("earlyReturn", 0) > 0  # and meets the scene's events
    assert report.violations == [], "\n".join(report.violations[:20])
