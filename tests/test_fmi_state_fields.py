"""Every field of a saved FMU state, changed and given a correct checksum, is refused with the field
named or is recomputed from the rest, never trusted (docs/fmi.md, "State and instances": a
restored state is one the instance could have reached itself).

The blob is walked field by field in the layout c_src/gw_state.c documents (version 3, native byte
order), and the checksum is recomputed with zlib.crc32, the CRC-32 of IEEE 802.3 that the layout
names: the refusals below come from the fields' own checks, not from the checksum. A changed
field is given to fmi2DeSerializeFMUstate and, if that accepts it, to fmi2SetFMUstate.

Each row says what the standard or the project lets the field be, and so whether the changed value
is refused ("refused", with the text the log must hold) or reachable ("any": accepted). Rows for a
value the instance recomputes ("recomputed") check the value read back after the restore.
Of the 68 rows, 57 must be refused; the runtime that checked only each field's own range accepted
19 of them (M = -1, R = -1, M = 0, k_diam = 0, a start time after the current time, a last
successful time after it, a negative set-up tolerance, a fall indicator below 0 in a wheel still
upright, a front state that contradicts the initialisation, ...) and read back outputs of 1e300."""
from __future__ import annotations

import ctypes
import math
import struct
import zlib

import pytest

from fmi_helpers import Model, rolled_state

OK, ERROR = 0, 3
INSTANTIATED, STEP_COMPLETE, STEP_FAILED, EVENT_MODE = 1, 4, 8, 128  # gw_fmi2.h's state bits
INITIALISED, DISCARD = 0x10, 2  # the front word: bit 4 and fmi2DoStep's last status

INTS = ("front_state", "solver", "stop_defined", "tol_defined", "terminated", "front_word", "y_valid",
        "rel_tol_set", "abs_tol_set")
DOUBLES = ("t", "t_start", "t_stop", "tolerance", "last_successful_time", "rel_tol", "abs_tol", "max_step",
           "max_internal_steps", "h_adapt", "err_old")
COUNTERS = ("n_rhs", "n_accepted", "n_rejected", "n_evt", "n_events")
VECTORS = ("x", "s", "u", "p", "y", "e", "nominal", "t_events", "xc")


def layout(blob: bytes) -> dict[str, tuple[int, str]]:
    """Offset and struct format of every field of a version 3 state (c_src/gw_state.c)."""
    assert blob[:4] == b"GWST" and struct.unpack_from("<I", blob, 4)[0] == 3
    nx, ns, nu, np_, ny, ne, nc = struct.unpack_from("<7i", blob, 12)
    fields = {"magic": (0, "4s"), "version": (4, "<I"), "total": (8, "<I")}
    for k, name in enumerate(("nx", "ns", "nu", "np", "ny", "ne", "nc")):
        fields[name] = (12 + 4 * k, "<i")
    token_len = struct.unpack_from("<I", blob, 40)[0]
    fields["token_length"] = (40, "<I")
    fields["token"] = (44, "1s")
    pos = 44 + token_len
    for name in INTS:
        fields[name], pos = (pos, "<i"), pos + 4
    for name in DOUBLES:
        fields[name], pos = (pos, "<d"), pos + 8
    for name in COUNTERS:
        fields[name], pos = (pos, "<Q"), pos + 8
    for name, n in zip(VECTORS, (nx, ns, nu, np_, ny, ne, nx, ne, nx)):
        for i in range(n):
            fields[f"{name}[{i}]"], pos = (pos, "<d"), pos + 8
    for i in range(ne):
        fields[f"flags[{i}]"], pos = (pos, "<B"), pos + 1
    fields["crc"] = (pos, "<I")
    assert pos + 4 == len(blob)
    return fields


def read(blob: bytes, field: str):
    offset, fmt = layout(blob)[field]
    return struct.unpack_from(fmt, blob, offset)[0]


def changed(blob: bytes, **values) -> bytes:
    """The blob with fields set (a bytes value for magic/token) and the CRC-32 made right again."""
    b = bytearray(blob)
    fields = layout(blob)
    for name, value in values.items():
        offset, fmt = fields[name]
        struct.pack_into(fmt, b, offset, value)
    struct.pack_into("<I", b, len(b) - 4, zlib.crc32(bytes(b[:-4])) & 0xFFFFFFFF)
    return bytes(b)


def restore(inst, blob: bytes) -> int:
    """fmi2DeSerializeFMUstate, then fmi2SetFMUstate of what it made: the first status other than
    fmi2OK, or fmi2OK if both accepted the blob (the instance then holds it)."""
    state = ctypes.c_void_p()
    buf = (ctypes.c_char * len(blob)).from_buffer_copy(blob)
    status = inst.raw("fmi2DeSerializeFMUstate", buf, ctypes.c_size_t(len(blob)), ctypes.byref(state))
    if status == OK:
        status = inst.raw("fmi2SetFMUstate", state)
        inst.raw("fmi2FreeFMUstate", ctypes.byref(state))
    return status


def index_of(inst, blob: bytes, vector: str, name: str) -> int:
    """The index in a vector of the blob of the variable `name`: where its value stands, once."""
    value = inst.get(name)
    n = sum(1 for f in layout(blob) if f.startswith(vector + "["))
    hits = [i for i in range(n) if read(blob, f"{vector}[{i}]") == value]
    assert len(hits) == 1, (vector, name, value, hits)
    return hits[0]


def cases(inst, blob: bytes) -> list[tuple[str, dict, str]]:
    """(what, changed fields, expected) for a paper_earth Co-Simulation state after 1 s of rolling:
    expected is "any" (reachable: accepted), "recomputed" (accepted, the value not used) or the
    text the log must hold for a refusal."""
    M, R, k_diam = (index_of(inst, blob, "p", n) for n in ("M", "R", "k_diam"))
    token = read(blob, "token")
    t = read(blob, "t")
    nx = read(blob, "nx")
    rows = [
        # the header: what the blob is
        ("not a state", {"magic": b"GWSX"}, "not a gyrowheel FMU state"),
        ("another layout version", {"version": 2}, "layout version 2"),
        ("a wrong total size", {"total": len(blob) + 8}, "expected"),
        *((f"model size {k}", {k: read(blob, k) + 1}, "do not match this model")
          for k in ("nx", "ns", "nu", "np", "ny", "ne", "nc")),
        ("token length", {"token_length": read(blob, "token_length") + 1}, "belongs to another model"),
        ("token", {"token": bytes([token[0] ^ 1])}, "belongs to another model"),
        # the front end's words
        ("front state not a state", {"front_state": 3}, "invalid instance state 3"),
        ("Instantiated after an initialisation", {"front_state": INSTANTIATED},
         "instance state Instantiated after an initialisation"),
        ("EventMode in Co-Simulation", {"front_state": EVENT_MODE}, "cannot be set into a Co-Simulation"),
        ("front word bits", {"front_word": 0x20}, "invalid status word"),
        ("StepComplete without an initialisation", {"front_word": 0}, "StepComplete without an initialisation"),
        ("StepFailed without fmi2Discard", {"front_state": STEP_FAILED},
         "last fmi2DoStep status 0 in instance state StepFailed"),
        # settings: the ranges of fmi2SetReal / fmi2SetInteger (gw_value_check)
        ("solver", {"solver": 42}, "solver = 42 is not a solver"),
        ("rel_tol", {"rel_tol": -1.0}, "rel_tol = -1 is outside its valid range"),
        ("abs_tol", {"abs_tol": 2.0}, "abs_tol = 2 is outside its valid range"),
        ("max_step", {"max_step": 0.0}, "max_step = 0 must be > 0"),
        ("max_internal_steps", {"max_internal_steps": 0.5}, "max_internal_steps = 0.5 must be a whole number"),
        *((f"flag {k}", {k: 2}, f"{k} = 2 (must be 0 or 1)")
          for k in ("stop_defined", "tol_defined", "terminated", "y_valid", "rel_tol_set", "abs_tol_set")),
        # the experiment: fmi2SetupExperiment's checks (gw_experiment_check), undefined values are 0
        ("set-up tolerance when defined", {"tol_defined": 1, "tolerance": -1e-6},
         "tolerance -1e-06 is outside the valid range"),
        ("set-up tolerance when undefined", {"tolerance": -1e-6}, "tolerance = -1e-06 with tol_defined = 0"),
        ("stop time when undefined", {"t_stop": 5.0}, "t_stop = 5 with stop_defined = 0"),
        ("stop time before the start", {"stop_defined": 1, "t_stop": -1.0},
         "stopTime -1 must be finite and >= startTime 0"),
        ("start time not finite", {"t_start": math.inf}, "non-finite t_start"),
        # times: t_start <= last_successful_time <= t <= t_stop
        ("start time after the current time", {"t_start": t + 1.0},
         f"t_start = {t + 1.0:.17g} after last_successful_time"),
        ("last successful time after t", {"last_successful_time": t + 1.0}, "after t = "),
        ("t before the last successful time", {"t": t - 0.5}, "after t = 0.5"),
        ("t after the stop time", {"stop_defined": 1, "t_stop": t - 0.5}, "after t_stop = 0.5"),
        ("t not finite", {"t": math.nan}, "non-finite t"),
        # the solver's memory
        ("step size", {"h_adapt": -1e-3}, "negative step size"),
        ("step size, any >= 0", {"h_adapt": 0.25}, "any"),
        ("controller memory", {"err_old": 1.5}, "err_old = 1.5"),
        # statistics: any count is reachable
        *((f"counter {k}", {k: 2**63}, "any") for k in COUNTERS),
        # parameters: the model's validity checks, as at fmi2ExitInitializationMode
        ("M = -1", {f"p[{M}]": -1.0}, "FMU state: M (mass) must be > 0"),
        ("R = -1", {f"p[{R}]": -1.0}, "FMU state: R (radius) must be > 0"),
        ("M = 0", {f"p[{M}]": 0.0}, "FMU state: M (mass) must be > 0"),
        ("k_diam = 0", {f"p[{k_diam}]": 0.0}, "FMU state: k_diam"),
        ("M not finite", {f"p[{M}]": math.inf}, f"invalid p[{M}] = inf"),
        ("M = 3, valid", {f"p[{M}]": 3.0}, "any"),
        # states and start values: any finite state is reachable (fmi2SetContinuousStates)
        ("x[3] not finite", {"x[3]": math.nan}, "invalid x[3] = nan"),
        ("x[0] = 1e6", {"x[0]": 1e6}, "any"),
        ("s[0] not finite", {"s[0]": math.nan}, "invalid s[0] = nan"),
        # cached values: outputs and nominals follow from the rest
        ("output 1e300", {f"y[{i}]": 1e300 for i in range(read(blob, "ny"))}, "recomputed"),
        ("output not finite", {"y[0]": math.inf}, "invalid y[0] = inf"),
        ("nominal 5", {"nominal[0]": 5.0}, "recomputed"),
        ("nominal <= 0", {"nominal[0]": -1.0}, "a nominal must be finite and > 0"),
        # events: an indicator at or below 0 has fired; flags and firing times go together
        ("fall indicator below 0, upright", {"e[0]": -1.0}, "e[0] = -1 (event fall) at or below 0"),
        ("fall indicator 0, upright", {"e[0]": 0.0}, "e[0] = 0 (event fall) at or below 0"),
        ("fall indicator large", {"e[0]": 1e300}, "any"),
        ("a firing time without a firing", {"t_events[0]": 0.5}, "t_events[0] = 0.5 (event fall) but the event"),
        ("fall flag without termination", {"flags[0]": 1}, "terminated = 0, but a terminating event has fired"),
        ("terminated without a terminating event", {"terminated": 1}, "terminated = 1, but no terminating"),
        ("flag not 0/1", {"flags[0]": 2}, "event flag 0 = 2"),
        ("compensation", {"xc[1]": 1e-3}, "a compensation is at most an ulp"),
    ]
    assert nx == 8
    return rows


@pytest.fixture(scope="module")
def rolled(earth_fmu):
    """A paper_earth Co-Simulation instance after 1 s, its state blob and its outputs there."""
    s, blob = rolled_state(earth_fmu)
    outputs = {n: s.get(n) for n in ("beta", "energy", "z", "vx")}
    yield s, blob, outputs
    s.free()


def _fresh(s, blob):
    """The instance back at the saved state (after a refusal it is in the Error state)."""
    s.slave.reset()
    assert restore(s, blob) == OK


def run_cases(s, blob, outputs) -> list[tuple[str, str, str]]:
    """(what, expected, wrong answer or "") for every row, the instance left at the unchanged
    state. A recomputed row must read back the outputs of the unchanged state (the instance's
    own values there: y = out(t, x, u, p) at the same point)."""
    results = []
    for what, values, expected in cases(s, blob):
        _fresh(s, blob)
        n = len(s.messages)
        accepted = restore(s, changed(blob, **values)) == OK
        log = "\n".join(m for _, _, m in s.messages[n:])
        wrong = ""
        if expected in ("any", "recomputed") and not accepted:
            wrong = f"refused, but {expected}: {log}"
        elif expected == "recomputed" and {k: s.get(k) for k in outputs} != outputs:
            wrong = f"accepted, and its value used: {({k: s.get(k) for k in outputs})}"
        elif expected not in ("any", "recomputed") and accepted:
            wrong = "accepted"
        elif expected not in ("any", "recomputed") and expected not in log:
            wrong = f"refused without {expected!r}: {log}"
        results.append((what, expected, wrong))
    _fresh(s, blob)
    return results


def test_every_field_is_refused_or_recomputed(rolled):
    s, blob, outputs = rolled
    results = run_cases(s, blob, outputs)
    wrong = [f"{what}: {answer}" for what, _, answer in results if answer]
    refused = sum(1 for _, e, _ in results if e not in ("any", "recomputed"))
    print(f"{len(results)} changed fields, {refused} to refuse, {len(wrong)} answered wrongly")
    assert not wrong, "\n".join(wrong)
    assert refused >= 45 and len(results) >= 60


def test_a_refused_state_leaves_the_instance_where_it_was(rolled):
    """After a refusal (fmi2Error: the Error state) fmi2Terminate keeps the last consistent state:
    the one the instance held, not the refused blob's."""
    s, blob, outputs = rolled
    _fresh(s, blob)
    M = index_of(s, blob, "p", "M")
    assert restore(s, changed(blob, **{f"p[{M}]": -1.0})) == ERROR
    assert s.raw("fmi2Terminate") == 1  # fmi2Warning: terminated after an fmi2Error
    assert {k: s.get(k) for k in outputs} == outputs and s.get("M") == 2.0
    _fresh(s, blob)


def test_a_state_with_m_minus_1_never_steps(rolled):
    """The reported case: M = -1 and R = -1 restored, then fmi2DoStep answered fmi2OK with a
    negative energy. The energy of the wheel (M g z + kinetic, each term >= 0 for M > 0) can
    never be negative; the state is refused instead."""
    s, blob, _ = rolled
    _fresh(s, blob)
    M, R = index_of(s, blob, "p", "M"), index_of(s, blob, "p", "R")
    assert restore(s, changed(blob, **{f"p[{M}]": -1.0, f"p[{R}]": -1.0})) == ERROR
    assert "M (mass) must be > 0" in s.log_text() and "R (radius) must be > 0" in s.log_text()
    assert s.raw("fmi2DoStep", ctypes.c_double(1.0), ctypes.c_double(0.1), 1) == ERROR
    _fresh(s, blob)


def test_model_exchange_states_let_the_time_be_anything(earth_fmu):
    """Model Exchange: fmi2SetTime takes any finite time, so a state whose t lies before its last
    successful time is reachable and accepted; its event rules hold as in Co-Simulation."""
    m = Model(earth_fmu, logging_on=False)
    try:
        m.init()
        m.fmu2.newDiscreteStates()
        m.fmu2.enterContinuousTimeMode()
        m.fmu2.setTime(-3.0)  # what an importer may do
        blob = bytes(m.fmu2.serializeFMUstate(m.fmu2.getFMUstate()))
        assert read(blob, "t") == -3.0 and read(blob, "last_successful_time") == 0.0
        assert restore(m, blob) == OK
        assert restore(m, changed(blob, **{"e[0]": -1.0})) == ERROR
        assert "e[0] = -1 (event fall) at or below 0" in m.log_text()
    finally:
        m.free()


@pytest.mark.parametrize("beta", [-0.5, 1e300])
def test_a_state_past_the_fall_without_the_fall_is_refused(rolled, beta):
    """The reported case: the state vector of an upright Co-Simulation state changed to a tilt past
    the fall (beta = -0.5 below beta_min = 0.001, or beta = 1e300), the fall not fired, the stored
    indicator and the checksum left right: the instance read beta = -0.5 with fallen = false and its
    next step reported the fall. A Co-Simulation step ends at the fall when the fall indicator
    sin(beta) - sin(beta_min) reaches 0, so no reachable state holds an indicator at or below 0 with
    the fall not fired: sin(-0.5) - sin(0.001) = -0.4804 and sin(1e300) - sin(0.001) = -0.8189
    (Python's math.sin, not the FMU) are, and the state is refused naming the event."""
    s, blob, outputs = rolled
    _fresh(s, blob)
    beta_index = index_of(s, blob, "x", "beta")
    assert read(blob, "flags[0]") == 0 and read(blob, "e[0]") > 0.0
    indicator = math.sin(beta) - math.sin(s.get("beta_min"))
    assert indicator < -0.4
    n = len(s.messages)
    assert restore(s, changed(blob, **{f"x[{beta_index}]": beta})) == ERROR
    log = "\n".join(m for _, _, m in s.messages[n:])
    assert "event fall" in log and f"indicator {indicator:.4g}" in log, log
    assert s.raw("fmi2DoStep", ctypes.c_double(1.0), ctypes.c_double(0.1), 1) == ERROR
    _fresh(s, blob)
    assert s.get("beta") == outputs["beta"] and s.get("fallen") == 0.0

