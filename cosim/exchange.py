"""The exchange of a communication point, shared by gyrowheel's master (cosim/master.py) and the
sweep's (studies/system_target.py).

A link is (read, write, linear): read() fetches the connection's output, write(value) sets its
input, linear is (factor, offset) of its ssc:LinearTransformation or None. The levels come from
gyrowheel.cosim.system.exchange_levels: within a level every output is read before any input is
set, so the file's order of the connections does not matter; levels run in order, so an output
with direct feedthrough is read after the inputs it depends on are set.
"""
from __future__ import annotations


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
