"""Whether a model name can prefix the C API of `gyrowheel export-c` (docs/c_api.md).

The name becomes the opaque type (`typedef struct NAME NAME;`), the prefix of every function
(NAME_create) and macro (NAME_NP), and the file names NAME.h / NAME.c that users put on their
include path.  So beyond being an ASCII C identifier it must not be
  - a keyword of C (C99 to C23) or C++ (the header is used from C++ under extern "C"),
  - reserved by C (a leading underscore) or C++ (a double underscore anywhere),
  - the name of a standard C or common POSIX header (NAME.h on `-I.` would hide <NAME.h>:
    compared without case, as on case-insensitive file systems),
  - a name the C library declares (`system`, `clock`, `log`, `FILE`, `errno`, ...): found by
    compiling `typedef struct NAME NAME;` after every standard header (`probe`).
"""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

from gyrowheel.scratch import temporary_directory

C_KEYWORDS = frozenset("""auto break case char const continue default do double else enum extern float
for goto if inline int long register restrict return short signed sizeof static struct switch typedef
union unsigned void volatile while
alignas alignof bool constexpr false nullptr static_assert thread_local true typeof typeof_unqual""".split())
CXX_KEYWORDS = frozenset("""and and_eq asm bitand bitor catch char8_t char16_t char32_t class compl concept
consteval constinit const_cast co_await co_return co_yield decltype delete dynamic_cast explicit export
friend mutable namespace new noexcept not not_eq operator or or_eq private protected public
reinterpret_cast requires static_cast template this throw try typeid typename using virtual wchar_t
xor xor_eq""".split())
RESERVED = frozenset({"main"})  # the program's entry point
C_HEADERS = ("assert complex ctype errno fenv float inttypes iso646 limits locale math setjmp signal "
             "stdalign stdarg stdatomic stdbit stdbool stdckdint stddef stdint stdio stdlib stdnoreturn "
             "string tgmath threads time uchar wchar wctype").split()
POSIX_HEADERS = "dirent dlfcn fcntl poll pthread sched semaphore strings termios unistd".split()
# the headers the probe includes: C99's (every C99 compiler has them) and the POSIX ones a
# real-time program includes (the export's own realtime.c: time.h, sys/mman.h)
PROBE_HEADERS = ("assert complex ctype errno fenv float inttypes iso646 limits locale math setjmp signal "
                 "stdarg stdbool stddef stdint stdio stdlib string tgmath time wchar wctype").split()


class ModelNameError(ValueError):
    """The model name cannot prefix a C API; the message says why and what to do."""


def check(name: str) -> str:
    """The model name, or ModelNameError (no compiler needed)."""
    rename = "; rename the model in [model] name"
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
        raise ModelNameError(f"model name {name!r} is not an ASCII C identifier (letters, digits, _)")
    if name in C_KEYWORDS or name in CXX_KEYWORDS:
        lang = "C" if name in C_KEYWORDS else "C++"
        raise ModelNameError(f"model name {name!r} is a {lang} keyword{rename}")
    if name in RESERVED:
        raise ModelNameError(f"model name {name!r} is reserved in C (the program's entry point){rename}")
    if name.startswith("_") or "__" in name:
        raise ModelNameError(f"model name {name!r} is a reserved identifier in C or C++ "
                             f"(a leading underscore, or two underscores in a row){rename}")
    if re.match(r"(?i)(gw_|gwc_|gyrowheel)", name):
        raise ModelNameError(f"model name {name!r} starts with a prefix the runtime reserves (gw_, gwc_, gyrowheel)")
    if name.lower() in C_HEADERS + POSIX_HEADERS:
        where = "" if name == name.lower() else " (on a case-insensitive file system)"
        raise ModelNameError(f"model name {name!r} would make {name}.h hide the system header "
                             f"<{name.lower()}.h>{where} of programs built with -I on the export{rename}")
    return name


def _compiles(cc: str, headers: list[str], name: str) -> bool:
    source = "".join(f"#include <{h}.h>\n" for h in headers) + f"typedef struct {name} {name};\n"
    with temporary_directory("name") as tmp:
        path = Path(tmp) / "probe.c"
        path.write_text(source)
        proc = subprocess.run([cc, "-std=c99", "-fsyntax-only", str(path)], capture_output=True, text=True)
    return proc.returncode == 0


def probe(name: str, cc: str) -> None:
    """ModelNameError if `typedef struct NAME NAME;` does not compile after the C library's
    headers, naming the header that declares NAME.  Runs the C compiler `cc` once (and once
    per header to name it, on a clash only)."""
    if _compiles(cc, PROBE_HEADERS, name):
        return
    header = next((f" <{h}.h>" for h in PROBE_HEADERS if not _compiles(cc, [h], name)), "s")
    raise ModelNameError(f"model name {name!r} clashes with a name declared by the C library's header{header}: "
                         f"a program including it could not use the export; rename the model in [model] name")
