"""modelDescription.xml and buildDescription.xml of an FMI 3.0 FMU (FMI 3.0.2, sections 2.4
and 2.5.1), from the same variable table as the FMI 2.0 one (fmu_build/variables.py,
build_table(..., fmi=3)).

What differs from FMI 2.0 (fmu_build/model_description.py): the GUID is the
instantiationToken; every variable is an element of its type (Real -> Float64, Integer ->
Int32, Boolean, Enumeration) with its attributes on it; the independent variable `time` is
declared (value reference 0); `derivative` and ModelStructure's entries name value references,
not indices; the event indicators are variables (<EventIndicator>), the sources are listed in
sources/buildDescription.xml, not in the model description.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from datetime import datetime, timezone

from gyrowheel.fmu_build.model_description import (LOG_CATEGORIES, _unit_of, enumerations, range_attrs, start_text,
                                                   variable_attrs, write_log_categories_and_experiment, write_units)
from gyrowheel.fmu_build.scene import Experiment
from gyrowheel.fmu_build.variables import Variable

TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "Enumeration": "Enumeration"}
TIME_VR = 0  # the independent variable's value reference (FMI 3.0.2, section 2.4.7.4)
XML_HEAD = '<?xml version="1.0" encoding="UTF-8"?>\n'


def _log_categories() -> dict[str, str]:
    """The FMI 2 categories (c_src/gw_log.c), described by FMI 3.0's status names."""
    return {name: desc.replace("fmi2", "fmi3") for name, desc in LOG_CATEGORIES.items()}


def _text(root: ET.Element) -> str:
    ET.indent(root, "  ")
    return XML_HEAD + ET.tostring(root, encoding="unicode") + "\n"


def write_model_description3(model_name: str, exp: Experiment, table: list[Variable], identifier: str,
                             token: str, description: str, taylor: bool = False,
                             reinit: bool = False) -> str:
    """The FMI 3.0 modelDescription.xml text (FMI 3.0.2, section 2.4) of an FMU with both
    Model Exchange and Co-Simulation.

    table: build_table(..., fmi=3), rows with value references 1..N, the event indicators'
    rows (kind "indicator") among them; token: the instantiationToken (the GUID the C model
    table holds); taylor: the model has the Taylor kernel, so the Solver enumeration lists
    item taylor; reinit: an event may set the continuous states anew (an update event, e.g.
    stiction's mode switch: section 2.4.7.5, attribute reinit of a continuous state).
    Raises ValueError for a unit without a definition (model_description.UNITS).
    """
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0",
        "modelName": model_name,
        "instantiationToken": token,
        "description": description,
        "generationTool": "gyrowheel",
        "generationDateAndTime": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "variableNamingConvention": "flat",
    })
    common = {  # section 2.4.1: what the runtime offers in both interfaces
        "modelIdentifier": identifier,
        "canBeInstantiatedOnlyOncePerProcess": "false",
        "canGetAndSetFMUState": "true",
        "canSerializeFMUState": "true",
        "providesDirectionalDerivatives": "true",
        "providesAdjointDerivatives": "true",
        "providesPerElementDependencies": "false",
    }
    ET.SubElement(root, "ModelExchange", {**common, "needsCompletedIntegratorStep": "false",
                                          "providesEvaluateDiscreteStates": "false"})
    ET.SubElement(root, "CoSimulation", {  # section 4.2.1
        **common,
        "canHandleVariableCommunicationStepSize": "true",
        "maxOutputDerivativeOrder": "0",
        "providesIntermediateUpdate": "false",
        "mightReturnEarlyFromDoStep": "true",  # at a located event, when earlyReturnAllowed
        "canReturnEarlyAfterIntermediateUpdate": "false",
        "providesEvaluateDiscreteStates": "false",
        "hasEventMode": "true",
    })
    write_units(root, {"s"} | {u for v in table if (u := _unit_of(v))})

    types = ET.SubElement(root, "TypeDefinitions")
    for type_name, items in enumerations(table, taylor).items():
        enum = ET.SubElement(types, "EnumerationType", {"name": type_name})
        for name, value in items:
            ET.SubElement(enum, "Item", {"name": name, "value": str(value)})
    write_log_categories_and_experiment(root, exp, _log_categories())

    mvs = ET.SubElement(root, "ModelVariables")
    ET.SubElement(mvs, "Float64", {"name": "time", "valueReference": str(TIME_VR), "causality": "independent",
                                   "variability": "continuous", "unit": "s", "description": "simulation time"})
    for v in table:
        element = ET.SubElement(mvs, TYPES[v.type], _variable_attrs(v, reinit))
        if v.elements:  # an array variable of one dimension (section 2.4.7.2)
            ET.SubElement(element, "Dimension", {"start": str(len(v.elements))})

    ms = ET.SubElement(root, "ModelStructure")  # section 2.4.8, in the schema's order
    for v in table:
        if v.causality == "output":
            ET.SubElement(ms, "Output", _unknown_attrs(v.vr, v.dependencies))
    for v in table:
        if v.kind == "derivative":
            ET.SubElement(ms, "ContinuousStateDerivative", _unknown_attrs(v.vr, v.dependencies))
    for v in table:
        if (v.causality == "output" or v.kind in ("state", "derivative")) and v.initial in ("calculated", "approx"):
            ET.SubElement(ms, "InitialUnknown", _unknown_attrs(v.vr, v.initial_dependencies))
    for v in table:
        if v.kind == "indicator":
            ET.SubElement(ms, "EventIndicator", _unknown_attrs(v.vr, v.dependencies))
    return _text(root)


def _variable_attrs(v: Variable, reinit: bool) -> dict[str, str]:
    """A variable element's attributes (FMI 3.0.2, section 2.4.7)."""
    attrs = variable_attrs(v)
    if v.declared_type:
        attrs["declaredType"] = v.declared_type
    if v.type == "Real":
        if (u := _unit_of(v)):
            attrs["unit"] = u
        if v.quantity.display_unit:
            attrs["displayUnit"] = v.quantity.display_unit
    attrs.update(range_attrs(v))
    if (start := start_text(v)) is not None:
        attrs["start"] = start
    if v.derivative_of is not None:
        attrs["derivative"] = str(v.derivative_of)  # the state's value reference
    if reinit and v.state_index >= 0:
        attrs["reinit"] = "true"
    return attrs


def _unknown_attrs(vr: int, deps: tuple[int, ...] | None) -> dict[str, str]:
    attrs = {"valueReference": str(vr)}
    if deps is not None:
        attrs["dependencies"] = " ".join(str(d) for d in deps)
    return attrs


def write_build_description(identifier: str, source: str) -> str:
    """sources/buildDescription.xml (FMI 3.0.2, section 2.5.1.2, fmi3BuildDescription.xsd):
    one BuildConfiguration of `identifier`, C99, the one translation unit `source` (the other
    files of sources/ are its parts, empty when compiled alone); sources/ is the include
    directory the standard implies."""
    root = ET.Element("fmiBuildDescription", {"fmiVersion": "3.0"})
    config = ET.SubElement(root, "BuildConfiguration", {"modelIdentifier": identifier})
    files = ET.SubElement(config, "SourceFileSet", {"language": "C99"})
    ET.SubElement(files, "SourceFile", {"name": source})
    return _text(root)
