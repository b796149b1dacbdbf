"""Seeded fuzzer of fmi2 call sequences against one FMU's shared library (docs/fmi.md, "Fuzzing").

Each sequence instantiates the FMU (Co-Simulation or Model Exchange, by the seed), makes random
calls in random states with hostile arguments (unknown value references, NaN, inf, 1e308,
denormals, negative tolerances, corrupt FMU states, huge seeds), then checks that the instance
can still be terminated (if it was initialised), reset, re-initialised, stepped and freed.
The library is called through ctypes directly (no fmpy wrapper), with a logger of its own.

Invariants checked after every call (a violation is reported with the seed and the call):
  finite       no value written to a caller's array is non-finite; with a status above
               fmi2Warning the array is left untouched
  logged       every status other than fmi2OK comes with a logged message of that status (or is a
               repeat the FMU collapses: then the last such message had that status); unlike
               fmi3's, not always starting with the function's name (the step budget's refusals)
  allowed      fmi2Discard only from the functions FMI 2.0.4 section 2.1.3 allows it for
  recoverable  fmi2Terminate after an initialisation, fmi2Reset, a new initialisation and
               fmi2FreeInstance always succeed
  state        a call outside the states FMI 2.0.4's tables allow it in (tests/fmi_state_table.py)
               returns fmi2Error with its reason logged, naming the state the instance is in
               (tracked along the sequence: legal calls move it as the standard's diagrams say,
               every fmi2Error into Error)
The invariants' checks, the report and the command line are tests/fuzz/fuzz_common.py's: a
crash is a child process dying, best seen with the library built with ASan+UBSan (--sanitize;
docs/fmi.md, "Fuzzing").

    python tests/fuzz/fmi2_fuzz.py FMU [--sequences N] [--calls N] [--seed S] [--jobs J] [--sanitize]
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

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # tests/: the state tables
import fmi_state_table as ST  # noqa: E402
from fuzz.fuzz_common import (DISCARD, ERROR, HOSTILE, OK, WARNING, Report, check_call, cli,  # noqa: E402
                              prefill, run_in_process)

DISCARD_ALLOWED = {  # FMI 2.0.4 section 2.1.3 (fmiGetXXXStatus: every status inquiry)
    "ME": {"fmi2SetReal", "fmi2SetInteger", "fmi2SetBoolean", "fmi2SetString", "fmi2SetContinuousStates",
           "fmi2GetReal", "fmi2GetDerivatives", "fmi2GetContinuousStates", "fmi2GetEventIndicators"},
    "CS": {"fmi2SetReal", "fmi2SetInteger", "fmi2SetBoolean", "fmi2SetString", "fmi2DoStep", "fmi2GetStatus",
           "fmi2GetRealStatus", "fmi2GetIntegerStatus", "fmi2GetBooleanStatus", "fmi2GetStringStatus"},
}
LOGGER = C.CFUNCTYPE(None, C.c_void_p, C.c_char_p, C.c_int, C.c_char_p, C.c_char_p)
ALLOC = C.CFUNCTYPE(C.c_void_p, C.c_size_t, C.c_size_t)
FREE = C.CFUNCTYPE(None, C.c_void_p)
LIBC = C.CDLL(None)
LIBC.calloc.restype = C.c_void_p
LIBC.calloc.argtypes = [C.c_size_t, C.c_size_t]
LIBC.free.argtypes = [C.c_void_p]


class Callbacks(C.Structure):
    _fields_ = [("logger", LOGGER), ("allocateMemory", ALLOC), ("freeMemory", FREE),
                ("stepFinished", C.c_void_p), ("componentEnvironment", C.c_void_p)]


class EventInfo(C.Structure):
    _fields_ = [("newDiscreteStatesNeeded", C.c_int), ("terminateSimulation", C.c_int),
                ("nominalsOfContinuousStatesChanged", C.c_int), ("valuesOfContinuousStatesChanged", C.c_int),
                ("nextEventTimeDefined", C.c_int), ("nextEventTime", C.c_double)]


class Fuzzer:
    PLATFORM, UNITY = "linux64", "gw_fmu.c"  # where its library is, what builds it (--sanitize)
    HEADERS = Path(fmpy.__file__).resolve().parent / "c-code"

    def __init__(self, fmu: str | Path, unzipdir: str | Path | None = None):
        self.md = read_model_description(str(fmu))
        self.unzipdir = Path(unzipdir or extract(str(fmu)))
        ident = self.md.coSimulation.modelIdentifier
        self.lib = C.CDLL(str(self.unzipdir / "binaries" / "linux64" / f"{ident}.so"))
        for name in ("fmi2Instantiate",):
            getattr(self.lib, name).restype = C.c_void_p
        self.vars = self.md.modelVariables
        self.real = [v for v in self.vars if v.type == "Real"]
        self.states = [d.variable.derivative for d in self.md.derivatives]
        self.nx = len(self.states)
        self.nz = self.md.numberOfEventIndicators
        self.messages: list[tuple[int, str]] = []
        self._logger = LOGGER(self._log)
        self._cb = Callbacks(self._logger, ALLOC(lambda n, s: LIBC.calloc(n, s)), FREE(lambda p: LIBC.free(p)), None, None)

    def _log(self, env, name, status, category, message):
        self.messages.append((status, (message or b"").decode(errors="replace")))

    # ---- one call, with the invariants ----------------------------------------------------
    def call(self, rep: Report, kind: str, fn: str, *args, out=None, seed=0) -> int:
        n_before = len(self.messages)
        prefill(out)
        f = getattr(self.lib, fn)
        f.restype = C.c_int
        before, allowed = self.fstate, ST.legal(kind, fn, self.fstate, self.ended)
        t0 = time.perf_counter()
        status = f(C.c_void_p(self.c), *args)
        seconds = time.perf_counter() - t0
        self._track(kind, fn, status, allowed, args)
        rep.count(status)
        where = f"seed {seed}: {kind} {fn}{tuple(a for a in args if isinstance(a, (int, float)))} -> {status}"
        check_call(rep, where + f" (state {before})", fn, status, self.messages[n_before:], self.messages[:n_before],
                   allowed=allowed, reason="" if allowed else ST.refusal(kind, fn, before), out=out,
                   discard_ok=fn in DISCARD_ALLOWED[kind], seconds=seconds)
        return status

    def _track(self, kind: str, fn: str, status: int, allowed: bool, args) -> None:
        """The instance's state after the call, as the standard's diagrams say."""
        if status >= ERROR or not allowed:
            self.fstate = ST.ERROR
        elif fn == "fmi2DoStep" and status == DISCARD:
            self.fstate, self.ended = (ST.STEP_FAILED if self.fstate == ST.STEP_COMPLETE else self.fstate), True
        elif fn == "fmi2Reset":
            self.fstate, self.ended = ST.INSTANTIATED, False
        elif fn == "fmi2GetFMUstate":
            self.saved_states[args[0]._obj.value] = (self.fstate, self.ended)
        elif fn == "fmi2DeSerializeFMUstate":
            self.saved_states[args[2]._obj.value] = self.deserialized_from or (self.fstate, self.ended)
        elif fn == "fmi2SetFMUstate":
            self.fstate, self.ended = self.saved_states.get(args[0].value, (self.fstate, self.ended))
        else:
            self.fstate = ST.after(kind, fn, self.fstate)

    # ---- random arguments -------------------------------------------------------------------
    @staticmethod
    def value(rng: random.Random, v=None) -> float:
        if rng.random() < 0.35:
            return rng.choice(HOSTILE)
        start = float(v.start) if v is not None and v.start not in (None, "") else 1.0
        return start * rng.choice([1.0, 1.0, 0.5, 2.0, -1.0, 1e-3, 1e3]) + rng.gauss(0, 0.01)

    def vrs(self, rng: random.Random, pool, n=None):
        n = n or rng.randint(1, 4)
        out = [rng.choice(pool).valueReference if rng.random() > 0.05 else rng.randint(0, 10_000) for _ in range(n)]
        return (C.c_uint * n)(*out), n

    # ---- a sequence -------------------------------------------------------------------------
    def sequence(self, rep: Report, seed: int, n_calls: int) -> None:
        rng = random.Random(seed)
        kind = "ME" if rng.random() < 0.4 else "CS"
        self.messages.clear()
        self.c = self.lib.fmi2Instantiate(b"fuzz", 0 if kind == "ME" else 1, self.md.guid.encode(), b"",
                                          C.byref(self._cb), 0, int(rng.random() < 0.3))
        if not self.c:
            rep.breach("other", f"seed {seed}: fmi2Instantiate failed")
            return
        self.fstate, self.ended, self.saved_states, self.deserialized_from = ST.INSTANTIATED, False, {}, None
        t, initialised, saved = 0.0, False, []
        self._state = None  # FMU states belong to their instance
        ops = self.ops(kind)
        if rng.random() < 0.8:
            initialised = self.start(rep, kind, rng, seed)
        for _ in range(n_calls):
            op = rng.choice(ops)
            st = op(rep, kind, rng, seed, t)
            if st >= ERROR and rng.random() < 0.7:  # explore on: reset and start again
                self.call(rep, kind, "fmi2Reset", seed=seed)
                initialised, t = self.start(rep, kind, rng, seed), 0.0
                continue
            if op.__name__ == "op_exit_init" and st <= WARNING:
                initialised = True
            if op.__name__ == "op_reset" and st == OK:
                initialised = False
            if op.__name__ == "op_step" and st <= DISCARD:
                t = self._time()
            if op.__name__ == "op_get_state" and st == OK:
                saved.append(self._state)
        self.recover(rep, kind, seed, initialised)
        for state in saved:  # an FMU state outlives fmi2Reset, not fmi2FreeInstance's owner
            self.call(rep, kind, "fmi2FreeFMUstate", C.byref(state), seed=seed)
        self.lib.fmi2FreeInstance(C.c_void_p(self.c))
        rep.sequences += 1

    def start(self, rep: Report, kind: str, rng: random.Random, seed: int) -> bool:
        """A valid initialisation, sometimes with a spinless wheel (it falls within 0.5 s), sometimes
        left in Initialization Mode; True if it ended the initialisation."""
        self.call(rep, kind, "fmi2SetupExperiment", 0, C.c_double(0.0), C.c_double(0.0), 0, C.c_double(0.0), seed=seed)
        spin = [v for v in self.real if v.name == "gamma_dot"]
        if spin and rng.random() < 0.4:
            self.call(rep, kind, "fmi2SetReal", (C.c_uint * 1)(spin[0].valueReference), C.c_size_t(1),
                      (C.c_double * 1)(rng.choice([0.0, 1.0])), seed=seed)
        self.call(rep, kind, "fmi2EnterInitializationMode", seed=seed)
        if rng.random() < 0.15:  # the sequence goes on in Initialization Mode
            return False
        if kind == "ME":
            ok = self.call(rep, kind, "fmi2ExitInitializationMode", seed=seed) <= WARNING
            return ok and self.call(rep, kind, "fmi2NewDiscreteStates", C.byref(EventInfo()), seed=seed) == OK \
                and self.call(rep, kind, "fmi2EnterContinuousTimeMode", seed=seed) == OK
        return self.call(rep, kind, "fmi2ExitInitializationMode", seed=seed) <= WARNING

    def _time(self) -> float:
        v = C.c_double(0.0)
        f = self.lib.fmi2GetRealStatus
        f.restype = C.c_int
        f(C.c_void_p(self.c), 2, C.byref(v))  # fmi2LastSuccessfulTime
        return v.value

    def recover(self, rep: Report, kind: str, seed: int, initialised: bool) -> None:
        """terminate (if initialised), reset, initialise again, one step, must all work"""
        if initialised and self.call(rep, kind, "fmi2Terminate", seed=seed) > WARNING:
            why = self.messages[-1][1] if self.messages else ""
            # refused only where no simulation exists (a state of before the initialisation
            # restored, or an error in the initialisation itself)
            if not any(k in why for k in ("state Instantiated", "state InitializationMode",
                                          "failed before its initialisation")):
                rep.breach("other", f"seed {seed}: fmi2Terminate failed after an initialisation: {why}")
        if self.call(rep, kind, "fmi2Reset", seed=seed) != OK:
            rep.breach("other", f"seed {seed}: fmi2Reset failed")
            return
        ok = self.call(rep, kind, "fmi2SetupExperiment", 0, C.c_double(0.0), C.c_double(0.0), 0, C.c_double(0.0),
                       seed=seed) == OK
        ok = ok and self.call(rep, kind, "fmi2EnterInitializationMode", seed=seed) == OK
        ok = ok and self.call(rep, kind, "fmi2ExitInitializationMode", seed=seed) == OK
        if kind == "CS":
            ok = ok and self.call(rep, kind, "fmi2DoStep", C.c_double(0.0), C.c_double(0.01), 1, seed=seed) == OK
        else:
            x = (C.c_double * self.nx)()
            ok = ok and self.call(rep, kind, "fmi2GetDerivatives", x, C.c_size_t(self.nx), out=x, seed=seed) == OK
        ok = ok and self.call(rep, kind, "fmi2Terminate", seed=seed) == OK
        if not ok:
            rep.breach("other", f"seed {seed}: not usable after fmi2Reset: {self.messages[-3:]}")

    # ---- the operations ------------------------------------------------------------------------
    def ops(self, kind: str):
        common = [self.op_set_real, self.op_set_real, self.op_set_integer, self.op_set_boolean, self.op_set_string,
                  self.op_get_real, self.op_get_real, self.op_get_integer, self.op_get_boolean, self.op_setup,
                  self.op_enter_init, self.op_exit_init, self.op_exit_init, self.op_terminate, self.op_reset,
                  self.op_get_state, self.op_set_state, self.op_corrupt_state, self.op_dirder, self.op_dirder,
                  self.op_debug_logging]
        if kind == "CS":
            return common + [self.op_step] * 6 + [self.op_status] * 2
        return common + [self.op_event_mode, self.op_new_discrete, self.op_ct_mode, self.op_completed,
                         self.op_set_time, self.op_set_states, self.op_set_states, self.op_get_derivatives,
                         self.op_get_derivatives, self.op_get_indicators, self.op_get_states, self.op_nominals]

    def op_set_real(self, rep, kind, rng, seed, t):
        vr, n = self.vrs(rng, self.real)
        vals = (C.c_double * n)(*[self.value(rng) for _ in range(n)])
        return self.call(rep, kind, "fmi2SetReal", vr, C.c_size_t(n), vals, seed=seed)

    def op_set_integer(self, rep, kind, rng, seed, t):
        vr, n = self.vrs(rng, [v for v in self.vars if v.type in ("Integer", "Enumeration")] or self.vars, 1)
        val = (C.c_int * 1)(rng.choice([-1, 0, 1, 2, 3, 4, 5, 6, 42, 2**31 - 1]))
        return self.call(rep, kind, "fmi2SetInteger", vr, C.c_size_t(1), val, seed=seed)

    def op_set_boolean(self, rep, kind, rng, seed, t):
        vr, n = self.vrs(rng, self.vars, 1)
        return self.call(rep, kind, "fmi2SetBoolean", vr, C.c_size_t(1), (C.c_int * 1)(rng.choice([0, 1, 7])), seed=seed)

    def op_set_string(self, rep, kind, rng, seed, t):
        n = rng.choice([0, 1])
        return self.call(rep, kind, "fmi2SetString", (C.c_uint * 1)(1), C.c_size_t(n), (C.c_char_p * 1)(b"x"), seed=seed)

    def op_get_real(self, rep, kind, rng, seed, t):
        vr, n = self.vrs(rng, self.real, rng.randint(1, 12))
        out = (C.c_double * n)()
        return self.call(rep, kind, "fmi2GetReal", vr, C.c_size_t(n), out, out=out, seed=seed)

    def op_get_integer(self, rep, kind, rng, seed, t):
        vr, n = self.vrs(rng, self.vars, 2)
        return self.call(rep, kind, "fmi2GetInteger", vr, C.c_size_t(n), (C.c_int * n)(), seed=seed)

    def op_get_boolean(self, rep, kind, rng, seed, t):
        vr, n = self.vrs(rng, self.vars, 2)
        return self.call(rep, kind, "fmi2GetBoolean", vr, C.c_size_t(n), (C.c_int * n)(), seed=seed)

    def op_setup(self, rep, kind, rng, seed, t):
        tol = rng.choice([1e-4, 1e-8, self.value(rng)])
        start = rng.choice([0.0, 0.0, 1.0, self.value(rng)])
        return self.call(rep, kind, "fmi2SetupExperiment", int(rng.random() < 0.5), C.c_double(tol), C.c_double(start),
                         int(rng.random() < 0.3), C.c_double(start + rng.choice([1.0, 100.0, -1.0])), seed=seed)

    def op_enter_init(self, rep, kind, rng, seed, t):
        return self.call(rep, kind, "fmi2EnterInitializationMode", seed=seed)

    def op_exit_init(self, rep, kind, rng, seed, t):
        return self.call(rep, kind, "fmi2ExitInitializationMode", seed=seed)

    def op_terminate(self, rep, kind, rng, seed, t):
        return self.call(rep, kind, "fmi2Terminate", seed=seed)

    def op_reset(self, rep, kind, rng, seed, t):
        return self.call(rep, kind, "fmi2Reset", seed=seed) if rng.random() < 0.3 else OK

    def op_step(self, rep, kind, rng, seed, t):
        h = rng.choice([0.01, 0.1, 0.5, 2.0, 1e-9, 1e-16, 0.0, -0.1, math.nan])
        tc = t if rng.random() < 0.85 else self.value(rng)
        return self.call(rep, kind, "fmi2DoStep", C.c_double(tc), C.c_double(h), 1, seed=seed)

    def op_status(self, rep, kind, rng, seed, t):
        k = rng.randint(0, 3)
        which = rng.choice(["Real", "Boolean", "Integer", "Status", "String"])
        if which == "Real":
            out = (C.c_double * 1)()
            return self.call(rep, kind, "fmi2GetRealStatus", k, out, out=out, seed=seed)
        holder = {"Boolean": C.c_int, "Integer": C.c_int, "Status": C.c_int, "String": C.c_char_p}[which]()
        return self.call(rep, kind, f"fmi2Get{which}Status" if which != "Status" else "fmi2GetStatus", k,
                         C.byref(holder), seed=seed)

    def op_get_state(self, rep, kind, rng, seed, t):
        self._state = C.c_void_p()
        return self.call(rep, kind, "fmi2GetFMUstate", C.byref(self._state), seed=seed)

    def op_set_state(self, rep, kind, rng, seed, t):
        st = getattr(self, "_state", None)
        if st is None or not st.value:
            return OK
        return self.call(rep, kind, "fmi2SetFMUstate", st, seed=seed)

    def op_corrupt_state(self, rep, kind, rng, seed, t):
        st = getattr(self, "_state", None)
        if st is None or not st.value:
            return OK
        size = C.c_size_t()
        if self.call(rep, kind, "fmi2SerializedFMUstateSize", st, C.byref(size), seed=seed) != OK:
            return ERROR
        buf = (C.c_char * size.value)()
        if self.call(rep, kind, "fmi2SerializeFMUstate", st, buf, size, seed=seed) != OK:
            return ERROR
        raw = bytearray(buf.raw)
        for _ in range(rng.choice([0, 1, 1, 3])):
            i = rng.randrange(len(raw) * 8)
            raw[i // 8] ^= 1 << (i % 8)
        cut = rng.choice([len(raw), len(raw), len(raw) - 1, 10])
        data = (C.c_char * cut).from_buffer_copy(bytes(raw[:cut]))
        new = C.c_void_p()
        self.deserialized_from = self.saved_states.get(st.value)  # an accepted blob is unchanged
        st2 = self.call(rep, kind, "fmi2DeSerializeFMUstate", data, C.c_size_t(cut), C.byref(new), seed=seed)
        if st2 == OK:
            st2 = self.call(rep, kind, "fmi2SetFMUstate", new, seed=seed)
            self.call(rep, kind, "fmi2FreeFMUstate", C.byref(new), seed=seed)
        return st2

    def op_dirder(self, rep, kind, rng, seed, t):
        unk, nu = self.vrs(rng, self.real, rng.randint(1, 5))
        kn, nk = self.vrs(rng, self.real, rng.randint(1, 3))
        seeds = (C.c_double * nk)(*[rng.choice([1.0, -0.5, 1e308, 1e-300, 3.0]) for _ in range(nk)])
        out = (C.c_double * nu)()
        return self.call(rep, kind, "fmi2GetDirectionalDerivative", unk, C.c_size_t(nu), kn, C.c_size_t(nk),
                         seeds, out, out=out, seed=seed)

    def op_debug_logging(self, rep, kind, rng, seed, t):
        return self.call(rep, kind, "fmi2SetDebugLogging", int(rng.random() < 0.5), C.c_size_t(0), None, seed=seed)

    def op_event_mode(self, rep, kind, rng, seed, t):
        return self.call(rep, kind, "fmi2EnterEventMode", seed=seed)

    def op_new_discrete(self, rep, kind, rng, seed, t):
        return self.call(rep, kind, "fmi2NewDiscreteStates", C.byref(EventInfo()), seed=seed)

    def op_ct_mode(self, rep, kind, rng, seed, t):
        return self.call(rep, kind, "fmi2EnterContinuousTimeMode", seed=seed)

    def op_completed(self, rep, kind, rng, seed, t):
        a, b = C.c_int(), C.c_int()
        return self.call(rep, kind, "fmi2CompletedIntegratorStep", 1, C.byref(a), C.byref(b), seed=seed)

    def op_set_time(self, rep, kind, rng, seed, t):
        return self.call(rep, kind, "fmi2SetTime", C.c_double(rng.choice([0.1, 1.0, self.value(rng)])), seed=seed)

    def op_set_states(self, rep, kind, rng, seed, t):
        x = (C.c_double * self.nx)()
        self.call(rep, kind, "fmi2GetContinuousStates", x, C.c_size_t(self.nx), out=x, seed=seed)
        vals = [v if math.isfinite(v) else 0.0 for v in x]
        i = rng.randrange(self.nx)
        vals[i] = vals[i] * rng.choice([1.0, 1.01, -1.0]) + (rng.choice(HOSTILE) if rng.random() < 0.2 else 0.01)
        return self.call(rep, kind, "fmi2SetContinuousStates", (C.c_double * self.nx)(*vals), C.c_size_t(self.nx),
                         seed=seed)

    def op_get_derivatives(self, rep, kind, rng, seed, t):
        x = (C.c_double * self.nx)()
        return self.call(rep, kind, "fmi2GetDerivatives", x, C.c_size_t(self.nx), out=x, seed=seed)

    def op_get_indicators(self, rep, kind, rng, seed, t):
        z = (C.c_double * max(self.nz, 1))()
        return self.call(rep, kind, "fmi2GetEventIndicators", z, C.c_size_t(self.nz), out=z, seed=seed)

    def op_get_states(self, rep, kind, rng, seed, t):
        x = (C.c_double * self.nx)()
        return self.call(rep, kind, "fmi2GetContinuousStates", x, C.c_size_t(self.nx), out=x, seed=seed)

    def op_nominals(self, rep, kind, rng, seed, t):
        x = (C.c_double * self.nx)()
        return self.call(rep, kind, "fmi2GetNominalsOfContinuousStates", x, C.c_size_t(self.nx), out=x, seed=seed)


def fuzz(fmu: str | Path, sequences: int, calls: int, seed: int = 0, unzipdir=None) -> Report:
    """sequences sequences of `calls` calls from seed on, in this process."""
    return run_in_process(Fuzzer(fmu, unzipdir), "fmi2", seed, sequences, calls)


def main(argv=None) -> int:
    return cli(argv, "fmi2", __doc__, Fuzzer, __file__)


if __name__ == "__main__":
    sys.exit(main())
