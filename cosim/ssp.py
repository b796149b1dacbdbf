"""SSP 1.0 files of a system: write_ssp writes an .ssp, read_ssp reads one back.

The .ssp is written with pyssp-standard (SSP 1.0, namespace http://ssp-standard.org/SSP1/...):
SystemStructure.ssd plus resources/<component>.fmu, the components' parameter bindings (a
parameter set .ssv), the units' accuracy (rel_tol bound to the scene's) and OMSimulator's
annotation. read_ssp() reads an .ssp back for gyrowheel's own master (cosim/master.py) and the
sweep, refusing what it does not understand and what is not valid against the vendored SSP 1.0
schemas (SystemFileError, one line naming the element). The system itself and its checks:
gyrowheel.cosim.system.
"""
from __future__ import annotations

import math
import shutil
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from fmpy import read_model_description

from gyrowheel.cosim.system import (FMU_TYPE, OMS_ANNOTATION, OMS_NS, SSC_NS, SSD_NS, SSV_NS, Component, Connection,
                                    SystemDescription, SystemFileError, describe, fmu_variables)
from gyrowheel.cosim.units import kind_of
from gyrowheel.extras import require
from gyrowheel.fmi_types import out_of_range, whole_number
from gyrowheel.scratch import temporary_directory

# -- SSP ---------------------------------------------------------------------------------------
def write_ssp(system: SystemDescription, path: str | Path, step: float = 0.01) -> Path:
    """Write <path>.ssp: SystemStructure.ssd (SSP 1.0) and resources/<component>.fmu.

    Besides the components, connections (with their linear transformations), start values and
    DefaultExperiment, the file carries what other masters need to run it as gyrowheel's does:
    - each component's accuracy (accuracy_bindings): SSP 1.0 has no tolerance field and a master
      may pass its own to fmi2SetupExperiment (OMSimulator: 1e-4); the FMU's rel_tol bound as a
      parameter takes precedence over it (docs/interface.md, "Tolerances");
    - OMSimulator's system annotation (type "org.openmodelica": oms:FixedStepMaster with the
      communication step `step` [s] and the smallest tolerance the components declare), without
      which OMSimulator 3.0's command line cannot tell the system's type; other masters skip it
      (ssc:TAnnotations are open to any content).
    Raises SystemFileError, before anything is written, if the system fails the check read_ssp
    applies (SystemDescription.check: types, units, loops) or a start value is not a parameter or
    an input (check_bindings), ValueError for a step that is not a positive number;
    MissingExtraError without gyrowheel[system] (pyssp-standard)."""
    if not (isinstance(step, (int, float)) and step > 0 and math.isfinite(step)):
        raise ValueError(f"step must be a positive number of seconds, got {step!r}")
    require("system", "gyrowheel.cosim.ssp.write_ssp()")  # pyssp-standard: the optional part [system]
    from pyssp_standard.common_content_ssc import TypeReal
    from pyssp_standard.ssd import SSD, Component as SspComponent, Connection as SspConnection
    from pyssp_standard.ssd import Connector, DefaultExperiment, System

    system.check()
    system = SystemDescription(system.name, [Component(c.name, c.fmu, {**accuracy_bindings(c), **c.start_values})
                                             for c in system.components],
                               system.connections, system.start_time, system.stop_time)
    for c in system.components:
        check_bindings(c)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with temporary_directory("ssp") as tmp:
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
        _add_connections_and_annotation(ssd_path, system, step)
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
PARAMETER_SET_TYPE = "application/x-ssp-parameter-set"
SSV_TYPES = ("Real", "Integer", "Boolean", "String", "Enumeration")  # SSP 1.0 ssv:TParameter, but Binary


def check_bindings(component: Component, where: str = "") -> dict:
    """The component's parameter bindings as values of their FMU variables' types.

    A binding must set a parameter or an input of its FMU (SystemFileError otherwise). SSP 1.0
    parameter sets carry parameter values; libcosim's SSP loader applies them only to variables
    of causality parameter or input and drops any other with a warning ("Non-input causality
    for variable wheel:beta"), so a binding of a state's start value (an output with
    initial="exact", e.g. the wheel's beta) would make masters disagree. Set such start values
    in the scene's [initial] (the FMU's default start) or through a master's own start values.
    Enumeration variables (the wheel's solver) are refused too: libcosim and ecos leave them out
    and would ignore the binding. Values: a Real takes a number, an Integer a whole number, a
    Boolean true/false (or 1/0), a String text; anything else raises SystemFileError naming
    <component>.<variable>. Returns {name: float | int | bool | str}.
    """
    if not component.start_values:
        return {}
    variables = fmu_variables(component.fmu, component.name)
    out = {}
    for name, value in component.start_values.items():
        v = variables.get(name)
        got = v.causality if v is not None else None
        if got not in BINDABLE:
            raise SystemFileError(
                f"{where}{component.name}.{name}: an SSP parameter binding sets a parameter or an input, "
                f"this is {'an ' + got if got else 'not a variable'} (SSP masters such as libcosim ignore it): "
                f"give it as the FMU's start value (a scene's [initial]) or as a master's start value")
        if v.type == "Enumeration":
            raise SystemFileError(
                f"{where}{component.name}.{name}: an Enumeration; libcosim and ecos leave FMI 2.0 Enumeration "
                f"variables out (\"Enumeration variable type not supported\") and ignore the binding, so masters "
                f"would disagree: set it in the FMU (a scene's [experiment]) or as a master's start value")
        out[name] = coerce_value(v, value, f"{where}{component.name}.{name}")
    return out


def coerce_value(v, value, where: str):
    """value (a number, or the text of an SSV value attribute) as the type of FMU variable v.
    Raises SystemFileError naming `where`: a value not of v's type (`'1.5' is not a valid
    Integer`), a whole number outside its type's range (`3000000000.0 is out of range [1,
    2147483647] (Integer)`: the variable's declared range, gyrowheel.fmi_types)."""
    text = value.strip() if isinstance(value, str) else value
    try:
        if kind_of(v.type) == "Real":
            if isinstance(text, bool):
                raise ValueError
            return float(text)
        if v.type == "Boolean":
            if isinstance(text, str):
                if text.lower() not in ("true", "false", "1", "0"):
                    raise ValueError
                return text.lower() in ("true", "1")
            if text not in (0, 1):
                raise ValueError
            return bool(text)
        if v.type == "String":
            return str(value)
        number = whole_number(text)
    except (TypeError, ValueError):
        raise SystemFileError(f"{where}: {value!r} is not a valid {v.type}") from None
    outside = out_of_range(v, number)  # ctypes would wrap it
    if outside:
        raise SystemFileError(f"{where}: {value!r} is {outside}")
    return number


def _ssv_element(v, value) -> tuple[str, str]:
    """(SSV element name, value attribute) of a binding of FMU variable v (SSP 1.0 ssv:TParameter;
    never ssv:Enumeration, which libcosim's SSP parser (0.0.6) aborts the process on)."""
    if kind_of(v.type) == "Real":
        return "Real", repr(float(value))
    if v.type == "Boolean":
        return "Boolean", "true" if value else "false"
    if v.type == "String":
        return "String", str(value)
    return "Integer", str(int(value))


def _add_parameter_bindings(ssd_path: Path, system: SystemDescription) -> None:
    """Inline ssd:ParameterBindings (SSP 1.0 section 5.3.5) for components with start values.

    pyssp-standard 0.9 writes bindings only as external .ssv references; the values belong in
    the .ssd itself here, so they are added to the written tree in schema order. Only parameters
    and inputs are bound (check_bindings), each as its variable's SSV type (_ssv_element); every
    component's set is named PARAMETER_SET.
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
        values_of = check_bindings(comp)
        variables = fmu_variables(comp.fmu, comp.name)
        bindings = ET.Element(f"{{{SSD_NS}}}ParameterBindings")
        values = ET.SubElement(ET.SubElement(bindings, f"{{{SSD_NS}}}ParameterBinding"), f"{{{SSD_NS}}}ParameterValues")
        pset = ET.SubElement(values, f"{{{SSV_NS}}}ParameterSet", {"version": "1.0", "name": PARAMETER_SET})
        params = ET.SubElement(pset, f"{{{SSV_NS}}}Parameters")
        for name, value in values_of.items():
            kind, text = _ssv_element(variables[name], value)
            ET.SubElement(ET.SubElement(params, f"{{{SSV_NS}}}Parameter", {"name": name}), f"{{{SSV_NS}}}{kind}",
                          {"value": text})
        children = list(elem)
        position = next((i for i, ch in enumerate(children) if ch.tag != f"{{{SSD_NS}}}Connectors"), len(children))
        elem.insert(position, bindings)
    tree.write(ssd_path, xml_declaration=True, encoding="UTF-8")


def accuracy_bindings(component: Component) -> dict[str, float]:
    """{"rel_tol": its start value} for an FMU with a Real parameter rel_tol (gyrowheel's FMUs:
    the scene's accuracy, docs/interface.md), else {}. Bound in the .ssp, it is set explicitly
    and so takes precedence over any tolerance a master passes to fmi2SetupExperiment; abs_tol
    then stays the scene's (docs/interface.md, "Tolerances", rule 1)."""
    v = fmu_variables(component.fmu, component.name).get("rel_tol")
    if v is None or kind_of(v.type) != "Real" or v.causality != "parameter" or v.start is None:
        return {}
    return {"rel_tol": float(v.start)}


def _add_connections_and_annotation(ssd_path: Path, system: SystemDescription, step: float) -> None:
    """ssc:LinearTransformation and suppressUnitConversion on the connections that carry them
    (pyssp-standard 0.9 writes neither), and OMSimulator's annotation of the system (write_ssp)."""
    ET.register_namespace("ssd", SSD_NS)
    ET.register_namespace("ssc", SSC_NS)
    ET.register_namespace("ssv", SSV_NS)
    ET.register_namespace("oms", OMS_NS)
    tree = ET.parse(ssd_path)
    sysel = tree.getroot().find("ssd:System", _NS)
    written = sysel.findall("ssd:Connections/ssd:Connection", _NS)
    for el, k in zip(written, system.connections):
        if k.transformed:
            el.insert(0, ET.Element(f"{{{SSC_NS}}}LinearTransformation", {"factor": repr(float(k.factor)),
                                                                           "offset": repr(float(k.offset))}))
        if k.suppress_unit_conversion:
            el.set("suppressUnitConversion", "true")
    tolerances = [md.defaultExperiment.tolerance for md in
                  (read_model_description(str(c.fmu), validate=False) for c in system.components)
                  if md.defaultExperiment is not None and md.defaultExperiment.tolerance is not None]
    tolerance = min(float(t) for t in tolerances) if tolerances else 1e-4
    annotations = ET.SubElement(sysel, f"{{{SSD_NS}}}Annotations")
    oms = ET.SubElement(ET.SubElement(annotations, f"{{{SSC_NS}}}Annotation", {"type": OMS_ANNOTATION}),
                        f"{{{OMS_NS}}}Annotations")
    ET.SubElement(ET.SubElement(oms, f"{{{OMS_NS}}}SimulationInformation"), f"{{{OMS_NS}}}FixedStepMaster",
                  {"description": "oms-ma", "stepSize": repr(float(step)), "relativeTolerance": repr(tolerance)})
    tree.write(ssd_path, xml_declaration=True, encoding="UTF-8")


_NS = {"ssd": SSD_NS, "ssc": SSC_NS, "ssv": SSV_NS}


def _number(text: str | None, default: float, what: str) -> float:
    if text is None:
        return default
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if value != value or value in (float("inf"), float("-inf")):
        raise SystemFileError(f"{what} = {text!r} is not a finite number")
    return value


def _parameter_values(binding, root: Path, where: str) -> dict[str, tuple[str, str, str | None]]:
    """{name (with the binding's prefix): (SSV type, value text, unit)} of one ssd:ParameterBinding,
    inline (ssd:ParameterValues) or from its source .ssv in the archive (SSP 1.0 section 5.3.5)."""
    _understood(binding, ("ssd:ParameterValues", "ssd:ParameterMapping", "ssd:Annotations"), where)
    kind = binding.get("type", PARAMETER_SET_TYPE)
    if kind != PARAMETER_SET_TYPE:
        raise SystemFileError(f"{where}: parameter binding of type {kind!r} (only {PARAMETER_SET_TYPE})")
    if binding.find("ssd:ParameterMapping", _NS) is not None:
        raise SystemFileError(f"{where}: ssd:ParameterMapping is not supported by gyrowheel's master "
                              "(bind the FMU's own variable names)")
    source = binding.get("source")
    if source:
        if binding.get("sourceBase", "SSD") != "SSD" or "://" in source:
            raise SystemFileError(f"{where}: parameter source {source!r}: only files in the .ssp beside "
                                  "SystemStructure.ssd are supported (sourceBase SSD)")
        ssv = _inside(root, source, where)
        try:
            pset = ET.parse(ssv).getroot()
        except ET.ParseError as exc:
            raise SystemFileError(f"{where}: {source} is not well-formed XML: {exc}") from None
    else:
        values = binding.find("ssd:ParameterValues", _NS)
        if values is None:
            return {}
        _understood(values, ("ssv:ParameterSet",), f"{where}: ssd:ParameterValues")
        pset = values.find("ssv:ParameterSet", _NS)
        if pset is None:
            return {}
    if pset.tag != f"{{{SSV_NS}}}ParameterSet":
        raise SystemFileError(f"{where}: {source or 'ParameterValues'} holds no ssv:ParameterSet")
    prefix = binding.get("prefix", "")
    out = {}
    for p in pset.findall("ssv:Parameters/ssv:Parameter", _NS):
        name = p.get("name")
        typed = [ch for ch in p if ch.tag.startswith(f"{{{SSV_NS}}}")]
        if not name or len(typed) != 1:
            raise SystemFileError(f"{where}: a parameter needs a name and one value element, got {name!r}")
        kind = typed[0].tag.split("}", 1)[1]
        if kind not in SSV_TYPES:
            raise SystemFileError(f"{where}: parameter {name!r}: ssv:{kind} values are not supported "
                                  f"({', '.join(SSV_TYPES)})")
        if typed[0].get("value") is None:
            raise SystemFileError(f"{where}: parameter {name!r} has no value")
        out[prefix + name] = (kind, typed[0].get("value"), typed[0].get("unit"))
    if source:
        _valid(ssv, SSV_SCHEMA, f"{where}: {source}")
    return out


def _inside(root: Path, source: str, where: str) -> Path:
    """The archive member `source` (relative to SystemStructure.ssd), refusing paths that leave it."""
    target = (root / source).resolve()
    if not target.is_relative_to(root.resolve()):
        raise SystemFileError(f"{where}: {source!r} points outside the .ssp")
    if not target.is_file():
        raise SystemFileError(f"{where}: {source} is not in the archive")
    return target


def _bound(binding_values: dict, component: str, variables: dict, where: str) -> dict:
    """Check each binding's SSV type and unit against the FMU variable; {name: value text}."""
    out = {}
    for name, (value_kind, text, unit) in binding_values.items():
        v = variables.get(name)
        if v is not None:
            # an Integer may bind an Enumeration (by value) or a Real
            fmu_kind = "Enumeration" if v.type == "Enumeration" else kind_of(v.type)
            if value_kind != fmu_kind and not (value_kind == "Integer" and fmu_kind in ("Enumeration", "Real")):
                raise SystemFileError(f"{where}{component}.{name}: bound as ssv:{value_kind}, the FMU's variable "
                                      f"is a {v.type}")
            fmu_unit = v.unit or (v.declaredType.unit if v.declaredType is not None else None)
            if unit and fmu_unit and unit != fmu_unit:
                raise SystemFileError(f"{where}{component}.{name}: value in {unit!r}, the FMU's unit is "
                                      f"{fmu_unit!r} (unit conversion is not supported)")
        out[name] = text
    return out


# The child elements the reader knows (SystemStructureDescription.xsd): those it reads, those it
# refuses by name, and those that carry no value (geometry, annotations, unit and enumeration
# definitions); anything else is refused rather than ignored.
ROOT_CHILDREN = ("ssd:System", "ssd:Enumerations", "ssd:Units", "ssd:DefaultExperiment", "ssd:Annotations")
SYSTEM_CHILDREN = ("ssd:Connectors", "ssd:ElementGeometry", "ssd:Elements", "ssd:Connections",
                   "ssd:SignalDictionaries", "ssd:SystemGeometry", "ssd:GraphicalElements",
                   "ssd:ParameterBindings", "ssd:Annotations")
ELEMENTS = ("ssd:Component", "ssd:SignalDictionaryReference", "ssd:System")
COMPONENT_CHILDREN = ("ssd:Connectors", "ssd:ElementGeometry", "ssd:ParameterBindings", "ssd:Annotations")
CONNECTOR_CHILDREN = ("ssc:Real", "ssc:Integer", "ssc:Boolean", "ssc:String", "ssc:Enumeration", "ssc:Binary",
                      "ssd:ConnectorGeometry", "ssd:Annotations")
SCHEMAS = Path(__file__).resolve().parent / "schemas" / "ssp1"  # the SSP 1.0.1 schemas (XSD 1.0), BSD licence
SSD_SCHEMA = "SystemStructureDescription.xsd"
SSV_SCHEMA = "SystemStructureParameterValues.xsd"


def _valid(document: Path, schema: str, where: str) -> None:
    """Validate an SSP 1.0 document against its vendored schema (lxml, which fmpy requires);
    SystemFileError with the schema's first message, one line, naming its line and element."""
    from lxml import etree
    validator = etree.XMLSchema(etree.parse(str(SCHEMAS / schema)))
    try:
        ok = validator.validate(etree.parse(str(document)))
    except etree.XMLSyntaxError as exc:
        raise SystemFileError(f"{where} is not well-formed XML: {exc}") from None
    if not ok:
        first = validator.error_log[0]
        message = " ".join(_qname(first.message).split())
        raise SystemFileError(f"{where}, line {first.line}: not valid SSP 1.0 ({schema}): {message}")


def read_ssp(path: str | Path, unpack_dir: str | Path) -> SystemDescription:
    """Read an .ssp (SSP 1.0): components with their FMUs unpacked under unpack_dir, connections,
    parameter bindings (inline or .ssv files in the archive, of the components and of the system
    with names '<component>.<variable>'; the system's take precedence, SSP 1.0 section 5.3.5)
    and the DefaultExperiment. Nothing is skipped: a child element the reader does not know
    (_understood), more than one transformation on a connection, an unsupported transformation
    or binding, and finally anything SystemStructure.ssd or an .ssv breaks of the vendored SSP
    1.0 schemas (cosim/schemas/ssp1, XSD 1.0) is refused; the system passes
    SystemDescription.check with the connectors' units. Raises SystemFileError naming the file
    and the element at fault, in one line."""
    path = Path(path)
    if not path.is_file():
        raise SystemFileError(f"{path}: no such SSP file")
    root_dir = Path(unpack_dir)
    try:
        with zipfile.ZipFile(path) as zf:
            zf.extractall(root_dir)
    except zipfile.BadZipFile:
        raise SystemFileError(f"{path}: not an SSP archive (not a zip file)") from None
    ssd = root_dir / "SystemStructure.ssd"
    if not ssd.is_file():
        raise SystemFileError(f"{path}: has no SystemStructure.ssd")
    try:
        root = ET.parse(ssd).getroot()
    except ET.ParseError as exc:
        raise SystemFileError(f"{path}: SystemStructure.ssd is not well-formed XML: {exc}") from None
    sysel = root.find("ssd:System", _NS)
    if sysel is None:
        raise SystemFileError(f"{path}: SystemStructure.ssd has no ssd:System")
    _understood(root, ROOT_CHILDREN, f"{path}: ssd:SystemStructureDescription")
    _understood(sysel, SYSTEM_CHILDREN, f"{path}: system {sysel.get('name')!r}")
    for group, child in (("Elements", ELEMENTS), ("Connections", ("ssd:Connection",)),
                         ("ParameterBindings", ("ssd:ParameterBinding",))):
        for el in sysel.findall(f"ssd:{group}", _NS):
            _understood(el, child, f"{path}: system {sysel.get('name')!r}, ssd:{group}")
    if sysel.find("ssd:Elements/ssd:System", _NS) is not None or sysel.find("ssd:Elements/ssd:SignalDictionaryReference", _NS) is not None:
        raise SystemFileError(f"{path}: nested systems and signal dictionaries are not supported "
                              "(components of FMUs only)")
    components, raw = [], {}
    for el in sysel.findall("ssd:Elements/ssd:Component", _NS):
        name, source = el.get("name"), el.get("source", "")
        if not name:
            raise SystemFileError(f"{path}: a component has no name")
        where = f"{path}: component {name!r}"
        if el.get("type", FMU_TYPE) != FMU_TYPE:
            raise SystemFileError(f"{where} is not an FMU ({el.get('type')})")
        _understood(el, COMPONENT_CHILDREN, where)
        for connectors in el.findall("ssd:Connectors", _NS):
            _understood(connectors, ("ssd:Connector",), f"{where}, ssd:Connectors")
            for conn in connectors:
                _understood(conn, CONNECTOR_CHILDREN, f"{where}, connector {conn.get('name')!r}")
        for bindings in el.findall("ssd:ParameterBindings", _NS):
            _understood(bindings, ("ssd:ParameterBinding",), f"{where}, ssd:ParameterBindings")
        fmu = _inside(root_dir, source, where)
        components.append(Component(name, fmu))
        raw[name] = {}
        for binding in el.findall("ssd:ParameterBindings/ssd:ParameterBinding", _NS):
            raw[name].update(_parameter_values(binding, root_dir, f"{where}, parameter binding"))
    for binding in sysel.findall("ssd:ParameterBindings/ssd:ParameterBinding", _NS):
        for name, value in _parameter_values(binding, root_dir, f"{path}: system parameter binding").items():
            comp, _, var = name.partition(".")
            if comp not in raw or not var:
                raise SystemFileError(f"{path}: system parameter binding {name!r}: expected "
                                      f"<component>.<variable> with a component of {', '.join(raw) or 'none'}")
            raw[comp][var] = value
    units = _connector_units(sysel)
    connections = [_connection(k, units, f"{path}: ") for k in sysel.findall("ssd:Connections/ssd:Connection", _NS)]
    exp = root.find("ssd:DefaultExperiment", _NS)
    system = SystemDescription(root.get("name") or sysel.get("name"), components, connections)
    if exp is not None:
        system.start_time = _number(exp.get("startTime"), 0.0, f"{path}: DefaultExperiment startTime")
        system.stop_time = _number(exp.get("stopTime"), system.stop_time, f"{path}: DefaultExperiment stopTime")
        if not system.stop_time > system.start_time:
            raise SystemFileError(f"{path}: DefaultExperiment stopTime {system.stop_time:g} is not after "
                                  f"startTime {system.start_time:g}")
    try:
        system.check(units)
    except SystemFileError as exc:
        raise SystemFileError(f"{path}: {exc}") from None
    for c in components:
        c.start_values = _bound(raw[c.name], c.name, fmu_variables(c.fmu, c.name), f"{path}: ")
        c.start_values = check_bindings(c, f"{path}: ")
    _valid(ssd, SSD_SCHEMA, f"{path}: SystemStructure.ssd")  # what the checks above leave: the standard's rules
    return system


# SSP 1.0 transformations (SystemStructureCommon.xsd, GTransformationChoice) the master does not apply
MAPPINGS = ("BooleanMappingTransformation", "IntegerMappingTransformation", "EnumerationMappingTransformation")


def _qname(tag: str) -> str:
    """'ssc:LinearTransformation' for '{http://ssp-standard.org/SSP1/SystemStructureCommon}LinearTransformation'."""
    for prefix, ns in _NS.items():
        tag = tag.replace(f"{{{ns}}}", f"{prefix}:")
    return tag


def _understood(el, allowed: tuple[str, ...], where: str) -> None:
    """Refuse any child element of el the reader does not understand (allowed: 'ssd:Connectors', ...,
    the SSP 1.0 children it reads or that carry no value: geometry, annotations), naming it."""
    for child in el:
        if not isinstance(child.tag, str):  # a comment or processing instruction
            continue
        if _qname(child.tag) not in allowed:
            raise SystemFileError(f"{where}: {_qname(child.tag)} is not an element gyrowheel's reader knows "
                                  f"here (known: {', '.join(allowed)})")


CONNECTION_CHILDREN = ("ssc:LinearTransformation", *(f"ssc:{m}" for m in MAPPINGS), "ssd:ConnectionGeometry",
                       "ssd:Annotations")


def _connection(el, units: dict, where: str) -> Connection:
    """One ssd:Connection: its ends and its transformation. ssc:LinearTransformation is applied
    (factor and offset, defaults 1 and 0); each mapping transformation is refused by name, and so
    is more than one transformation (SSP 1.0 GTransformationChoice: at most one) and any child
    that is not an SSP 1.0 child of a connection."""
    k = Connection(el.get("startElement"), el.get("startConnector"), el.get("endElement"), el.get("endConnector"))
    here = f"{where}connection {describe(k)}"
    _understood(el, CONNECTION_CHILDREN, here)
    transformations = [_qname(ch.tag) for ch in el if isinstance(ch.tag, str) and _qname(ch.tag) in
                       CONNECTION_CHILDREN[:4]]
    if len(transformations) > 1:
        raise SystemFileError(f"{here}: {len(transformations)} transformations ({', '.join(transformations)}): "
                              f"SSP 1.0 allows at most one per connection")
    for child in el:
        kind = child.tag.split("}", 1)[-1] if isinstance(child.tag, str) else ""
        if child.tag == f"{{{SSC_NS}}}LinearTransformation":
            k.factor = _number(child.get("factor"), 1.0, f"{here}: factor")
            k.offset = _number(child.get("offset"), 0.0, f"{here}: offset")
        elif kind in MAPPINGS:
            raise SystemFileError(f"{here}: ssc:{kind} is not supported by gyrowheel's "
                                  f"master (of the SSP 1.0 transformations only ssc:LinearTransformation is)")
    k.suppress_unit_conversion = el.get("suppressUnitConversion", "false").strip() in ("true", "1")
    return k


def _connector_units(sysel) -> dict[tuple[str, str], str]:
    """{(component, connector): unit} of the components' ssd:Connectors that declare a Real unit."""
    out = {}
    for comp in sysel.findall("ssd:Elements/ssd:Component", _NS):
        for conn in comp.findall("ssd:Connectors/ssd:Connector", _NS):
            real = conn.find("ssc:Real", _NS)
            if real is not None and real.get("unit"):
                out[(comp.get("name"), conn.get("name"))] = real.get("unit")
    return out
