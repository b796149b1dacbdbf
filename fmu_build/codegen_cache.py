"""A content-addressed cache of the generated C, gw_funcs.c, and its functions (opt-in).

Generating a large model's C is a build's second cost after the compile: casadi.cse over the
functions, CasADi's code generator and make_internal's rewriting take 7 s of the Gyrover's
(gyrover_ice: 2.5 MB of C), and an FMU's FMI 2 and FMI 3 builds, or two builds of one scene in
other directories, generate the same text.  With GYROWHEEL_BUILD_CACHE set to a directory (the
compile cache's, gyrowheel.fmu_build.build_cache; unset or empty: off), codegen.generate_functions
looks the result up there first and stores what it generated.

The key (sha256, hex) covers everything the result depends on:
  - the functions to generate, by slot, as CasADi serialises them (Function.serialize: the
    expression graph, the names of the function, of its inputs and outputs);
  - CasADi: its version and git revision (its cse and code generator);
  - gyrowheel's code generation: the text of fmu_build/codegen.py and fmu_build/casadi_c.py (the
    CodeGenerator options, the cse, make_internal's rewriting), so any edit of them misses.
An entry, <key>.codegen.entry, holds gw_funcs.c's text and the generated functions (after cse,
serialised: what the Taylor kernel and model_desc.c are written from) as JSON, behind the
compile cache's digest line: written atomically, a damaged entry is generated again and
rewritten, and generations of one key wait for each other (build_cache.cached_entry).  A hit
writes the same gw_funcs.c and returns functions that generate the same C, so the FMU's
sources and binary are those of a build without the cache, byte for byte
(tests/test_codegen_cache.py checks a Gyrover's).
"""
from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path

import casadi as ca

from gyrowheel.fmu_build import build_cache

SUFFIX = ".codegen.entry"
# the modules whose text the generated C depends on (the cse, the generator's options, make_internal)
GENERATORS = tuple(Path(__file__).resolve().with_name(name) for name in ("codegen.py", "casadi_c.py"))


def casadi_identity() -> bytes:
    """CasADi's version and git revision."""
    return f"{ca.CasadiMeta.version()}\0{ca.CasadiMeta.git_revision()}".encode()


def codegen_key(functions: dict[str, ca.Function]) -> str:
    """The cache key of generating `functions` (slot -> CasADi Function), see the module's doc."""
    parts = [casadi_identity(), *(path.read_bytes() for path in GENERATORS)]
    for slot, fn in functions.items():
        parts += [slot.encode(), fn.serialize().encode()]
    digest = hashlib.sha256()
    for part in parts:
        digest.update(len(part).to_bytes(8, "little"))
        digest.update(part)
    return digest.hexdigest()


def cached_generation(functions: dict[str, ca.Function], c_file: Path,
                      generate: Callable[[], dict[str, ca.Function]]) -> dict[str, ca.Function]:
    """generate() (writes c_file, returns the generated functions by slot), or, with
    GYROWHEEL_BUILD_CACHE set and an entry of `functions` there, c_file written from the entry
    and its functions; what generate() made is stored."""
    directory = build_cache.cache_dir()
    if directory is None:
        return generate()

    def make() -> bytes:
        generated = generate()
        return json.dumps({"c": c_file.read_text(),
                           "functions": [[slot, f.serialize()] for slot, f in generated.items()]}).encode()
    data, hit = build_cache.cached_entry(directory, codegen_key(functions), SUFFIX, make)
    entry = json.loads(data)
    if hit:
        c_file.write_text(entry["c"])
    return {slot: ca.Function.deserialize(text) for slot, text in entry["functions"]}
