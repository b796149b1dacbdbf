"""What the FMI call-sequence fuzzers (tests/fuzz/fmi2_fuzz.py, fmi3_fuzz.py) share: the
invariants checked after every call, the report, the isolation of a long run in child processes
(a crash or a hang is counted, named by its seed, and the run goes on) and the build of an FMU's
library with AddressSanitizer and UndefinedBehaviorSanitizer (docs/fmi.md, "Fuzzing").

Invariants after every call (check_call):
  finite       no value written to a caller's array is non-finite; with a status above Warning
               the array is left untouched
  logged       every status other than OK comes with a logged message of that status (or is a
               repeat the FMU collapses: then the last such message had that status); with
               `named`, the message starts with the function's name
  state        a call outside the states the standard allows it in returns Error with its
               reason logged
  allowed      Discard only from the functions the standard allows it for
  hang         no call takes longer than CALL_SECONDS
A crash is the child process dying (under the sanitizers: any report); a hang is a child that
finishes no sequence within SEQUENCE_SECONDS, or a call over CALL_SECONDS.
"""
from __future__ import annotations

import json
import math
import os
import selectors
import subprocess
import sys
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4
HOSTILE = [math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, -5e-324, 0.0, -1.0, 1e-300, 1e6, 42.0]
SENTINEL = 12345.678
CALL_SECONDS = 5.0        # one call longer than this is a hang
SEQUENCE_SECONDS = 120.0  # a child finishing no sequence for this long hangs: it is killed
KEEP = 2000               # violation texts kept (all are counted)

# the kinds of breach the totals count, in the order they are printed
KINDS = {"crash": "crashes", "hang": "hangs", "non-finite": "non-finite writes",
         "written": "writes despite failure", "unlogged": "unlogged refusals",
         "state": "illegal calls not refused", "discard": "misplaced discards", "other": "other violations"}


@dataclass
class Report:
    api: str = "fmi2"
    sequences: int = 0
    calls: int = 0
    statuses: dict[int, int] = field(default_factory=dict)
    violations: list[str] = field(default_factory=list)
    breaches: dict[str, int] = field(default_factory=dict)
    seconds: float = 0.0
    seen: dict[str, int] = field(default_factory=dict)  # what the calls ran into (events, ...)

    def breach(self, kind: str, text: str) -> None:
        self.breaches[kind] = self.breaches.get(kind, 0) + 1
        if len(self.violations) < KEEP:
            self.violations.append(text)

    def saw(self, what: str) -> None:
        self.seen[what] = self.seen.get(what, 0) + 1

    def count(self, status: int) -> None:
        self.calls += 1
        self.statuses[status] = self.statuses.get(status, 0) + 1

    def merge(self, other: "Report") -> None:
        self.sequences += other.sequences
        self.calls += other.calls
        for k, v in other.statuses.items():
            self.statuses[int(k)] = self.statuses.get(int(k), 0) + v
        for k, v in other.breaches.items():
            self.breaches[k] = self.breaches.get(k, 0) + v
        for k, v in other.seen.items():
            self.seen[k] = self.seen.get(k, 0) + v
        self.violations.extend(other.violations[:max(0, KEEP - len(self.violations))])

    def summary(self) -> str:
        names = {0: "OK", 1: "Warning", 2: "Discard", 3: "Error", 4: "Fatal"}
        counts = ", ".join(f"{names.get(k, k)} {v}" for k, v in sorted(self.statuses.items()))
        seen = "".join(f", {k} {v}" for k, v in sorted(self.seen.items()))
        return (f"{self.sequences} sequences, {self.calls} {self.api} calls in {self.seconds:.1f} s ({counts}{seen}); "
                f"{sum(self.breaches.values())} violations")

    def totals(self) -> str:
        parts = [f"sequences {self.sequences}", f"calls {self.calls}"]
        parts += [f"{label} {self.breaches.get(kind, 0)}" for kind, label in KINDS.items()]
        return ", ".join(parts)


def check_call(rep: Report, where: str, fn: str, status: int, new: list[tuple[int, str]],
               history: list[tuple[int, str]], *, allowed: bool = True, reason: str = "",
               out=None, discard_ok: bool = True, named: bool = False, seconds: float = 0.0) -> None:
    """The invariants after one call of fn that answered status.

    new: the (status, message) pairs logged during the call; history: those logged before it;
    allowed: the call is legal in the state it was made in (else it must answer Error and log
    reason); out: the caller's array (filled with SENTINEL before the call) or None; discard_ok:
    Discard is an allowed answer of fn; named: a message of a non-OK status starts with fn."""
    if seconds > CALL_SECONDS:
        rep.breach("hang", f"{where}: the call took {seconds:.1f} s")
    if not allowed:
        said = [m for _, m in new] or [m for s, m in history if s != OK][-1:]
        if status != ERROR or not any(reason in m for m in said):
            rep.breach("state", f"{where}: illegal here: not {rep.api}Error with {reason!r}")
    if status == DISCARD and not discard_ok:
        rep.breach("discard", f"{where}: {rep.api}Discard is not allowed for {fn}")
    if status != OK and not _logged(fn, status, new, history, named):
        rep.breach("unlogged", f"{where}: status {status} without a logged reason"
                               + (f" starting with {fn!r}" if named else "") + f": {new}")
    if out is not None:
        values = list(out)
        if status > WARNING and any(v != SENTINEL for v in values):
            rep.breach("written", f"{where}: array written despite status {status}")
        if any(not math.isfinite(v) for v in values):
            rep.breach("non-finite", f"{where}: non-finite value written {values}")


def _logged(fn: str, status: int, new, history, named: bool) -> bool:
    def fits(s: int, m: str) -> bool:
        return s == status and (not named or m.startswith(fn) or m.startswith("(the previous message"))
    if any(fits(s, m) for s, m in new):
        return True
    last = [(s, m) for s, m in [*history, *new] if s != OK][-1:]  # a repeat the FMU counts, not logs
    return bool(last) and fits(*last[0])


def run_in_process(fuzzer, api: str, first: int, count: int, calls: int) -> Report:
    """Sequences first .. first+count-1 of `calls` calls in this process (a crash ends it)."""
    rep = Report(api=api)
    t0 = time.perf_counter()
    for seed in range(first, first + count):
        fuzzer.sequence(rep, seed, calls)
    rep.seconds = time.perf_counter() - t0
    return rep


def prefill(out) -> None:
    if out is not None:
        for i in range(len(out)):
            out[i] = SENTINEL


# ---- a long run in child processes ---------------------------------------------------------------
def child_loop(fuzzer, api: str, first: int, count: int, calls: int) -> None:
    """Run in a child: sequences first .. first+count-1, one JSON line of the sequence's report
    each on stdout (the parent's progress and totals)."""
    for seed in range(first, first + count):
        rep = Report(api=api)
        t0 = time.perf_counter()
        fuzzer.sequence(rep, seed, calls)
        rep.seconds = time.perf_counter() - t0
        sys.stdout.write(json.dumps({"seed": seed, "report": asdict(rep)}) + "\n")
        sys.stdout.flush()


def _from_json(d: dict) -> Report:
    r = Report(**{k: v for k, v in d.items() if k != "statuses"})
    r.statuses = {int(k): v for k, v in d["statuses"].items()}
    return r


def run_isolated(child_cmd: list[str], api: str, first: int, count: int, env: dict | None = None,
                 sequence_seconds: float = SEQUENCE_SECONDS) -> Report:
    """Sequences first .. first+count-1 in child processes: child_cmd + [--first F --count N]
    (which runs child_loop). A child that dies is a crash at the sequence it was in, one that
    finishes no sequence in sequence_seconds a hang (it is killed); either way a new child goes
    on with the next seed."""
    total, seed, end = Report(api=api), first, first + count
    while seed < end:
        proc = subprocess.Popen(child_cmd + ["--first", str(seed), "--count", str(end - seed)],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)
        err: list[str] = []
        reader = threading.Thread(target=lambda: err.extend(proc.stderr), daemon=True)
        reader.start()
        sel = selectors.DefaultSelector()
        sel.register(proc.stdout, selectors.EVENT_READ)
        while True:
            if not sel.select(timeout=sequence_seconds):
                proc.kill()
                proc.wait()
                total.breach("hang", f"seed {seed}: no sequence finished in {sequence_seconds:.0f} s")
                seed += 1
                break
            line = proc.stdout.readline()
            if not line:
                code = proc.wait()
                reader.join(5)
                if seed < end or code != 0:
                    total.breach("crash", f"seed {seed}: the process exited with {code}: {_crash_report(err)}")
                    seed += 1
                break
            msg = json.loads(line)
            total.merge(_from_json(msg["report"]))
            total.seconds += msg["report"]["seconds"]
            seed = msg["seed"] + 1
        sel.close()
        proc.stdout.close()
    return total


def _crash_report(err: list[str]) -> str:
    """The head of a sanitizer's report (what and where), else the end of stderr."""
    starts = [k for k, line in enumerate(err) if "ERROR: AddressSanitizer" in line or "runtime error:" in line]
    lines = err[starts[0]:starts[0] + 14] if starts else err[-20:]
    return "".join(lines).strip()[:3000]


def run_parallel(child_cmd: list[str], api: str, first: int, count: int, jobs: int,
                 env: dict | None = None) -> Report:
    """run_isolated over `jobs` children at once, each a contiguous share of the seeds."""
    shares = [(first + k * count // jobs, (k + 1) * count // jobs - k * count // jobs) for k in range(jobs)]
    results: list[Report] = [Report(api=api) for _ in shares]

    def one(k: int) -> None:
        results[k] = run_isolated(child_cmd, api, shares[k][0], shares[k][1], env)
    threads = [threading.Thread(target=one, args=(k,)) for k in range(jobs)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    total = Report(api=api)
    for r in results:
        total.merge(r)
        total.seconds = max(total.seconds, r.seconds)
    return total


# ---- the library built with the sanitizers -------------------------------------------------------
SANITIZE = ["-std=c99", "-shared", "-fPIC", "-O1", "-g", "-fno-omit-frame-pointer",
            "-fsanitize=address,undefined", "-fno-sanitize-recover=all"]


def sanitized_library(unzipdir: str | Path, unity: str, library: str | Path, headers: str | Path) -> dict:
    """Compile the FMU's sources/<unity> with ASan+UBSan over its shipped library (unzipdir is a
    copy of the FMU's files: the library is replaced) and return the environment a process that
    loads it needs (the sanitizers' runtimes preloaded: python itself is not instrumented)."""
    src = Path(unzipdir) / "sources"
    cmd = ["gcc", *SANITIZE, f"-I{src}", f"-I{headers}", str(src / unity), "-o", str(library), "-lm"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}\n{r.stderr}")
    runtimes = [subprocess.run(["gcc", f"-print-file-name={lib}"], capture_output=True, text=True,
                               check=True).stdout.strip() for lib in ("libasan.so", "libubsan.so")]
    env = dict(os.environ)
    env["LD_PRELOAD"] = ":".join(runtimes)
    env["ASAN_OPTIONS"] = "detect_leaks=0:abort_on_error=0"  # python's own allocations are no finding
    env["UBSAN_OPTIONS"] = "print_stacktrace=1:halt_on_error=1"
    env["PYTHONMALLOC"] = "malloc"  # the caller's arrays in ASan's heap: a write past one is reported
    return env


# ---- the command line both fuzzers share ---------------------------------------------------------
def cli(argv, api: str, doc: str, fuzzer_class, script: str) -> int:
    """python tests/fuzz/<api>_fuzz.py FMU [--sequences N] [--calls N] [--seed S] [--jobs J]
    [--sanitize] [--in-process]: the totals line, the summary and the first violations; exit
    status 1 on any violation. Without --in-process every sequence runs in a child process
    (crashes and hangs counted); --sanitize first builds the FMU's library from its sources with
    ASan+UBSan (fuzzer_class.UNITY) in a copy of the FMU's files."""
    import argparse
    import tempfile

    from fmpy import extract, read_model_description

    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("fmu")
    ap.add_argument("--sequences", type=int, default=20000)
    ap.add_argument("--calls", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=1, help="child processes at once")
    ap.add_argument("--sanitize", action="store_true", help="the library built with ASan+UBSan")
    ap.add_argument("--in-process", action="store_true", help="no child processes (a crash ends the run)")
    ap.add_argument("--unzipdir", help=argparse.SUPPRESS)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--first", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--count", type=int, default=0, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        child_loop(fuzzer_class(a.fmu, a.unzipdir), api, a.first, a.count, a.calls)
        return 0
    with tempfile.TemporaryDirectory(prefix=f"{api}_fuzz_") as tmp:
        unzipdir, env = a.unzipdir, None
        if a.sanitize:
            unzipdir = extract(a.fmu, unzipdir=tmp)
            md = read_model_description(a.fmu)
            ident = (md.coSimulation or md.modelExchange).modelIdentifier
            lib = Path(unzipdir) / "binaries" / fuzzer_class.PLATFORM / f"{ident}.so"
            env = sanitized_library(unzipdir, fuzzer_class.UNITY, lib, fuzzer_class.HEADERS)
        t0 = time.perf_counter()
        if a.in_process:
            rep = run_in_process(fuzzer_class(a.fmu, unzipdir), api, a.seed, a.sequences, a.calls)
        else:
            cmd = [sys.executable, script, a.fmu, "--child", "--calls", str(a.calls)]
            if unzipdir:
                cmd += ["--unzipdir", str(unzipdir)]
            rep = run_parallel(cmd, api, a.seed, a.sequences, max(1, a.jobs), env)
        rep.seconds = time.perf_counter() - t0
    print(rep.totals())
    print(rep.summary())
    for v in rep.violations[:50]:
        print("  " + v)
    return 1 if rep.breaches else 0
