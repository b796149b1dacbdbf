"""The exchange of a communication point, shared by gyrowheel's master (cosim/master.py) and the
sweep's (studies/system_target.py).

A link is (read, write, linear): read() fetches the connection's output, write(value) sets its
input, linear is (factor, offset) of its ssc:LinearTransformation or None. The levels come from
exchange_levels (from the FMUs' feedthrough; SystemDescription.check refuses a loop): within a
level every output is read before any input is set, so the file's order of the connections does
not matter; levels run in order, so an output with direct feedthrough is read after the inputs
it depends on are set.
"""
from __future__ import annotations

import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from gyrowheel.cosim.system import SystemDescription, SystemFileError, describe


def exchange(levels: list[list[int]], links: list) -> list:
    """One exchange; returns the value each link carried (after its transformation)."""
    carried = [None] * len(links)
    for level in levels:
        for i in level:
            read, _, linear = links[i]
            value = read()
            carried[i] = value if linear is None else linear[0] * value + linear[1]
        for i in level:
            links[i][1](carried[i])
    return carried


def settle(levels: list[list[int]], links: list) -> list[int]:
    """Exchanges in Initialization Mode, where an output may also depend on inputs through its
    InitialUnknowns dependencies (FMI 2.0.4 section 2.2.8), until one carries exactly what the
    previous one carried (NaN equal to NaN): at most len(links) + 2 exchanges. Returns [] when
    the values settled, else the indices of the links whose values still changed."""
    carried = exchange(levels, links)
    moving = []
    for _ in range(len(links) + 1):
        again = exchange(levels, links)
        moving = [i for i, (a, b) in enumerate(zip(carried, again)) if not (a == b or (a != a and b != b))]
        if not moving:
            return []
        carried = again
    return moving


def exchange_levels(system: SystemDescription) -> list[list[int]]:
    """The order of a communication point's exchange: levels of indices into system.connections.

    Every connection of a level is read (its output fetched) before any of that level is set, so
    the file's order of the connections never matters (a Jacobi exchange). A connection whose
    output has direct feedthrough from an input that another connection sets (the output's
    ModelStructure/Outputs dependencies, FMI 2.0.4 section 2.2.8: no attribute means every
    input) comes in a later level than that connection, so it carries the value its source
    computes from the input just set. A cycle of such connections is an algebraic loop, which a
    master of fixed steps cannot resolve: SystemFileError naming each connection and each
    feedthrough of the loop.
    """
    feeds = {c.name: feedthrough(c.fmu, c.name) for c in system.components}
    setters = {(k.end_element, k.end_connector): i for i, k in enumerate(system.connections)}
    after = {}  # connection -> the connections it must follow
    for i, k in enumerate(system.connections):
        inputs = feeds.get(k.start_element, {}).get(k.start_connector, ())
        after[i] = sorted(setters[(k.start_element, u)] for u in inputs if (k.start_element, u) in setters)
    levels, placed = [], {}
    state = {}  # 1: on the current path, 2: done

    def visit(i, path):
        if state.get(i) == 2:
            return placed[i]
        if state.get(i) == 1:
            raise SystemFileError(f"system {system.name!r}: algebraic loop "
                                  f"{_loop_text(system, path[path.index(i):][::-1])}: gyrowheel's master "
                                  f"does not solve algebraic loops: break it with a component whose output does "
                                  f"not depend directly on its input")
        state[i] = 1
        level = 1 + max((visit(j, path + [i]) for j in after[i]), default=-1)
        state[i], placed[i] = 2, level
        return level

    for i in range(len(system.connections)):
        visit(i, [])
    for i in range(len(system.connections)):
        while len(levels) <= placed[i]:
            levels.append([])
        levels[placed[i]].append(i)
    return levels


def _loop_text(system: SystemDescription, loop: list[int]) -> str:
    """'A.y -> B.u, B.y -> A.u (B.y depends directly on B.u, A.y on A.u: ...)' for a cycle of
    connections in the order the values flow."""
    first = loop.index(min(loop))  # start at the loop's first connection in the file
    links = [system.connections[j] for j in loop[first:] + loop[:first]]
    through = [f"{n.start_element}.{n.start_connector} on {k.end_element}.{k.end_connector}"
               for k, n in zip(links, links[1:] + links[:1])]
    return (", ".join(describe(k) for k in links) + " (" + through[0].replace(" on ", " depends directly on ", 1)
            + "".join(", " + t for t in through[1:]) + ": ModelStructure/Outputs dependencies, FMI 2.0.4 "
            "section 2.2.8)")


def feedthrough(fmu: str | Path, component: str = "") -> dict[str, tuple[str, ...]]:
    """{output: inputs it depends on directly} of an FMI 2.0 or 3.0 FMU, from modelDescription.xml's
    ModelStructure (FMI 2.0.4 section 2.2.8, FMI 3.0.2 section 2.4.8: an output without a
    dependencies attribute depends on every known, i.e. every input; an empty one on none; of
    the listed knowns only the inputs count). Outputs with no input dependency are left out. Raises SystemFileError if
    the file cannot be read."""
    where = f"component {component!r}: " if component else ""
    fmu = Path(fmu)
    try:
        if fmu.is_dir():
            text = (fmu / "modelDescription.xml").read_bytes()
        else:
            with zipfile.ZipFile(fmu) as zf:
                text = zf.read("modelDescription.xml")
        root = ET.fromstring(text)
    except (OSError, KeyError, zipfile.BadZipFile, ET.ParseError) as exc:
        raise SystemFileError(f"{where}{fmu.name} is not a readable FMU ({type(exc).__name__}: {exc})") from None
    if root.get("fmiVersion", "").startswith("3."):
        # FMI 3.0.2 section 2.4.8: ModelStructure/Output names its variable and its dependencies
        # by value reference; the variables are ModelVariables' children of every type
        listed = root.find("ModelVariables")
        variables = list(listed) if listed is not None else []
        by_vr = {v.get("valueReference"): v for v in variables}
        unknowns, key = root.findall("ModelStructure/Output"), "valueReference"
        bad = "ModelStructure has an Output with a bad valueReference"

        def named(ref: str) -> str:
            return by_vr[ref].get("name")
    else:
        # FMI 2.0.4 section 2.2.8: ModelStructure/Outputs/Unknown by 1-based index into ModelVariables
        variables = root.findall("ModelVariables/ScalarVariable")
        unknowns, key = root.findall("ModelStructure/Outputs/Unknown"), "index"
        bad = "ModelStructure/Outputs has an Unknown with a bad index"

        def named(index: str) -> str:
            if not 1 <= int(index) <= len(variables):
                raise IndexError(index)
            return variables[int(index) - 1].get("name")
    inputs = [v.get("name") for v in variables if v.get("causality") == "input"]
    out = {}
    for unknown in unknowns:
        try:
            name = named(unknown.get(key))
            deps = unknown.get("dependencies")
            used = list(inputs) if deps is None else [n for n in map(named, deps.split()) if n in inputs]
        except (TypeError, ValueError, IndexError, KeyError):
            raise SystemFileError(f"{where}{fmu.name}: {bad} "
                                  f"or dependencies ({ET.tostring(unknown, encoding='unicode').strip()})") from None
        if used:
            out[name] = tuple(used)
    return out
