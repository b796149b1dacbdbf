"""A system of FMUs (an SSP 1.0 .ssp, e.g. the Gyrover's wheel + controller) as a sweep target.

The same stepping as gyrowheel's own master (cosim/master.py): every communication step each
component steps from t to t + h with its inputs held, then the connections carry the outputs to
the inputs in the levels of gyrowheel.cosim.exchange.exchange_levels (Jacobi within a level,
outputs with direct feedthrough after the inputs they depend on), each with its linear
transformation; in Initialization Mode the exchange is repeated until the values settle.
The sweep's --output-interval is the master's communication step. A component that terminates
(the wheel falling: fmi2Discard + fmi2Terminated) ends the run there, as a fall, not a failure.

Names: the first component (the plant, 'wheel') keeps its variables' own names (M, beta_deg,
beta, x ...), so the built-in metrics read its outputs; every component's variables are also
'<component>.<variable>' (controller.gain_scale, controller.tilt_cmd).
"""
from __future__ import annotations

from dataclasses import replace
from functools import partial
from pathlib import Path

from gyrowheel.cosim.exchange import exchange, exchange_levels, settle
from gyrowheel.scratch import temporary_directory
from gyrowheel.studies.target import FmuTarget, PointFailure


class SspTarget:
    """Components and connections of an .ssp; each worker opens one instance of every component."""

    def __init__(self, path: str | Path):
        from gyrowheel.cosim.ssp import read_ssp

        self.path = Path(path)
        with temporary_directory("sweep-ssp") as tmp:
            system = read_ssp(self.path, tmp)
            self.components = {c.name: FmuTarget(c.fmu) for c in system.components}
            self._bytes = {name: t.payload() for name, t in self.components.items()}
            self.levels = exchange_levels(system)  # the FMUs' ModelStructure, while they are unpacked
        self.plant = system.components[0].name
        self.starts = {c.name: dict(c.start_values) for c in system.components}
        self.connections = [(k.start_element, k.start_connector, k.end_element, k.end_connector,
                             (k.factor, k.offset) if k.transformed else None) for k in system.connections]
        self.default_stop_time = system.stop_time
        steps = [t.default_step for t in self.components.values() if t.default_step]
        self.default_step = min(steps) if steps else None
        self._variables = {}
        self.outputs, self.where = [], {}  # where: sweep name -> (component, variable)
        for name, t in self.components.items():
            for var, v in t.variables().items():
                for alias in ([var] if name == self.plant else []) + [f"{name}.{var}"]:
                    self._variables[alias] = replace(v, name=alias)
                    self.where[alias] = (name, var)
            self.outputs += [o if name == self.plant else f"{name}.{o}" for o in t.outputs]
        self.flag_names = list(self.components[self.plant].flag_names)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_bytes"] = None  # shipped once per worker as the payload
        return state

    def variables(self) -> dict:
        return self._variables

    def canonical(self, name: str) -> str:
        """One name per variable: the plant's 'M' and 'wheel.M' are both 'wheel.M'."""
        component, var = self.where.get(name, (None, name))
        return f"{component}.{var}" if component else name

    def payload(self):
        return self._bytes

    def open(self, payload) -> "SystemInstance":
        return SystemInstance(self, payload)

    def refused(self, values: dict, start_time: float, points=()) -> tuple[str, str] | None:
        """The first of `values` ({sweep name: value}) its component refuses as it is set
        (FmuTarget.refused): (the sweep name, '<component>: <reason>'), or None. points: not
        read: the master initialises the components together, connected, so a refusal at
        initialisation is a failed point (each point's reason in the table)."""
        split: dict[str, dict] = {}
        for alias, value in values.items():
            component, var = self.where[alias]
            split.setdefault(component, {})[var] = (alias, value)
        for component, own in split.items():
            found = self.components[component].refused({var: v for var, (_, v) in own.items()}, start_time)
            if found is not None:
                return own[found[0]][0], f"{component}: {found[1]}"
        return None


class SystemInstance:
    """One instance per component, reused point after point (each reset, set, initialised)."""

    def __init__(self, target: SspTarget, payload):
        self.target = target
        self.units = {}
        try:
            for name, t in target.components.items():
                self.units[name] = t.open(payload[name] if payload is not None else None)
        except Exception:
            self.close()
            raise
        self.output_names = list(target.outputs)
        self._links = []
        for a, av, b, bv, linear in target.connections:
            kind = target.components[a].variables()[av].type  # both ends of one type: SystemDescription.check
            self._links.append((partial(self.units[a].get, target.components[a].variables()[av].vr, kind),
                                partial(self.units[b].put, target.components[b].variables()[bv].vr, kind), linear))
        self._slices, i = [], 0
        for name, unit in self.units.items():
            self._slices.append((unit, slice(i, i + len(unit.output_names))))
            i += len(unit.output_names)

    def start(self, values: dict, start_time: float) -> None:
        split = {name: dict(self.target.starts[name]) for name in self.units}
        for alias, value in values.items():
            component, var = self.target.where[alias]
            split[component][var] = value
        for name, unit in self.units.items():
            unit.enter_initialisation(split[name], start_time)
        moving = settle(self.target.levels, self._links)
        if moving:
            raise PointFailure("the initial values are not consistent: " + ", ".join(
                "{}.{} -> {}.{}".format(*self.target.connections[i][:4]) for i in moving) + " still change")
        for unit in self.units.values():
            unit.exit_initialisation()

    def step(self, t: float, h: float) -> float | None:
        ended = None
        for unit in self.units.values():
            when = unit.step(t, h)
            if when is not None and ended is None:
                ended = when
        if ended is None:
            exchange(self.target.levels, self._links)
        return ended

    def read(self, row) -> None:
        for unit, where in self._slices:
            unit.read(row[where])

    def flags(self) -> list[str]:
        """The plant's true Boolean flags, then the other components' as '<component>.<flag>'
        (e.g. the controller's 'controller.lost')."""
        out = list(self.units[self.target.plant].flags())
        for name, unit in self.units.items():
            if name != self.target.plant:
                out += [f"{name}.{f}" for f in unit.flags()]
        return out

    def close(self) -> None:
        for unit in self.units.values():
            unit.close()
