"""Invalid input through the FMI functions is refused with a reason; nothing non-finite reaches
the caller (docs/fmi.md). The cases are calls a seeded fmi2 fuzzer made (tests/fuzz/fmi2_fuzz.py;
the budget of internal steps, its other finding: test_bounded_calls.py):
  (a) no non-finite value handed to the caller
      R = 0, M = 0, M = 1e308, R = 5e-324 set in Initialization Mode, fmi2GetReal(der(...)):
        fmi2Error naming the variable and the failed validity check, the caller's array untouched
        (not NaN with fmi2Warning and no log)
      fmi2GetDirectionalDerivative with seed 1e308: fmi2Error, not Inf with fmi2OK
  (b) Model Exchange fmi2ExitInitializationMode with gamma_dot = 1e200: fmi2Error with the reason, exactly
      as Co-Simulation, and no Event Mode (fmi2Discard is not allowed for that call, and an
      instance half-initialised in Event Mode would be unusable)
  (c) corrupt FMU states: a CRC-32 and the same range checks as fmi2Set* refuse every single bit
      flip of a paper_earth state (checking the header alone accepts 3,848 of 4,536) and every
      bad field (solver = 42, NaN states, rel_tol = -1)
  (d) refused at the call with a reason, not accepted to fail later or never: an out-of-range
      solver via fmi2SetInteger, rel_tol = 1e308 / 1e6 (no error control / "step size
      underflow"), fmi2DoStep with h below the resolution of t (no advance, nothing said),
      fmi2SetInteger / fmi2SetString in Continuous-Time Mode.
"""
from __future__ import annotations

import ctypes
import math
import random
import struct
import zlib

import pytest
from fmpy.fmi1 import FMICallException

from conftest import STATES
from fmi_helpers import Model, Slave, rolled_state

SENTINEL = 12345.0


def _raw_get_real(inst, names):
    """fmi2GetReal into an array pre-filled with a sentinel: (status, values)."""
    n = len(names)
    vr = (ctypes.c_uint * n)(*[inst.vr(x) for x in names])
    out = (ctypes.c_double * n)(*([SENTINEL] * n))
    status = inst.raw("fmi2GetReal", vr, ctypes.c_size_t(n), out)
    return status, list(out)


@pytest.mark.parametrize("values,check", [({"R": 0.0}, "R (radius) must be > 0"), ({"M": 0.0}, "M (mass) must be > 0"),
                                          ({"M": 1e308}, ""), ({"R": 5e-324}, "")])
@pytest.mark.parametrize("kind", [Slave, Model])
def test_initial_derivatives_never_non_finite(earth_fmu, kind, values, check):
    inst = kind(earth_fmu, logging_on=False)
    try:
        inst.fmu2.setupExperiment(startTime=0.0)
        inst.set(**values)
        inst.fmu2.enterInitializationMode()
        names = [f"der({n})" for n in STATES] + ["energy"]
        status, out = _raw_get_real(inst, names)
        if status == 0:  # computable after all: then every value is finite
            assert all(math.isfinite(v) for v in out)
        else:  # fmi2Error with the reason, not fmi2Warning with NaN in the array and no message
            assert status == 3 and out == [SENTINEL] * len(names)
            assert "is not finite" in inst.log_text() and check in inst.log_text()
    finally:
        inst.free()


@pytest.mark.parametrize("kind", [Slave, Model])
def test_huge_seed_is_refused_not_inf(earth_fmu, kind):
    inst = kind(earth_fmu, logging_on=False)
    try:
        inst.init()
        n = 2
        uvr = (ctypes.c_uint * n)(inst.vr("der(beta_dot)"), inst.vr("z"))
        kvr = (ctypes.c_uint * 1)(inst.vr("beta"))
        seed = (ctypes.c_double * 1)(1e308)
        out = (ctypes.c_double * n)(SENTINEL, SENTINEL)
        status = inst.raw("fmi2GetDirectionalDerivative", uvr, ctypes.c_size_t(n), kvr, ctypes.c_size_t(1), seed, out)
        assert status == 3 and list(out) == [SENTINEL, SENTINEL]  # fmi2Error, not fmi2OK with inf
        assert "the seed is too large" in inst.log_text()
    finally:
        inst.free()


@pytest.mark.parametrize("kind", [Slave, Model])
def test_exit_initialization_refusal_is_the_same_in_both_interfaces(earth_fmu, kind):
    inst = kind(earth_fmu, logging_on=False)
    try:
        inst.fmu2.setupExperiment(startTime=0.0)
        inst.set(gamma_dot=1e200)  # beyond the start rates' range (T would overflow)
        inst.fmu2.enterInitializationMode()
        status = inst.raw("fmi2ExitInitializationMode")
        assert status == 3  # fmi2Error in ME too, not fmi2Discard with nothing logged
        assert "fmi2ExitInitializationMode: gamma_dot must lie in [-1e+09, 1e+09] rad/s" in inst.log_text()
        if kind is Model:  # not half-initialised in Event Mode: Event Mode calls are refused
            assert inst.raw("fmi2EnterContinuousTimeMode") == 3
        inst.fmu2.reset()
        inst.init()
    finally:
        inst.free()


# ---- (c) corrupt FMU states -------------------------------------------------------------------

@pytest.fixture(scope="module")
def saved(earth_fmu):
    """A paper_earth instance after 1 s and its serialised state."""
    s, blob = rolled_state(earth_fmu)
    yield s, blob
    s.free()


def _accepts(s, blob: bytes) -> bool:
    state = ctypes.c_void_p()
    buf = (ctypes.c_char * len(blob)).from_buffer_copy(blob)
    status = s.raw("fmi2DeSerializeFMUstate", buf, ctypes.c_size_t(len(blob)), ctypes.byref(state))
    if status == 0:
        s.raw("fmi2FreeFMUstate", ctypes.byref(state))
        return True
    s.slave.reset()  # fmi2Error: back to a usable instance
    s.init()
    s.slave.doStep(0.0, 1.0)
    return False


def test_every_single_bit_flip_is_refused(saved):
    s, blob = saved
    assert _accepts(s, blob)
    accepted = sum(_accepts(s, bytes(blob[:i // 8]) + bytes([blob[i // 8] ^ (1 << i % 8)]) + blob[i // 8 + 1:])
                   for i in range(8 * len(blob)))
    print(f"{8 * len(blob)} single bit flips, {accepted} accepted (checking the header alone: 3,848 of 4,536)")
    assert accepted == 0
    assert "CRC-32 checksum does not match" in s.log_text()


def _body(blob: bytes) -> int:
    """Offset of the first field after the model token (gw_state.c layout 3)."""
    return 44 + struct.unpack_from("<I", blob, 40)[0]


# layout 3 after the token: 9 int32, 11 doubles (t, t_start, t_stop, tolerance,
# last_successful_time, rel_tol, abs_tol, max_step, max_internal_steps, h_adapt, err_old), 5 uint64,
# then the vectors x, s, u, p, y, e, nominal, t_events, xc
_DBL = {name: 36 + 8 * k for k, name in enumerate(
    ("t", "t_start", "t_stop", "tolerance", "last_successful_time", "rel_tol", "abs_tol", "max_step",
     "max_internal_steps", "h_adapt", "err_old"))}
_VECTORS = ("x", "s", "u", "p", "y", "e", "nominal", "t_events", "xc")


def _field(blob: bytes, where) -> int:
    """Offset in the blob of a body offset (int) or of a vector element (name, index)."""
    if isinstance(where, int):
        return _body(blob) + where
    name, i = where
    nx, ns, nu, np_, ny, ne, _ = struct.unpack_from("<7i", blob, 12)
    lengths = dict(zip(_VECTORS, (nx, ns, nu, np_, ny, ne, nx, ne, nx)))
    offset = _body(blob) + 36 + 8 * len(_DBL) + 5 * 8
    for v in _VECTORS[:_VECTORS.index(name)]:
        offset += 8 * lengths[v]
    return offset + 8 * i


def _with_crc(blob: bytearray) -> bytes:
    struct.pack_into("<I", blob, len(blob) - 4, zlib.crc32(bytes(blob[:-4])) & 0xFFFFFFFF)
    return bytes(blob)


@pytest.mark.parametrize("field,where,fmt,value,reason", [
    ("solver", 4, "<i", 42, "solver = 42 is not a solver"),
    ("rel_tol", _DBL["rel_tol"], "<d", -1.0, "rel_tol = -1 is outside its valid range"),
    ("abs_tol", _DBL["abs_tol"], "<d", 1e6, "abs_tol = 1e+06 is outside its valid range"),
    ("abs_tol", _DBL["abs_tol"], "<d", 1e-40, "abs_tol = 1e-40 is outside its valid range"),
    ("abs_tol", _DBL["abs_tol"], "<d", -1e-10, "abs_tol = -1e-10 is outside its valid range"),
    ("max_internal_steps", _DBL["max_internal_steps"], "<d", 0.0,
     "max_internal_steps = 0 must be a whole number from 1 to 2147483647"),
    ("max_internal_steps", _DBL["max_internal_steps"], "<d", 2.5, "max_internal_steps = 2.5 must be a whole number"),
    ("max_internal_steps", _DBL["max_internal_steps"], "<d", 3e9, "max_internal_steps = 3000000000 must be"),
    ("err_old", _DBL["err_old"], "<d", -1e-3, "err_old = -0.001 (the error norm of an accepted step: 0 to 1)"),
    ("err_old", _DBL["err_old"], "<d", 2.0, "err_old = 2 (the error norm of an accepted step"),
    ("err_old", _DBL["err_old"], "<d", math.nan, "non-finite err_old"),
    ("x[0]", ("x", 0), "<d", math.nan, "invalid x[0] = nan"),
    ("xc[3]", ("xc", 3), "<d", math.inf, "invalid xc[3] = inf (not finite)"),
    ("xc[3]", ("xc", 3), "<d", 1e-9, "invalid xc[3] = 1e-09 (a compensation is at most an ulp of its state)"),
    ("t", _DBL["t"], "<d", math.inf, "non-finite t"),
    ("terminated", 16, "<i", 7, "terminated = 7 (must be 0 or 1)"),
    ("front state", 0, "<i", 3, "invalid instance state 3"),
])
def test_fields_out_of_range_are_refused_even_with_a_valid_checksum(saved, field, where, fmt, value, reason):
    s, blob = saved
    b = bytearray(blob)
    struct.pack_into(fmt, b, _field(blob, where), value)
    assert not _accepts(s, _with_crc(b))  # the checksum is not enough: the range checks refuse it
    assert reason in s.log_text(), s.log_text()[-300:]


@pytest.mark.parametrize("field,where,value", [
    ("abs_tol", _DBL["abs_tol"], 0.0),  # follow rel_tol: valid, the scenes' default
    ("max_internal_steps", _DBL["max_internal_steps"], 1.0),
    ("max_internal_steps", _DBL["max_internal_steps"], 2147483647.0),
    ("err_old", _DBL["err_old"], 0.0),
    ("err_old", _DBL["err_old"], 1.0),
    ("xc[3]", ("xc", 3), 0.0),
])
def test_fields_at_the_edges_of_their_ranges_are_accepted(saved, field, where, value):
    s, blob = saved
    b = bytearray(blob)
    struct.pack_into("<d", b, _field(blob, where), value)
    assert _accepts(s, _with_crc(b)), s.log_text()[-300:]


def test_the_saved_run_carries_the_solvers_memory(earth_fmu):
    """The blob holds the budget, a controller memory of an accepted step and a compensation of at
    most half an ulp of each state (paper_earth after 1 s of DOPRI5: the scene's solver auto runs
    taylor, which keeps no controller memory)."""
    s = Slave(earth_fmu, logging_on=False)
    s.init(solver=3)
    s.slave.doStep(0.0, 1.0)
    blob = bytes(s.slave.serializeFMUstate(s.slave.getFMUstate()))
    s.free()
    budget, err_old = (struct.unpack_from("<d", blob, _field(blob, _DBL[k]))[0]
                       for k in ("max_internal_steps", "err_old"))
    assert budget == 1_000_000 and 1e-4 <= err_old <= 1.0
    nx = struct.unpack_from("<i", blob, 12)[0]
    x = struct.unpack_from(f"<{nx}d", blob, _field(blob, ("x", 0)))
    xc = struct.unpack_from(f"<{nx}d", blob, _field(blob, ("xc", 0)))
    assert all(abs(c) <= math.ulp(v) / 2 for v, c in zip(x, xc)) and any(c != 0.0 for c in xc)


def test_random_payload_with_a_valid_header_is_refused(saved):
    s, blob = saved
    rng = random.Random(8)
    for _ in range(50):
        b = bytearray(blob[:_body(blob)]) + bytearray(rng.getrandbits(8) for _ in range(len(blob) - _body(blob)))
        assert not _accepts(s, bytes(b))
        assert not _accepts(s, _with_crc(b))  # a valid checksum over garbage: the range checks


# ---- (d) settings and calls refused at the call ------------------------------------------------

@pytest.mark.parametrize("name,value,reason", [
    ("solver", 42, "solver = 42 is not a solver"), ("solver", 0, "solver = 0 is not a solver"),
    ("rel_tol", 1e308, "rel_tol = 1e+308 is outside its valid range"),
    ("rel_tol", 1e6, "rel_tol = 1e+06 is outside its valid range"),
    ("rel_tol", 1e-20, "rel_tol = 1e-20 is outside its valid range"),
    # abs_tol = 0 is valid (follow rel_tol, the scenes' default): the smallest refused are below 1e-30
    ("abs_tol", 1e-40, "abs_tol = 1e-40 is outside its valid range [1e-30, 1] or 0"),
    ("abs_tol", -1e-9, "abs_tol = -1e-09 is outside its valid range"),
    ("max_step", 0.0, "max_step = 0 must be > 0"),
    ("max_internal_steps", 0, "max_internal_steps = 0 must be a whole number from 1 to 2147483647"),
    ("max_internal_steps", -5, "max_internal_steps = -5 must be a whole number from 1 to 2147483647"),
])
def test_settings_are_refused_at_the_call(earth_fmu, name, value, reason):
    s = Slave(earth_fmu, logging_on=False)
    try:
        with pytest.raises(FMICallException) as exc:  # at the call, not failing later or never
            s.set(**{name: value})
        assert exc.value.status == 3 and reason in s.log_text()
    finally:
        s.free()


def test_step_below_the_resolution_of_t_is_refused(earth_fmu):
    s = Slave(earth_fmu, logging_on=False)
    try:
        s.init(start_time=1e6)
        with pytest.raises(FMICallException) as exc:  # not fmi2OK with t unchanged, silently
            s.slave.doStep(1e6, 1e-12)
        assert exc.value.status == 3
        assert "is below the resolution of currentCommunicationPoint" in s.log_text()
    finally:
        s.free()


@pytest.mark.parametrize("function", ["fmi2SetInteger", "fmi2SetBoolean", "fmi2SetString"])
def test_discrete_setters_are_refused_in_continuous_time_mode(earth_fmu, function):
    """FMI 2.0.4 section 3.2.3: not in Continuous-Time Mode, also with nvr = 0 (the call itself is
    checked against the state machine, not only its variables)."""
    m = Model(earth_fmu, logging_on=False)
    try:
        m.init()
        m.fmu2.newDiscreteStates()
        m.fmu2.enterContinuousTimeMode()
        assert m.raw(function, None, ctypes.c_size_t(0), None) == 3
        assert f"{function}: illegal call in state ContinuousTimeMode" in m.log_text()
        m.fmu2.reset()
        m.init()
    finally:
        m.free()
