"""A system of FMUs: components, connections, their checks, and its OspSystemStructure.xml.

Every connection joins an output of one component to an input of another by variable name (SSP
1.0 section 5.3.6). SystemDescription.check is what every reader, writer and master applies. The
system's SSP 1.0 file (.ssp): gyrowheel.cosim.ssp (write_ssp, read_ssp); the same system is
written here as OspSystemStructure.xml for libcosim (Open Simulation Platform, MSMI schema 0.1).
"""
from __future__ import annotations

import math
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree as ET

from fmpy import read_model_description

from gyrowheel.errors import GyrowheelError
from gyrowheel.cosim.units import kind_of

SSD_NS = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC_NS = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV_NS = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
OSP_NS = "http://opensimulationplatform.com/MSMI/OSPSystemStructure"
FMU_TYPE = "application/x-fmu-sharedlibrary"
OMS_NS = "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"
OMS_ANNOTATION = "org.openmodelica"


class SystemFileError(GyrowheelError, ValueError):
    """A system file that cannot be read or does not fit its FMUs; the message says where."""


@dataclass
class Component:
    """One FMU of a system: name (unique in the system: the prefix of its result columns,
    '<name>.<variable>'), fmu (its file), start_values ({variable: value} set before
    initialisation: SSP parameter bindings)."""

    name: str
    fmu: Path  # on disk (while writing) or inside the unpacked .ssp (after reading)
    start_values: dict[str, object] = field(default_factory=dict)  # parameter / input values by name


@dataclass
class Connection:
    """An output of one component feeding an input of another, by names (SSP 1.0 section
    5.3.6): start_element.start_connector -> end_element.end_connector. A Real connection may
    carry a linear transformation (ssc:LinearTransformation, SSP 1.0 section 5.3.6 and
    SystemStructureCommon.xsd): the input receives factor * output + offset. Both ends have
    one unit unless suppress_unit_conversion (unit conversion is not supported)."""

    start_element: str
    start_connector: str  # an output
    end_element: str
    end_connector: str  # an input
    factor: float = 1.0
    offset: float = 0.0
    suppress_unit_conversion: bool = False  # the SSP attribute: no conversion between the ends' units

    @property
    def transformed(self) -> bool:
        return self.factor != 1.0 or self.offset != 0.0


@dataclass
class SystemDescription:
    """A system of FMUs, as an .ssp holds it (write_ssp writes one, read_ssp reads one back)
    and gyrowheel.system_run runs it.

    name         the system's name (the .ssd's System name)
    components   its FMUs, a list of Component (name, fmu path, start values)
    connections  output -> input links, a list of Connection (SSP 1.0 section 5.3.6)
    start_time   s, DefaultExperiment startTime
    stop_time    s, DefaultExperiment stopTime (> start_time): where system_run stops by default
    """

    name: str
    components: list[Component]
    connections: list[Connection]
    start_time: float = 0.0
    stop_time: float = 60.0

    def component(self, name: str) -> Component:
        for c in self.components:
            if c.name == name:
                return c
        raise SystemFileError(f"no component {name!r}; components: {', '.join(c.name for c in self.components)}")

    def check(self, connector_units: dict[tuple[str, str], str] | None = None) -> list[list[int]]:
        """The system is runnable by gyrowheel's Co-Simulation master: at least one component, unique
        component names, every component an FMI 2.0 or FMI 3.0 FMU with Co-Simulation, every
        connection an existing output to an existing input of the same kind of value (SSP 1.0
        section 5.3.6; an FMI 2.0 Real joins an FMI 3.0 Float64, cosim/units.py kind), each input
        with one source, a linear transformation only on a Real connection (it is defined for
        continuous values), both ends of a connection in one unit unless it suppresses unit
        conversion (check_units), no algebraic loop. The reader (read_ssp), the writers
        (write_ssp, write_osp) and the master (gyrowheel.cosim.master.run) all apply it, so a file
        gyrowheel writes is one it reads.

        connector_units: {(component, connector): unit} declared by an .ssd's connectors (they
        take precedence over the FMU variables' units); None: the FMUs' units only.
        Raises SystemFileError naming the component, connection or variable. Returns
        gyrowheel.cosim.exchange.exchange_levels(self)."""
        if not self.components:
            raise SystemFileError(f"system {self.name!r} has no components")
        names = [c.name for c in self.components]
        for c in self.components:
            if not c.name:
                raise SystemFileError(f"system {self.name!r}: a component has no name")
            if names.count(c.name) > 1:
                raise SystemFileError(f"system {self.name!r}: two components are named {c.name!r}")
        variables = {c.name: fmu_variables(c.fmu, c.name) for c in self.components}
        seen = set()
        for i, k in enumerate(self.connections, 1):
            ends = ((k.start_element, k.start_connector, "output"), (k.end_element, k.end_connector, "input"))
            for elem, conn, want in ends:
                if not elem or not conn:
                    raise SystemFileError(f"connection {i}: startElement, startConnector, endElement and "
                                          f"endConnector are required (connections to the system's own "
                                          f"connectors are not supported), got {describe(k)}")
                if elem not in variables:
                    raise SystemFileError(f"connection {describe(k)}: no component {elem!r}; components: "
                                          f"{', '.join(names)}")
                v = variables[elem].get(conn)
                got = v.causality if v is not None else None
                if got != want:
                    raise SystemFileError(f"connection {elem}.{conn}: must be an {want} of {elem}, "
                                          f"is {got or 'not a variable'}")
            src = variables[k.start_element][k.start_connector]
            dst = variables[k.end_element][k.end_connector]
            if src.dimensions:  # FMI 3.0 array output: its elements are scalar outputs of their own
                raise SystemFileError(f"connection {describe(k)}: {k.start_element}.{k.start_connector} is an "
                                      f"array variable (connections join scalar variables: connect the "
                                      f"scalar outputs it is made of)")
            if kind_of(src.type) != kind_of(dst.type):
                raise SystemFileError(f"connection {describe(k)}: joins a {src.type} to a {dst.type} "
                                      f"(a connection joins variables of one type)")
            if (k.end_element, k.end_connector) in seen:
                raise SystemFileError(f"input {k.end_element}.{k.end_connector} has two sources")
            seen.add((k.end_element, k.end_connector))
            if k.transformed and kind_of(src.type) != "Real":
                raise SystemFileError(f"connection {describe(k)}: a linear transformation on a {src.type} "
                                      f"connection (ssc:LinearTransformation is for Real values)")
            for what in ("factor", "offset"):
                if not math.isfinite(getattr(k, what)):
                    raise SystemFileError(f"connection {describe(k)}: {what} {getattr(k, what)!r} is not "
                                          f"a finite number")
            check_units(k, variables, connector_units or {})
        from gyrowheel.cosim.exchange import exchange_levels  # it reads the FMUs this module checks
        return exchange_levels(self)


def describe(k: "Connection") -> str:
    """'A.y -> B.u': a connection as messages name it."""
    return f"{k.start_element}.{k.start_connector} -> {k.end_element}.{k.end_connector}"


def fmu_variables(fmu: str | Path, component: str = "") -> dict:
    """{name: fmpy ModelVariable} of an FMI 2.0 or FMI 3.0 Co-Simulation FMU; SystemFileError if
    it is not one."""
    where = f"component {component!r}: " if component else ""
    try:
        md = read_model_description(str(fmu), validate=False)
    except Exception as exc:  # fmpy raises plain Exceptions (BadZipFile, KeyError, XML errors)
        raise SystemFileError(f"{where}{Path(fmu).name} is not a readable FMU "
                              f"({type(exc).__name__}: {exc})") from None
    if md.fmiVersion != "2.0" and not md.fmiVersion.startswith("3."):
        raise SystemFileError(f"{where}{Path(fmu).name} is an FMI {md.fmiVersion} FMU (FMI 2.0 or 3.0 needed)")
    if md.coSimulation is None:
        raise SystemFileError(f"{where}{Path(fmu).name} does not support Co-Simulation")
    return {v.name: v for v in md.modelVariables}


def connect_by_name(a: str, outputs: list[str], b: str) -> list[Connection]:
    """Connections a.<n> -> b.<n> for every name n."""
    return [Connection(a, n, b, n) for n in outputs]


def check_units(k: Connection, variables: dict, connector_units: dict) -> None:
    """A connection between different units would need the unit conversion SSP 1.0 performs
    unless suppressUnitConversion="true" (SystemStructureDescription.xsd, Connection); no master
    of gyrowheel's converts, so it is refused (SystemFileError naming the connection and both
    units). Each end's unit is its connector's (connector_units, {(component, connector): unit}),
    else its FMU variable's (variables: {component: fmu_variables(...)})."""
    if k.suppress_unit_conversion:
        return
    ends = []
    for elem, name in ((k.start_element, k.start_connector), (k.end_element, k.end_connector)):
        unit = connector_units.get((elem, name))
        if unit is None:
            v = variables[elem][name]
            unit = v.unit or (v.declaredType.unit if v.declaredType is not None else None)
        ends.append(unit)
    if ends[0] and ends[1] and ends[0] != ends[1]:
        raise SystemFileError(f"connection {describe(k)}: from {ends[0]!r} to {ends[1]!r}: unit conversion is not "
                              f"supported (state the factor with ssc:LinearTransformation and "
                              f"suppressUnitConversion=\"true\")")


# -- OSP (libcosim) ----------------------------------------------------------------------------
def write_osp(system: SystemDescription, directory: str | Path, step: float) -> Path:
    """OspSystemStructure.xml (with the FMUs beside it) in `directory`, fixed step `step` [s]."""
    system.check()
    for k in system.connections:
        if k.transformed:
            raise SystemFileError(f"connection {describe(k)}: a linear transformation cannot be written to "
                                  f"OspSystemStructure.xml (its VariableConnection carries none): use the .ssp")
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    ET.register_namespace("", OSP_NS)
    root = ET.Element(f"{{{OSP_NS}}}OspSystemStructure", {"version": "0.1"})
    ET.SubElement(root, f"{{{OSP_NS}}}StartTime").text = repr(float(system.start_time))
    ET.SubElement(root, f"{{{OSP_NS}}}BaseStepSize").text = repr(float(step))
    ET.SubElement(root, f"{{{OSP_NS}}}Algorithm").text = "fixedStep"
    sims = ET.SubElement(root, f"{{{OSP_NS}}}Simulators")
    for c in system.components:
        shutil.copy2(c.fmu, directory / f"{c.name}.fmu")
        sim = ET.SubElement(sims, f"{{{OSP_NS}}}Simulator", {"name": c.name, "source": f"{c.name}.fmu",
                                                           "stepSize": repr(float(step))})
        if c.start_values:  # OSP's value elements: Real, Integer (Enumerations too), Boolean, String
            init = ET.SubElement(sim, f"{{{OSP_NS}}}InitialValues")
            types = {n: kind_of(v.type) for n, v in fmu_variables(c.fmu, c.name).items()}
            for name, value in c.start_values.items():
                value_kind = types.get(name, "Real")
                value_kind, text = (("Real", repr(float(value))) if value_kind == "Real" else
                                    ("Boolean", "true" if value in (True, "true", "1", 1) else "false")
                                    if value_kind == "Boolean" else
                                    ("String", str(value)) if value_kind == "String" else ("Integer", str(int(value))))
                iv = ET.SubElement(init, f"{{{OSP_NS}}}InitialValue", {"variable": name})
                ET.SubElement(iv, f"{{{OSP_NS}}}{value_kind}", {"value": text})
    conns = ET.SubElement(root, f"{{{OSP_NS}}}Connections")
    for k in system.connections:
        vc = ET.SubElement(conns, f"{{{OSP_NS}}}VariableConnection")
        ET.SubElement(vc, f"{{{OSP_NS}}}Variable", {"simulator": k.start_element, "name": k.start_connector})
        ET.SubElement(vc, f"{{{OSP_NS}}}Variable", {"simulator": k.end_element, "name": k.end_connector})
    ET.indent(root, "  ")
    path = directory / "OspSystemStructure.xml"
    path.write_text('<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n")
    return path
