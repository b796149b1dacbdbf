"""Seeded fuzzer of fmi3 call sequences against one FMI 3.0 FMU's shared library (docs/fmi.md,
"Fuzzing").

Each sequence instantiates the FMU (Model Exchange, or Co-Simulation with eventModeUsed and
earlyReturnAllowed each on or off, by the seed), makes random calls of every fmi3 function that
takes an instance (those of the other interface and of what the FMU does not have too: clocks,
Scheduled Execution, configuration mode, the other variable types) in random states with hostile
arguments (unknown and read-only value references, array sizes that do not match, NaN, inf, 1e308,
denormals, negative or zero step sizes, corrupt and truncated serialized FMU states), then checks
that the instance can still be terminated, reset, re-initialised, stepped and freed. The calls go
through fmpy's FMU3Slave / FMU3Model argument types (tests/fmi3_helpers.py), the states' table is
tests/fmi3_state_table.py.

Invariants (tests/fuzz/fuzz_common.py, shared with the fmi2 fuzzer) after every call: no
non-finite value written to a caller's array, nothing written with a status above fmi3Warning,
every status other than fmi3OK logged with a message starting with the function's name, fmi3Discard
only where FMI 3.0.2 gives it a meaning, every call outside the state machine refused with
fmi3Error naming the state (the instance then in Error), no call slower than the bound. And FMI 3's
own: an argument that cannot be right (array sizes, unknown or read-only references, a step size
that is not > 0, a non-finite value where one is refused) answers fmi3Error; fmi3DoStep's flags are
consistent (earlyReturn only if earlyReturnAllowed, eventHandlingNeeded only with eventModeUsed,
lastSuccessfulTime finite within the step, after the terminating event fmi3Discard with
terminateSimulation), an event pending after an early return refuses fmi3DoStep until Event Mode.

    python tests/fuzz/fmi3_fuzz.py FMU [--sequences N] [--calls N] [--seed S] [--jobs J] [--sanitize]
"""
from __future__ import annotations

import ctypes as C
import math
import random
import sys
import time
from pathlib import Path

import fmpy
from fmpy import extract, read_model_description

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # tests/
import fmi3_state_table as ST  # noqa: E402
from fmi3_helpers import B, Instance3, well_formed  # noqa: E402
from fuzz.fuzz_common import (DISCARD, ERROR, HOSTILE, OK, WARNING, Report, check_call, cli,  # noqa: E402
                              prefill, run_in_process)

D = C.c_double
# fmi3Discard: the call failed, the FMU is as before and the master may try otherwise (2.2.3):
# where a master can: another step, other states or time, other inputs
DISCARD_ALLOWED = {"fmi3DoStep", "fmi3SetFloat64", "fmi3SetInt32", "fmi3SetInt64", "fmi3SetBoolean",
                   "fmi3SetContinuousStates", "fmi3SetTime", "fmi3GetFloat64", "fmi3GetContinuousStateDerivatives",
                   "fmi3GetContinuousStates", "fmi3GetEventIndicators", "fmi3CompletedIntegratorStep",
                   "fmi3UpdateDiscreteStates", "fmi3GetDirectionalDerivative", "fmi3GetAdjointDerivative"}
STEPS = [0.01, 0.01, 0.1, 0.5, 2.0, 3.0, 3.0, 1e-9, 1e-16, 0.0, -0.1, math.nan, math.inf, -math.inf]


class Fuzzer:
    PLATFORM, UNITY = "x86_64-linux", "gw_fmu3.c"  # where its library is, what builds it (--sanitize)
    HEADERS = Path(fmpy.__file__).resolve().parent / "c-code"

    def __init__(self, fmu: str | Path, unzipdir: str | Path | None = None):
        self.md = read_model_description(str(fmu))
        self.unzipdir = str(unzipdir or extract(str(fmu)))
        self.inst = {k: Instance3(fmu, k, self.unzipdir, self.md, logging_on=False) for k in ("CS", "ME")}
        for i in self.inst.values():
            i.free()
        vs = self.md.modelVariables
        self.float64 = [v for v in vs if v.type == "Float64"]
        self.settable = [v for v in self.float64 if v.causality in ("parameter", "input") and v.variability != "constant"]
        self.int32 = [v for v in vs if v.type == "Int32"]
        self.int64 = [v for v in vs if v.type in ("Int64", "Enumeration")]
        self.bools = [v for v in vs if v.type == "Boolean"]
        self.known = {v.valueReference for v in vs}
        self.nx, self.nz = len(self.md.derivatives), len(self.md.eventIndicators)
        self.spin = [v.valueReference for v in vs if v.name == "gamma_dot"]

    # ---- one call, with the invariants --------------------------------------------------------
    def call(self, rep: Report, fn: str, *args, out=None, bad: str = "", seed=0) -> int:
        """fn(instance, *args) with every invariant checked; bad: why the arguments cannot be right
        (the call must answer fmi3Error)."""
        I, self.rep = self.i, rep
        n_before = len(I.messages)
        prefill(out)
        before = self.fstate
        allowed = ST.legal(self.kind, fn, before, self.emu, self.ended)
        reason = "" if allowed else ST.refusal(self.kind, fn, before, self.emu)
        if allowed and fn == "fmi3DoStep" and self.pending:
            allowed, reason = False, "enter Event Mode first"
        t0 = time.perf_counter()
        status = I.fmu3._functions[fn](I.fmu3.component, *args)
        seconds = time.perf_counter() - t0
        rep.count(status)
        where = (f"seed {seed}: {self.kind}{'+emu' if self.emu else ''}{'+era' if self.era else ''} {fn}"
                 f"{tuple(_show(a) for a in args)} in {before} -> {status}")
        new = [(s, m) for s, _, m in I.messages[n_before:]]
        history = [(s, m) for s, _, m in I.messages[max(0, n_before - 3):n_before]]
        check_call(rep, where, fn, status, new, history, allowed=allowed, reason=reason, out=out,
                   discard_ok=fn in DISCARD_ALLOWED, named=True, seconds=seconds)
        if bad and allowed and status != ERROR:
            rep.breach("other", f"{where}: {bad}, not refused with fmi3Error")
        self._track(fn, status, allowed, args)
        return status

    def _track(self, fn: str, status: int, allowed: bool, args) -> None:
        """The instance's state after the call, as FMI 3.0.2's state machine says, and what the
        FMU's time, a terminating event and a pending event are then."""
        now = (self.fstate, self.ended, self.pending, self.t)
        if status >= ERROR or not allowed:
            self.fstate = ST.ERROR
        elif fn == "fmi3Reset":
            self.fstate, self.ended, self.pending, self.t = ST.INSTANTIATED, False, False, 0.0
        elif fn == "fmi3GetFMUState":
            self.saved[args[0]._obj.value] = now
        elif fn == "fmi3DeserializeFMUState":
            self.saved[args[2]._obj.value] = self.deserialized_from or now
        elif fn == "fmi3SetFMUState":
            self.fstate, self.ended, self.pending, self.t = self.saved.get(args[0].value, now)
        elif fn == "fmi3UpdateDiscreteStates":
            self.pending = False
        elif fn == "fmi3EnterInitializationMode":
            self.fstate, self.t = ST.INIT_MODE, args[2].value
        elif fn == "fmi3DoStep" and status <= WARNING:
            need, term, early, last = (a._obj.value for a in args[3:7])
            for flag, name in ((need, "eventHandlingNeeded"), (term, "terminateSimulation"), (early, "earlyReturn")):
                if flag:
                    self.rep.saw(name)
            self.ended, self.pending = self.ended or term, bool(need)
            self.t = last if math.isfinite(last) else self.t
        elif fn == "fmi3SetTime" and status <= WARNING:
            self.t = args[0].value
        else:
            self.fstate = ST.after(self.kind, fn, self.fstate, self.emu)

    # ---- random arguments ---------------------------------------------------------------------
    @staticmethod
    def value(rng: random.Random, v=None) -> float:
        if rng.random() < 0.35:
            return rng.choice(HOSTILE)
        start = float(v.start) if v is not None and v.start not in (None, "") else 1.0
        return start * rng.choice([1.0, 1.0, 0.5, 2.0, -1.0, 1e-3, 1e3]) + rng.gauss(0, 0.01)

    def vrs(self, rng: random.Random, pool, n=None):
        """n value references from pool, a few unknown ones; (array, n, an unknown one is in it)"""
        n = rng.randint(1, 4) if n is None else n
        out = [rng.choice(pool).valueReference if pool and rng.random() > 0.05 else rng.choice([10_000, 2**32 - 1, 77])
               for _ in range(n)]
        return (C.c_uint32 * max(n, 1))(*out), n, any(r not in self.known for r in out)

    def sizes(self, rng: random.Random, n: int) -> tuple[int, int]:
        """(nValues, length of the array) - nValues sometimes wrong, the array always large enough"""
        m = n if rng.random() < 0.85 else max(0, n + rng.choice([-1, 1, 5]))
        return m, max(n, m, 1)

    # ---- a sequence ---------------------------------------------------------------------------
    def sequence(self, rep: Report, seed: int, n_calls: int) -> None:
        rng = random.Random(seed)
        self.kind = "ME" if rng.random() < 0.4 else "CS"
        self.emu = self.kind == "ME" or rng.random() < 0.5
        self.era = self.kind == "CS" and rng.random() < 0.5
        self.i = self.inst[self.kind]
        self.i.messages.clear()
        self.i.instantiate(logging_on=rng.random() < 0.3, event_mode_used=self.kind == "CS" and self.emu,
                           early_return_allowed=self.era)
        self.fstate, self.ended, self.pending = ST.INSTANTIATED, False, False
        self.saved, self.deserialized_from, self.state = {}, None, None
        self.t, initialised, kept = 0.0, False, []
        ops = self.ops()
        if rng.random() < 0.8:
            initialised = self.start(rep, rng, seed)
        for _ in range(n_calls):
            op = rng.choice(ops)
            st = op(rep, rng, seed)
            if st >= ERROR and rng.random() < 0.7:  # explore on: reset and start again
                self.call(rep, "fmi3Reset", seed=seed)
                initialised = self.start(rep, rng, seed)
                continue
            if self.fstate not in (ST.INSTANTIATED, ST.INIT_MODE, ST.ERROR):
                initialised = True
            if op == self.op_get_state and st == OK:
                kept.append(self.state)
        self.recover(rep, seed, initialised)
        for state in kept:  # an FMU state outlives fmi3Reset
            self.call(rep, "fmi3FreeFMUState", C.byref(state), seed=seed)
        self.i.free()
        rep.sequences += 1

    def start(self, rep: Report, rng: random.Random, seed: int) -> bool:
        """A valid initialisation, sometimes with a spinless wheel (it falls within 0.5 s), sometimes
        left in Initialization Mode; True if it ended the initialisation (in Step or CT Mode)."""
        if self.spin and rng.random() < 0.4:
            self.call(rep, "fmi3SetFloat64", (C.c_uint32 * 1)(self.spin[0]), 1, (D * 1)(rng.choice([0.0, 1.0])), 1,
                      seed=seed)
        self.call(rep, "fmi3EnterInitializationMode", B(False), D(0.0), D(0.0), B(False), D(0.0), seed=seed)
        if rng.random() < 0.15:
            return False
        if self.call(rep, "fmi3ExitInitializationMode", seed=seed) > WARNING:
            return False
        if self.fstate == ST.EVENT_MODE:
            self.call(rep, "fmi3UpdateDiscreteStates", *[C.byref(B()) for _ in range(5)], C.byref(D()), seed=seed)
            return self.call(rep, "fmi3EnterContinuousTimeMode" if self.kind == "ME" else "fmi3EnterStepMode",
                             seed=seed) <= WARNING
        return True

    def recover(self, rep: Report, seed: int, initialised: bool) -> None:
        """terminate (if initialised), reset, initialise again, one step, terminate: all must work"""
        if initialised and self.fstate != ST.INSTANTIATED:
            if self.call(rep, "fmi3Terminate", seed=seed) > WARNING and self.fstate not in (ST.INSTANTIATED, ST.ERROR):
                rep.breach("other", f"seed {seed}: fmi3Terminate failed in {self.fstate}: {self.i.messages[-1:]}")
        if self.call(rep, "fmi3Reset", seed=seed) != OK:
            rep.breach("other", f"seed {seed}: fmi3Reset failed: {self.i.messages[-2:]}")
            return
        ok = self.call(rep, "fmi3EnterInitializationMode", B(False), D(0.0), D(0.0), B(False), D(0.0), seed=seed) == OK
        ok = ok and self.call(rep, "fmi3ExitInitializationMode", seed=seed) == OK
        if self.kind == "CS":
            if self.emu:
                ok = ok and self.call(rep, "fmi3EnterStepMode", seed=seed) == OK
            ok = ok and well_formed(self.i, "fmi3DoStep", 0.0, self._checked(rep, seed)) == OK
        else:
            ok = ok and well_formed(self.i, "fmi3GetContinuousStateDerivatives", 0.0, self._checked(rep, seed)) == OK
        ok = ok and self.call(rep, "fmi3Terminate", seed=seed) == OK
        if not ok:
            rep.breach("other", f"seed {seed}: not usable after fmi3Reset: {self.i.messages[-3:]}")

    def _checked(self, rep: Report, seed: int):
        return lambda fn, *args, out=None: self.call(rep, fn, *args, out=out, seed=seed)

    # ---- the operations -----------------------------------------------------------------------
    def ops(self):
        common = [self.op_set_float64] * 3 + [self.op_get_float64] * 3 + [
            self.op_int, self.op_int, self.op_bool, self.op_other_type, self.op_enter_init, self.op_exit_init,
            self.op_exit_init, self.op_terminate, self.op_reset, self.op_get_state, self.op_set_state,
            self.op_corrupt_state, self.op_dirder, self.op_dirder, self.op_debug_logging, self.op_event_mode,
            self.op_update, self.op_update, self.op_any, self.op_any, self.op_any]
        if self.kind == "CS":
            return common + [self.op_step] * 8 + [self.op_step_mode] * 2 + [self.op_handle_event] * 2
        return common + [self.op_ct_mode, self.op_ct_mode, self.op_completed, self.op_numbers, self.op_set_time, self.op_set_states,
                         self.op_set_states, self.op_me_array, self.op_me_array, self.op_me_array]

    def op_set_float64(self, rep, rng, seed):
        pool = self.settable if rng.random() < 0.8 else self.float64
        vr, n, unknown = self.vrs(rng, pool)
        if rng.random() < 0.03:
            vr[0], unknown = 0, True  # time: read-only
        m, size = self.sizes(rng, n)
        vals = (D * size)(*[self.value(rng) for _ in range(size)])
        bad = "unknown or read-only value reference" if unknown else ("nValues != nValueReferences" if m != n else "")
        return self.call(rep, "fmi3SetFloat64", vr, n, vals, m, bad=bad, seed=seed)

    def op_get_float64(self, rep, rng, seed):
        vr, n, unknown = self.vrs(rng, self.float64, rng.randint(0, 12))
        m, size = self.sizes(rng, n)
        out = (D * size)()
        bad = "unknown value reference" if unknown else ("nValues != nValueReferences" if m != n else "")
        return self.call(rep, "fmi3GetFloat64", vr, n, out, m, out=out if m == n else None, bad=bad, seed=seed)

    def op_int(self, rep, rng, seed):
        bits, pool = rng.choice([(32, self.int32), (64, self.int64)])
        typ = C.c_int32 if bits == 32 else C.c_int64
        vr, n, unknown = self.vrs(rng, pool or self.float64, 1)
        if not pool or rng.random() < 0.1:  # a variable of another type
            vr[0], unknown = rng.choice(self.float64).valueReference, True
        if rng.random() < 0.5:
            return self.call(rep, f"fmi3GetInt{bits}", vr, 1, (typ * 1)(), 1,
                             bad="not an Int{bits} variable" if unknown else "", seed=seed)
        val = rng.choice([-1, 0, 1, 2, 3, 4, 5, 6, 42, 2**31 - 1, -2**31])
        return self.call(rep, f"fmi3SetInt{bits}", vr, 1, (typ * 1)(val), 1,
                         bad=f"not an Int{bits} variable" if unknown else "", seed=seed)

    def op_bool(self, rep, rng, seed):
        vr, n, unknown = self.vrs(rng, self.bools or self.float64, 1)
        unknown = unknown or not self.bools
        if rng.random() < 0.5:
            return self.call(rep, "fmi3GetBoolean", vr, 1, (B * 1)(), 1, bad="not a Boolean" if unknown else "",
                             seed=seed)
        return self.call(rep, "fmi3SetBoolean", vr, 1, (B * 1)(rng.random() < 0.5), 1,
                         bad="not a Boolean" if unknown else "", seed=seed)

    def op_other_type(self, rep, rng, seed):
        """A getter or setter of a type the FMU has no variable of: no reference is fine, any is not."""
        t = rng.choice(ST.OTHER_TYPES)
        n = rng.choice([0, 0, 1, 2])
        vr = (C.c_uint32 * 2)(*[rng.choice(self.float64).valueReference, rng.randint(0, 10_000)])
        fn = f"fmi3{rng.choice(['Get', 'Set'])}{t}"
        bad = "a value reference of no such variable" if n else ""
        if t == "Binary":
            return self.call(rep, fn, vr, n, (C.c_size_t * 2)(1, 1), (C.POINTER(C.c_ubyte) * 2)(), n, bad=bad, seed=seed)
        typ = {"Float32": C.c_float, "Int8": C.c_int8, "UInt8": C.c_uint8, "Int16": C.c_int16, "UInt16": C.c_uint16,
               "UInt32": C.c_uint32, "UInt64": C.c_uint64, "String": C.c_char_p}[t]
        vals = (typ * 2)(*([b"x", b"y"] if t == "String" else [1, 2]))
        return self.call(rep, fn, vr, n, vals, n, bad=bad, seed=seed)

    def op_enter_init(self, rep, rng, seed):
        tol_def, stop_def = rng.random() < 0.5, rng.random() < 0.3
        tol = rng.choice([1e-4, 1e-8, self.value(rng)])
        start = rng.choice([0.0, 0.0, 1.0, self.value(rng)])
        stop = start + rng.choice([1.0, 100.0, -1.0, math.nan])
        bad = ""
        if not math.isfinite(start) or (tol_def and not (math.isfinite(tol) and tol > 0)) or \
                (stop_def and not (stop >= start)):
            bad = "a start time, tolerance or stop time that cannot be"
        return self.call(rep, "fmi3EnterInitializationMode", B(tol_def), D(tol), D(start), B(stop_def), D(stop),
                         bad=bad, seed=seed)

    def op_exit_init(self, rep, rng, seed):
        return self.call(rep, "fmi3ExitInitializationMode", seed=seed)

    def op_terminate(self, rep, rng, seed):
        return self.call(rep, "fmi3Terminate", seed=seed)

    def op_reset(self, rep, rng, seed):
        if rng.random() >= 0.3:
            return OK
        return self.call(rep, "fmi3Reset", seed=seed)

    def op_event_mode(self, rep, rng, seed):
        return self.call(rep, "fmi3EnterEventMode", seed=seed)

    def op_update(self, rep, rng, seed):
        flags, t_next = [B() for _ in range(5)], D()
        st = self.call(rep, "fmi3UpdateDiscreteStates", *[C.byref(f) for f in flags], C.byref(t_next), seed=seed)
        if st <= WARNING and flags[4].value and not math.isfinite(t_next.value):
            rep.breach("non-finite", f"seed {seed}: fmi3UpdateDiscreteStates: nextEventTime {t_next.value}")
        return st

    def op_numbers(self, rep, rng, seed):
        """fmi3GetNumberOf...: the sizes modelDescription.xml gives"""
        fn, want = rng.choice([("fmi3GetNumberOfContinuousStates", self.nx), ("fmi3GetNumberOfEventIndicators", self.nz)])
        n = C.c_size_t(12345)
        st = self.call(rep, fn, C.byref(n), seed=seed)
        if st <= WARNING and n.value != want:
            rep.breach("other", f"seed {seed}: {fn} says {n.value}, modelDescription.xml {want}")
        return st

    def op_handle_event(self, rep, rng, seed):
        """a master's event handling (FMI 3.0.2 section 4.2.4): Event Mode, the update, Step Mode"""
        st = self.call(rep, "fmi3EnterEventMode", seed=seed)
        if st <= WARNING:
            st = self.op_update(rep, rng, seed)
        return self.call(rep, "fmi3EnterStepMode", seed=seed) if st <= WARNING else st

    def op_step_mode(self, rep, rng, seed):
        return self.call(rep, "fmi3EnterStepMode", seed=seed)

    def op_ct_mode(self, rep, rng, seed):
        return self.call(rep, "fmi3EnterContinuousTimeMode", seed=seed)

    def op_step(self, rep, rng, seed):
        h = rng.choice(STEPS)
        t = self.t if rng.random() < 0.85 else self.value(rng)
        flags, last = [B(), B(), B()], D(ST_SENTINEL)
        pending, ended = self.pending, self.ended
        legal = ST.legal("CS", "fmi3DoStep", self.fstate, True, ended)
        bad = "" if math.isfinite(h) and h > 0 and math.isfinite(t) else "a step size or time that cannot be"
        st = self.call(rep, "fmi3DoStep", D(t), D(h), B(rng.random() < 0.5), *[C.byref(f) for f in flags],
                       C.byref(last), bad=bad if not ended else "", seed=seed)
        need, term, early = (f.value for f in flags)
        where = f"seed {seed}: fmi3DoStep({t}, {h}) -> {st} (need {need}, term {term}, early {early}, last {last.value})"
        if legal and not pending and st <= DISCARD:
            if st <= WARNING:
                if early and not self.era:
                    rep.breach("other", f"{where}: earlyReturn without earlyReturnAllowed")
                if need and not self.emu:
                    rep.breach("other", f"{where}: eventHandlingNeeded without eventModeUsed")
                if not (math.isfinite(last.value) and t - 1e-12 <= last.value <= t + h + 1e-9 * max(1.0, abs(t + h))):
                    rep.breach("non-finite" if not math.isfinite(last.value) else "other",
                               f"{where}: lastSuccessfulTime outside the step")
                if ended:
                    rep.breach("other", f"{where}: a step after the terminating event not refused")
            elif ended and not term:
                rep.breach("other", f"{where}: fmi3Discard after the terminating event without terminateSimulation")
        if st <= WARNING and math.isfinite(last.value) and last.value == ST_SENTINEL:
            rep.breach("other", f"{where}: lastSuccessfulTime not written")
        return st

    def op_get_state(self, rep, rng, seed):
        self.state = C.c_void_p()
        return self.call(rep, "fmi3GetFMUState", C.byref(self.state), seed=seed)

    def op_set_state(self, rep, rng, seed):
        if self.state is None or not self.state.value:
            return OK
        return self.call(rep, "fmi3SetFMUState", self.state, seed=seed)

    def op_corrupt_state(self, rep, rng, seed):
        st = self.state
        if st is None or not st.value:
            return OK
        size = C.c_size_t()
        if self.call(rep, "fmi3SerializedFMUStateSize", st, C.byref(size), seed=seed) != OK:
            return ERROR
        short = rng.random() < 0.1  # a buffer the caller says is too small
        n = size.value - 1 if short else size.value
        buf = (C.c_ubyte * max(size.value, 1))()
        s2 = self.call(rep, "fmi3SerializeFMUState", st, buf, n, bad="a buffer too small" if short else "", seed=seed)
        if s2 != OK:
            return s2
        raw = bytearray(bytes(buf))
        flips = rng.choice([0, 1, 1, 3])
        for _ in range(flips):
            i = rng.randrange(len(raw) * 8)
            raw[i // 8] ^= 1 << (i % 8)
        cut = rng.choice([len(raw), len(raw), len(raw) - 1, 10, 0])
        data = (C.c_ubyte * max(cut, 1)).from_buffer_copy(bytes(raw[:cut]) + b"\0" * (cut == 0))
        new = C.c_void_p()
        self.deserialized_from = self.saved.get(st.value)  # an accepted blob is unchanged
        s3 = self.call(rep, "fmi3DeserializeFMUState", data, cut, C.byref(new),
                       bad="a truncated serialized state" if cut < len(raw) else "", seed=seed)
        if s3 == OK and new.value:
            s3 = self.call(rep, "fmi3SetFMUState", new, seed=seed)
            self.call(rep, "fmi3FreeFMUState", C.byref(new), seed=seed)
        return s3

    def op_dirder(self, rep, rng, seed):
        fn = rng.choice(["fmi3GetDirectionalDerivative", "fmi3GetAdjointDerivative"])
        unk, nu, bad_u = self.vrs(rng, self.float64, rng.randint(1, 5))
        kn, nk, bad_k = self.vrs(rng, self.float64, rng.randint(1, 3))
        n_in, n_out = (nk, nu) if fn == "fmi3GetDirectionalDerivative" else (nu, nk)
        m_in, size_in = self.sizes(rng, n_in)
        m_out, size_out = self.sizes(rng, n_out)
        seeds = (D * size_in)(*[rng.choice([1.0, -0.5, 1e308, 1e-300, 3.0, math.nan]) for _ in range(size_in)])
        out = (D * size_out)()
        bad = "unknown value reference" if bad_u or bad_k else ("a seed or sensitivity size that does not match"
                                                                if (m_in, m_out) != (n_in, n_out) else "")
        return self.call(rep, fn, unk, nu, kn, nk, seeds, m_in, out, m_out,
                         out=out if (m_in, m_out) == (n_in, n_out) else None, bad=bad, seed=seed)

    def op_debug_logging(self, rep, rng, seed):
        cats = (C.c_char_p * 2)(b"logStatusError", rng.choice([b"logEvents", b"no such category"]))
        n = rng.choice([0, 1, 2])
        return self.call(rep, "fmi3SetDebugLogging", B(rng.random() < 0.5), n, cats if n else None, seed=seed)

    def op_any(self, rep, rng, seed):
        """any fmi3 function of the table, the other interface's and the absent ones too, with
        well-formed arguments: legal or refused by the state machine alone"""
        return well_formed(self.i, rng.choice(ST.FUNCTIONS), self.t, self._checked(rep, seed))

    def op_completed(self, rep, rng, seed):
        a, b = B(), B()
        return self.call(rep, "fmi3CompletedIntegratorStep", B(rng.random() < 0.5), C.byref(a), C.byref(b), seed=seed)

    def op_set_time(self, rep, rng, seed):
        t = rng.choice([self.t + 0.01, self.t + 0.1, self.value(rng)])
        return self.call(rep, "fmi3SetTime", D(t), bad="" if math.isfinite(t) else "a non-finite time", seed=seed)

    def op_set_states(self, rep, rng, seed):
        nx = self.nx
        x = (D * nx)()
        self.call(rep, "fmi3GetContinuousStates", x, nx, out=x, seed=seed)
        vals = [v if math.isfinite(v) else 0.0 for v in x]
        i = rng.randrange(nx)
        hostile = rng.random() < 0.2
        vals[i] = vals[i] * rng.choice([1.0, 1.01, -1.0]) + (rng.choice(HOSTILE) if hostile else 0.01)
        m, size = self.sizes(rng, nx)
        arr = (D * size)(*(vals + [0.0] * (size - nx)))
        bad = "nContinuousStates != the number of states" if m != nx else (
            "a non-finite state" if not all(math.isfinite(v) for v in vals) else "")
        return self.call(rep, "fmi3SetContinuousStates", arr, m, bad=bad, seed=seed)

    def op_me_array(self, rep, rng, seed):
        fn = rng.choice(["fmi3GetContinuousStateDerivatives", "fmi3GetContinuousStates",
                         "fmi3GetNominalsOfContinuousStates", "fmi3GetEventIndicators"])
        n = self.nz if fn == "fmi3GetEventIndicators" else self.nx
        m, size = self.sizes(rng, n)
        out = (D * size)()
        return self.call(rep, fn, out, m, out=out if m == n else None,
                         bad="an array size that does not match" if m != n else "", seed=seed)


ST_SENTINEL = -7.25e101  # lastSuccessfulTime before fmi3DoStep


def _show(a):
    """an argument as the report shows it"""
    if isinstance(a, (int, float, bool)):
        return a
    if isinstance(a, (C.c_double, C.c_bool)):
        return a.value
    if isinstance(a, C.Array):
        items = list(a)[:6]
        return [x.value if isinstance(x, C.c_void_p) else x for x in items] if not isinstance(a[0], bytes) else items
    return "&" if hasattr(a, "_obj") else type(a).__name__


def fuzz(fmu: str | Path, sequences: int, calls: int, seed: int = 0, unzipdir=None) -> Report:
    """sequences sequences of `calls` calls from seed on, in this process."""
    return run_in_process(Fuzzer(fmu, unzipdir), "fmi3", seed, sequences, calls)


def main(argv=None) -> int:
    return cli(argv, "fmi3", __doc__, Fuzzer, __file__)


if __name__ == "__main__":
    sys.exit(main())
