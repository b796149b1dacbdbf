"""CasADi's generated C made part of the FMU's single translation unit (c_src/gw_fmu.c).

casadi.CodeGenerator writes, per function, the evaluation entry point plus an API of a dozen
helpers (checkout, release, incref, n_in, name_in, sparsity_out, work_bytes, ...) and a few
file-level helpers (casadi_sq, ..._casadi_version), all with external linkage whatever the
options (CasADi 3.6-3.8: with_export only adds CASADI_SYMBOL_EXPORT to the API, not to
casadi_sq & co.).  Compiled as it comes, every FMU would export ~120 symbols with the same
names (two FMUs in one process would clash), and the body functions ignore some of the standard arguments
(32 -Wunused-parameter warnings).

`make_internal` rewrites the file so that it can only be part of the unity build:
  * every function the runtime calls (the `keep` names: <name> and <name>_work per slot) and
    every casadi_* helper becomes `static`; the rest of the API, unused by the runtime, is
    dropped, together with the sparsity patterns only it referred to;
  * each body function (casadi_f<N>) marks the standard arguments it ignores as used
    ((void)iw; ...), so the file is clean under -Wall -Wextra -Wpedantic;
  * each body's element loads `arg[i]? arg[i][j] : 0` become `arg[i][j]`: the runtime passes a
    valid pointer for every input it indexes (gw_model.h: only inputs of size 0 may be NULL,
    and those are never indexed), and the NULL tests split the body into branches that keep
    gcc from merging sin(x) and cos(x) into one sincos call (measured: one libm call, 5-7 ns,
    of a 28 ns right-hand side; docs/performance.md);
  * each body's sin and cos come from c_src/gw_sincos.h (static inline, at most 1 ulp;
    docs/performance.md): a cos(aY) and a sin(aY) of the same variable, aY unchanged in
    between, become one gw_sincos(aY, &gw_sN, &gw_cN) at the first of the two and reads of
    gw_sN / gw_cN (compilers do not merge two inlined reductions by themselves: measured); two
    such gw_sincos in a body (alpha and beta in gw_ode) become one gw_sincos2 at the second
    when nothing in between uses the first's output or changes its argument, and the
    second's argument is not the first's output (SSE2 lanes, the same bits); any other sin / cos a gw_sin / gw_cos; the file includes gw_sincos.h after
    <math.h>;
  * the whole file is guarded by GW_UNITY_BUILD, so that compiled on its own it is empty.
Anything it does not recognise (a function definition of another shape, a global left over)
raises CodegenFormatError naming the line: a new CasADi version fails the build loudly rather
than shipping a global symbol.  The result is checked by tests/test_fmu_sources.py (strict
gcc and clang builds, exported symbols, two FMUs in one process).
"""
from __future__ import annotations

import re

__all__ = ["CodegenFormatError", "make_internal", "UNITY_GUARD_OPEN", "UNITY_GUARD_CLOSE"]

UNITY_GUARD_OPEN = ("#ifndef GW_UNITY_BUILD\n"
                    "typedef int gw_unity_build_part; /* compiled on its own this file is empty: "
                    "see gw_fmu.c */\n#else\n")
UNITY_GUARD_CLOSE = "#endif /* GW_UNITY_BUILD */\n"

# a function definition head at column 0: return type, name, parameters, opening brace
_HEAD = re.compile(r"^(?P<static>static\s+)?(?P<type>[A-Za-z_][\w\s\*]*?[\s\*])(?P<name>[A-Za-z_]\w*)"
                   r"\((?P<params>[^;{}]*)\)\s*\{")
_SPARSITY = re.compile(r"^static const casadi_int (casadi_s\d+)\[\d+\] = \{[^;]*\};$")
_BODY = re.compile(r"casadi_f\d+")
_STANDARD_ARGS = ("arg", "res", "iw", "w", "mem")
_INPUT_LOAD = re.compile(r"\barg\[(\d+)\]\? arg\[\1\]\[(\d+)\] : 0;")
_TRIG = re.compile(r"(?<![\w.])(sin|cos)\(")
_TRIG_LINE = re.compile(r"^(?P<indent>\s*)(?P<out>\w+)=(?P<fn>sin|cos)\((?P<arg>\w+)\);$")
_MATH_INCLUDE = "#include <math.h>\n"
FASTMATH_INCLUDE = '#include "gw_sincos.h" /* gw_sin, gw_cos: see fmu_build/casadi_c.py */\n'


class CodegenFormatError(RuntimeError):
    """The CasADi output has a shape make_internal does not know."""


def _functions(lines: list[str]) -> list[tuple[int, int, re.Match]]:
    """(first line, last line, head match) of every top-level function definition."""
    found = []
    i = 0
    while i < len(lines):
        m = _HEAD.match(lines[i])
        if m and not lines[i].startswith((" ", "\t", "#")):
            depth = lines[i].count("{") - lines[i].count("}")
            j = i
            while depth > 0:
                j += 1
                if j >= len(lines):
                    raise CodegenFormatError(f"unterminated function {m['name']!r}")
                depth += lines[j].count("{") - lines[j].count("}")
            found.append((i, j, m))
            i = j + 1
        else:
            i += 1
    return found


def make_internal(text: str, keep: set[str]) -> str:
    """The generated C with internal linkage only, warning-clean, guarded for the unity build.

    text: the .c file casadi.CodeGenerator wrote (with_header=False, with_export=False).
    keep: names of the non-static functions the runtime references (gw_model.h slots).
    Raises CodegenFormatError if a kept name is missing or an unknown global remains.
    """
    lines = text.split("\n")
    drop: set[int] = set()
    seen: set[str] = set()
    for first, last, m in _functions(lines):
        name = m["name"]
        if m["static"]:
            if _BODY.fullmatch(name):
                for k in range(first + 1, last + 1):
                    lines[k] = _INPUT_LOAD.sub(r"arg[\1][\2];", lines[k])
                _merge_sincos(lines, first + 1, last)
                _pair_sincos(lines, first + 1, last)
                for k in range(first + 1, last + 1):
                    lines[k] = _TRIG.sub(r"gw_\1(", lines[k])
                body = "\n".join(lines[first + 1:last + 1])
                unused = [a for a in _STANDARD_ARGS
                          if re.search(rf"\b{a}\b", m["params"]) and not re.search(rf"\b{a}\b", body)]
                if unused:
                    lines[first] += "\n  " + " ".join(f"(void){a};" for a in unused)
            continue
        if name in keep or name.startswith("casadi_"):
            lines[first] = "static " + lines[first]
            seen.add(name)
        else:  # API the runtime never calls
            drop.update(range(first, last + 1))
            if last + 1 < len(lines) and lines[last + 1] == "":
                drop.add(last + 1)
    missing = keep - seen
    if missing:
        raise CodegenFormatError(f"generated C lacks the functions {sorted(missing)}")
    kept = [line for k, line in enumerate(lines) if k not in drop]
    # sparsity patterns referred to only by the dropped API
    code = "\n".join(kept)
    result = []
    for line in kept:
        sp = _SPARSITY.match(line)
        if sp and len(re.findall(rf"\b{sp.group(1)}\b", code)) <= 2:  # the #define and itself
            continue
        result.append(line)
    _check_no_globals(result)
    body = "\n".join(result).rstrip("\n") + "\n"
    if re.search(r"\bgw_(sin|cos|sincos|sincos2)\(", body):
        if _MATH_INCLUDE not in body:
            raise CodegenFormatError("generated C lacks #include <math.h>")
        body = body.replace(_MATH_INCLUDE, _MATH_INCLUDE + FASTMATH_INCLUDE, 1)
    return UNITY_GUARD_OPEN + "\n" + body + "\n" + UNITY_GUARD_CLOSE


def _merge_sincos(lines: list[str], first: int, last: int) -> None:
    """In lines[first:last+1] (one body), each pair `aX=cos(aY);` ... `aZ=sin(aY);` (either
    order, aY not assigned in between) -> one gw_sincos at the first line, a read at the second."""
    done: set[int] = set()
    n_pairs = 0
    for i in range(first, last + 1):
        m = _TRIG_LINE.match(lines[i])
        if not m or i in done:
            continue
        arg, other = m["arg"], "sin" if m["fn"] == "cos" else "cos"
        if m["out"] == arg:  # aY=sin(aY): aY is gone after this line
            continue
        assign = re.compile(rf"^\s*{re.escape(arg)}=")
        for j in range(i + 1, last + 1):
            mj = _TRIG_LINE.match(lines[j])
            if mj and j not in done and mj["fn"] == other and mj["arg"] == arg:
                s, c = f"gw_s{n_pairs}", f"gw_c{n_pairs}"
                mine, theirs = (c, s) if m["fn"] == "cos" else (s, c)
                lines[i] = (f"{m['indent']}casadi_real {s}, {c}; gw_sincos({arg}, &{s}, &{c}); "
                            f"{m['out']}={mine};")
                lines[j] = f"{mj['indent']}{mj['out']}={theirs};"
                done.update((i, j))
                n_pairs += 1
                break
            if assign.match(lines[j]) or "{" in lines[j] or "}" in lines[j]:  # changed, or scope
                break


_SINCOS_LINE = re.compile(r"^(?P<indent>\s*)casadi_real (?P<s>gw_s\d+), (?P<c>gw_c\d+); "
                          r"gw_sincos\((?P<arg>\w+), &(?P=s), &(?P=c)\); (?P<out>\w+)=(?P<val>gw_[sc]\d+);$")


def _pair_sincos(lines: list[str], first: int, last: int) -> None:
    """Two gw_sincos lines of one body -> one gw_sincos2 at the second (both arguments in the
    two lanes of a register), if nothing in between reads or writes the first one's outputs,
    writes its argument or opens or closes a block, and the second's argument is not the first
    one's output (sin(cos x) beside sin(x): the output is assigned only after the paired call,
    so the second lane would read it before it is written)."""
    found = [(i, m) for i in range(first, last + 1) if (m := _SINCOS_LINE.match(lines[i]))]
    for (i, m), (j, mj) in zip(found[::2], found[1::2]):
        between = "\n".join(lines[i + 1:j])
        used = re.search(rf"\b({m['out']}|{m['s']}|{m['c']})\b", between)
        if (used or mj["arg"] == m["out"] or re.search(rf"^\s*{m['arg']}=", between, re.M)
                or "{" in between or "}" in between):
            continue
        lines[i] = ""
        lines[j] = (f"{mj['indent']}casadi_real {m['s']}, {m['c']}, {mj['s']}, {mj['c']}; "
                    f"gw_sincos2({m['arg']}, {mj['arg']}, &{m['s']}, &{m['c']}, &{mj['s']}, &{mj['c']}); "
                    f"{m['out']}={m['val']}; {mj['out']}={mj['val']};")


def _check_no_globals(lines: list[str]) -> None:
    """Every top-level definition left must be static (or a preprocessor line, comment...)."""
    for first, _, m in _functions(lines):
        if not m["static"] and not lines[first].startswith("static "):
            raise CodegenFormatError(f"non-static function left: {lines[first]!r}")
    for line in lines:
        if re.match(r"^(const\s+)?(casadi_int|casadi_real|double|int|long)\b[^(]*=", line):
            raise CodegenFormatError(f"non-static object left: {line!r}")
