"""A system of FMUs: components, connections, and its files (SSP 1.0 .ssp, OspSystemStructure.xml).

The .ssp is written with pyssp-standard (SSP 1.0, namespace http://ssp-standard.org/SSP1/...):
SystemStructure.ssd plus resources/<component>.fmu. Every connection joins an output of one
component to an input of another by variable name (SSP 1.0 section 5.3.6). The same system
is written as OspSystemStructure.xml for libcosim (Open Simulation Platform, MSMI schema 0.1).
read_ssp() reads an .ssp back (lxml) for gyrowheel's own master (cosim/master.py).
"""
from __future__ import annotations

import shutil
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree as ET

from fmpy import read_model_description

SSD_NS = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC_NS = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV_NS = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
OSP_NS = "http://opensimulationplatform.com/MSMI/OSPSystemStructure"
FMU_TYPE = "application/x-fmu-sharedlibrary"


class SystemFileError(ValueError):
    """A system file that cannot be read or does not fit its FMUs; the message says where."""


@dataclass
class Component:
    name: str
    fmu: Path  # on disk (while writing) or inside the unpacked .ssp (after reading)
    start_values: dict[str, float] = field(default_factory=dict)  # parameters / start values by name


@dataclass
class Connection:
    start_element: str
    start_connector: str  # an output
    end_element: str
    end_connector: str  # an input


@dataclass
class SystemDescription:
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

    def check(self) -> None:
        """Every connection joins an existing output to an existing input; each input has one source."""
        causality = {}
        for c in self.components:
            md = read_model_description(str(c.fmu), validate=False)
            causality[c.name] = {v.name: v.causality for v in md.modelVariables}
        seen = set()
        for k in self.connections:
            for elem, conn, want in ((k.start_element, k.start_connector, "output"),
                                     (k.end_element, k.end_connector, "input")):
                if elem not in causality:
                    raise SystemFileError(f"connection {k}: no component {elem!r}")
                got = causality[elem].get(conn)
                if got != want:
                    raise SystemFileError(f"connection {elem}.{conn}: must be an {want} of {elem}, "
                                          f"is {got or 'not a variable'}")
            if (k.end_element, k.end_connector) in seen:
                raise SystemFileError(f"input {k.end_element}.{k.end_connector} has two sources")
            seen.add((k.end_element, k.end_connector))


def connect_by_name(a: str, outputs: list[str], b: str) -> list[Connection]:
    """Connections a.<n> -> b.<n> for every name n."""
    return [Connection(a, n, b, n) for n in outputs]


# -- SSP ---------------------------------------------------------------------------------------
def write_ssp(system: SystemDescription, path: str | Path) -> Path:
    """Write <path>.ssp: SystemStructure.ssd (SSP 1.0) and resources/<component>.fmu.

    Raises SystemFileError if a connection does not fit or a start value is not a parameter or
    an input (check_bindings)."""
    from pyssp_standard.common_content_ssc import TypeReal
    from pyssp_standard.ssd import SSD, Component as SspComponent, Connection as SspConnection
    from pyssp_standard.ssd import Connector, DefaultExperiment, System

    system.check()
    for c in system.components:
        check_bindings(c)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="gyrowheel-ssp-") as tmp:
        root = Path(tmp)
        (root / "resources").mkdir()
        ssd_path = root / "SystemStructure.ssd"
        with SSD(ssd_path, mode="w") as ssd:
            ssd.name, ssd.version = system.name, "1.0"
            ssd.system = System(name=system.name)
            for c in system.components:
                shutil.copy2(c.fmu, root / "resources" / f"{c.name}.fmu")
                md = read_model_description(str(c.fmu), validate=False)
                units = {v.name: v.unit for v in md.modelVariables}
                comp = SspComponent()
                comp.name, comp.component_type, comp.source = c.name, FMU_TYPE, f"resources/{c.name}.fmu"
                used = [(k.start_connector, "output") for k in system.connections if k.start_element == c.name]
                used += [(k.end_connector, "input") for k in system.connections if k.end_element == c.name]
                comp.connectors = [Connector(name=n, kind=kind, type_=TypeReal(units.get(n))) for n, kind in used]
                ssd.system.elements.append(comp)
            ssd.system.connections = [SspConnection(start_element=k.start_element, start_connector=k.start_connector,
                                                    end_element=k.end_element, end_connector=k.end_connector)
                                      for k in system.connections]
            ssd.default_experiment = DefaultExperiment()
            ssd.default_experiment.start_time, ssd.default_experiment.stop_time = system.start_time, system.stop_time
        _add_parameter_bindings(ssd_path, system)
        tmp_zip = path.with_suffix(path.suffix + ".part")
        with zipfile.ZipFile(tmp_zip, "w", zipfile.ZIP_DEFLATED) as zf:
            zf.write(ssd_path, "SystemStructure.ssd")
            for c in system.components:
                zf.write(root / "resources" / f"{c.name}.fmu", f"resources/{c.name}.fmu")
        tmp_zip.replace(path)
    return path


BINDABLE = ("parameter", "input")
# one name for every component's set: ecos applies the sets of the one name given at init,
# libcosim a component's first set (and any by its name), gyrowheel's master all of them
PARAMETER_SET = "start"


def check_bindings(component: Component, where: str = "") -> None:
    """A parameter binding must set a parameter or an input of its FMU (SystemFileError otherwise).

    SSP 1.0 parameter sets carry parameter values; libcosim's SSP loader applies them only to
    variables of causality parameter or input and drops any other with a warning ("Non-input
    causality for variable wheel:beta"), so a binding of a state's start value (an output with
    initial="exact", e.g. the wheel's beta) would make masters disagree. Set such start values in
    the scene's [initial] (the FMU's default start) or through a master's own start values.
    """
    if not component.start_values:
        return
    md = read_model_description(str(component.fmu), validate=False)
    causality = {v.name: v.causality for v in md.modelVariables}
    for name in component.start_values:
        got = causality.get(name)
        if got not in BINDABLE:
            raise SystemFileError(
                f"{where}{component.name}.{name}: an SSP parameter binding sets a parameter or an input, "
                f"this is {'an ' + got if got else 'not a variable'} (SSP masters such as libcosim ignore it): "
                f"give it as the FMU's start value (a scene's [initial]) or as a master's start value")


def _add_parameter_bindings(ssd_path: Path, system: SystemDescription) -> None:
    """Inline ssd:ParameterBindings (SSP 1.0 section 5.3.5) for components with start values.

    pyssp-standard 0.9 writes bindings only as external .ssv references; the values belong in
    the .ssd itself here, so they are added to the written tree in schema order. Only parameters
    and inputs are bound (check_bindings); every component's set is named PARAMETER_SET.
    """
    if not any(c.start_values for c in system.components):
        return
    ET.register_namespace("ssd", SSD_NS)
    ET.register_namespace("ssc", SSC_NS)
    ET.register_namespace("ssv", SSV_NS)
    tree = ET.parse(ssd_path)
    for elem in tree.getroot().iter(f"{{{SSD_NS}}}Component"):
        comp = system.component(elem.get("name"))
        if not comp.start_values:
            continue
        bindings = ET.Element(f"{{{SSD_NS}}}ParameterBindings")
        values = ET.SubElement(ET.SubElement(bindings, f"{{{SSD_NS}}}ParameterBinding"), f"{{{SSD_NS}}}ParameterValues")
        pset = ET.SubElement(values, f"{{{SSV_NS}}}ParameterSet", {"version": "1.0", "name": PARAMETER_SET})
        params = ET.SubElement(pset, f"{{{SSV_NS}}}Parameters")
        for name, value in comp.start_values.items():
            ET.SubElement(ET.SubElement(params, f"{{{SSV_NS}}}Parameter", {"name": name}), f"{{{SSV_NS}}}Real",
                          {"value": repr(float(value))})
        children = list(elem)
        position = next((i for i, ch in enumerate(children) if ch.tag != f"{{{SSD_NS}}}Connectors"), len(children))
        elem.insert(position, bindings)
    tree.write(ssd_path, xml_declaration=True, encoding="UTF-8")


def read_ssp(path: str | Path, unpack_dir: str | Path) -> SystemDescription:
    """Read an .ssp (SSP 1.0): components with their FMUs unpacked under unpack_dir, connections."""
    path = Path(path)
    if not path.is_file():
        raise SystemFileError(f"{path}: no such SSP file")
    try:
        with zipfile.ZipFile(path) as zf:
            zf.extractall(unpack_dir)
    except zipfile.BadZipFile:
        raise SystemFileError(f"{path}: not an SSP archive (not a zip file)") from None
    ssd = Path(unpack_dir) / "SystemStructure.ssd"
    if not ssd.is_file():
        raise SystemFileError(f"{path}: has no SystemStructure.ssd")
    try:
        root = ET.parse(ssd).getroot()
    except ET.ParseError as exc:
        raise SystemFileError(f"{path}: SystemStructure.ssd is not well-formed XML: {exc}") from None
    ns = {"ssd": SSD_NS, "ssc": SSC_NS, "ssv": SSV_NS}
    sysel = root.find("ssd:System", ns)
    if sysel is None:
        raise SystemFileError(f"{path}: SystemStructure.ssd has no ssd:System")
    components = []
    for el in sysel.findall("ssd:Elements/ssd:Component", ns):
        source = el.get("source", "")
        if el.get("type", FMU_TYPE) != FMU_TYPE:
            raise SystemFileError(f"{path}: component {el.get('name')!r} is not an FMU ({el.get('type')})")
        fmu = Path(unpack_dir) / source
        if not fmu.is_file():
            raise SystemFileError(f"{path}: component {el.get('name')!r}: {source} is not in the archive")
        starts = {p.get("name"): float(p.find("ssv:Real", ns).get("value"))
                  for p in el.findall("ssd:ParameterBindings/ssd:ParameterBinding/ssd:ParameterValues/"
                                      "ssv:ParameterSet/ssv:Parameters/ssv:Parameter", ns)
                  if p.find("ssv:Real", ns) is not None}
        components.append(Component(el.get("name"), fmu, starts))
        check_bindings(components[-1], f"{path}: ")
    connections = [Connection(k.get("startElement"), k.get("startConnector"), k.get("endElement"),
                              k.get("endConnector")) for k in sysel.findall("ssd:Connections/ssd:Connection", ns)]
    exp = root.find("ssd:DefaultExperiment", ns)
    system = SystemDescription(root.get("name") or sysel.get("name"), components, connections)
    if exp is not None:
        system.start_time = float(exp.get("startTime", 0.0))
        system.stop_time = float(exp.get("stopTime", system.stop_time))
    system.check()
    return system


# -- OSP (libcosim) ----------------------------------------------------------------------------
def write_osp(system: SystemDescription, directory: str | Path, step: float) -> Path:
    """OspSystemStructure.xml (with the FMUs beside it) in `directory`, fixed step `step` [s]."""
    system.check()
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
        if c.start_values:
            init = ET.SubElement(sim, f"{{{OSP_NS}}}InitialValues")
            for name, value in c.start_values.items():
                iv = ET.SubElement(init, f"{{{OSP_NS}}}InitialValue", {"variable": name})
                ET.SubElement(iv, f"{{{OSP_NS}}}Real", {"value": repr(float(value))})
    conns = ET.SubElement(root, f"{{{OSP_NS}}}Connections")
    for k in system.connections:
        vc = ET.SubElement(conns, f"{{{OSP_NS}}}VariableConnection")
        ET.SubElement(vc, f"{{{OSP_NS}}}Variable", {"simulator": k.start_element, "name": k.start_connector})
        ET.SubElement(vc, f"{{{OSP_NS}}}Variable", {"simulator": k.end_element, "name": k.end_connector})
    ET.indent(root, "  ")
    path = directory / "OspSystemStructure.xml"
    path.write_text('<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n")
    return path
