"""modelDescription.xml (FMI 2.0 Co-Simulation) from the variable table."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from datetime import datetime, timezone

from gyrowheel.fmu_build.scene import SOLVERS, Experiment
from gyrowheel.fmu_build.variables import Variable, enumeration_types

LOG_CATEGORIES = {  # must match c_src/gw_log.c
    "logEvents": "events: fall, warnings at located event times",
    "logSolver": "integrator statistics per communication step",
    "logStatusWarning": "messages with status fmi2Warning",
    "logStatusDiscard": "messages with status fmi2Discard",
    "logStatusError": "messages with status fmi2Error",
    "logStatusFatal": "messages with status fmi2Fatal",
    "logAll": "everything",
}

# name -> (SI base unit exponents, display units {name: factor})
UNITS = {
    "m": ({"m": 1}, {}),
    "s": ({"s": 1}, {}),
    "kg": ({"kg": 1}, {}),
    "rad": ({"rad": 1}, {"deg": 57.29577951308232}),
    "rad/s": ({"rad": 1, "s": -1}, {"rpm": 9.549296585513721, "deg/s": 57.29577951308232}),
    "rad/s2": ({"rad": 1, "s": -2}, {}),
    "m/s": ({"m": 1, "s": -1}, {"km/h": 3.6}),
    "m/s2": ({"m": 1, "s": -2}, {}),
    "N": ({"kg": 1, "m": 1, "s": -2}, {}),
    "N.m": ({"kg": 1, "m": 2, "s": -2}, {}),
    "J": ({"kg": 1, "m": 2, "s": -2}, {}),
    "W": ({"kg": 1, "m": 2, "s": -3}, {}),
    "1/s": ({"s": -1}, {}),
    "kg.m2": ({"kg": 1, "m": 2}, {}),
    "kg/m3": ({"kg": 1, "m": -3}, {}),
    "m2": ({"m": 2}, {}),
    "N.s": ({"kg": 1, "m": 1, "s": -1}, {}),
    "N.s/m": ({"kg": 1, "s": -1}, {}),
    "N.m.s": ({"kg": 1, "m": 2, "s": -1}, {}),
}


def _fmt(value: float) -> str:
    return repr(float(value))


def _unit_of(v: Variable) -> str | None:
    u = v.quantity.unit
    return u if u and u != "1" else None


def write_model_description(model_name: str, exp: Experiment, table: list[Variable], identifier: str,
                            guid: str, sources: list[str], description: str, model_exchange: bool = False,
                            directional: bool = False, taylor: bool = False) -> str:
    """The XML text. `sources` are the C files listed under <SourceFiles>.

    taylor: the model has the Taylor kernel, so the Solver enumeration lists item taylor (6);
    an FMU without it lists only the solvers it can run.

    model_exchange adds the ModelExchange interface (the runtime's fmi2GetDerivatives & co.),
    directional declares fmi2GetDirectionalDerivative (CasADi's exact Jacobian).
    """
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0",
        "modelName": model_name,
        "guid": guid,
        "description": description,
        "generationTool": "gyrowheel",
        "generationDateAndTime": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "variableNamingConvention": "flat",
        "numberOfEventIndicators": "0",
    })
    common = {  # capabilities the runtime has in both interfaces
        "modelIdentifier": identifier,
        "canBeInstantiatedOnlyOncePerProcess": "false",
        "canNotUseMemoryManagementFunctions": "false",
        "canGetAndSetFMUstate": "true",
        "canSerializeFMUstate": "true",
        "providesDirectionalDerivative": "true" if directional else "false",
    }
    interfaces = []
    if model_exchange:
        root.set("numberOfEventIndicators", str(sum(1 for v in table if v.kind == "event")))
        interfaces.append(ET.SubElement(root, "ModelExchange", {**common, "completedIntegratorStepNotNeeded": "true"}))
    interfaces.append(ET.SubElement(root, "CoSimulation", {
        **common,
        "canHandleVariableCommunicationStepSize": "true",
        "canInterpolateInputs": "false",
        "maxOutputDerivativeOrder": "0",
        "canRunAsynchronuously": "false",
    }))
    for element in interfaces:
        files = ET.SubElement(element, "SourceFiles")
        for name in sources:
            ET.SubElement(files, "File", {"name": name})

    write_units(root, {u for v in table if (u := _unit_of(v))})

    types = ET.SubElement(root, "TypeDefinitions")
    for type_name, items in enumerations(table, taylor).items():
        enum = ET.SubElement(ET.SubElement(types, "SimpleType", {"name": type_name}), "Enumeration")
        for name, value in items:
            ET.SubElement(enum, "Item", {"name": name, "value": str(value)})

    write_log_categories_and_experiment(root, exp, LOG_CATEGORIES)

    mvs = ET.SubElement(root, "ModelVariables")
    for v in table:
        sv = ET.SubElement(mvs, "ScalarVariable", variable_attrs(v))
        type_attrs: dict[str, str] = {}
        if v.declared_type:
            type_attrs["declaredType"] = v.declared_type
        if v.type == "Real":
            if (u := _unit_of(v)):
                type_attrs["unit"] = u
            if v.derivative_of is not None:
                type_attrs["derivative"] = str(v.derivative_of)
            if v.quantity.display_unit:
                type_attrs["displayUnit"] = v.quantity.display_unit
        type_attrs.update(range_attrs(v))
        if (start := start_text(v)) is not None:
            type_attrs["start"] = start
        ET.SubElement(sv, v.type, type_attrs)

    ms = ET.SubElement(root, "ModelStructure")
    outputs = ET.SubElement(ms, "Outputs")
    for i, v in enumerate(table, start=1):
        if v.causality == "output":
            ET.SubElement(outputs, "Unknown", _unknown_attrs(i, v.dependencies))
    derivatives = ET.SubElement(ms, "Derivatives")
    for i, v in enumerate(table, start=1):
        if v.kind == "derivative":
            ET.SubElement(derivatives, "Unknown", _unknown_attrs(i, v.dependencies))
    if len(derivatives) == 0:
        ms.remove(derivatives)
    initial = ET.SubElement(ms, "InitialUnknowns")
    for i, v in enumerate(table, start=1):
        if (v.causality == "output" or v.kind in ("state", "derivative")) and v.initial in ("calculated", "approx"):
            ET.SubElement(initial, "Unknown", _unknown_attrs(i, v.initial_dependencies))
    if len(initial) == 0:
        ms.remove(initial)
    ET.indent(root, "  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def variable_attrs(v: Variable) -> dict[str, str]:
    """The attributes every variable has in FMI 2.0.4 (ScalarVariable, section 2.2.7) and FMI
    3.0.2 (section 2.4.7): name, valueReference, description, causality, variability, initial."""
    attrs = {"name": v.name, "valueReference": str(v.vr)}
    if v.quantity.description:
        attrs["description"] = v.quantity.description
    attrs["causality"] = v.causality
    attrs["variability"] = v.variability
    if v.initial:
        attrs["initial"] = v.initial
    return attrs


def solver_items(taylor: bool) -> list[tuple[str, int]]:
    """The Solver enumeration's items (name, value): every solver, taylor only with the kernel."""
    return [(name, value) for name, value in SOLVERS.items() if name != "taylor" or taylor]


def enumerations(table: list[Variable], taylor: bool) -> dict[str, list[tuple[str, int]]]:
    """Every Enumeration type of the FMU, {name: [(item, value)]}: Solver (solver_items) and
    those of the Enumeration outputs (variables.enumeration_types, e.g. ContactMode)."""
    return {"Solver": solver_items(taylor), **enumeration_types(table)}


def range_attrs(v: Variable) -> dict[str, str]:
    """The min and max attributes (FMI 2.0.4 section 2.2.7, FMI 3.0.2 section 2.4.7.4: inclusive
    limits of the value) of a parameter or solver setting whose Quantity has them: the bounds the
    FMU refuses values beyond (at fmi2SetReal for the settings, at fmi2ExitInitializationMode for
    the model's parameters; docs/interface.md, "Valid ranges"). Start values of outputs carry
    none: an output's min and max would bound its values during the run too, which the start
    values' ranges do not. Returns {} or {"min": ..., "max": ...} (either alone)."""
    if v.kind not in ("param", "setting") or v.type not in ("Real", "Integer"):
        return {}
    text = _fmt if v.type == "Real" else (lambda x: str(int(x)))
    attrs = {}
    if v.quantity.minimum is not None:
        attrs["min"] = text(v.quantity.minimum)
    if v.quantity.maximum is not None:
        attrs["max"] = text(v.quantity.maximum)
    return attrs


def start_text(v: Variable) -> str | None:
    """The start attribute of a variable that has one (initial exact or approx, or an input:
    FMI 2.0.4 section 2.2.7, FMI 3.0.2 section 2.4.7.5), else None."""
    if v.initial not in ("exact", "approx") and v.causality != "input":
        return None
    if v.type == "Real":
        return _fmt(v.start)
    if v.type == "Boolean":
        return "true" if v.start else "false"
    return str(int(v.start))


def write_units(root: ET.Element, used: set[str]) -> None:
    """<UnitDefinitions> of the units `used` (by name, sorted), from UNITS: the same element in
    FMI 2.0.4 (section 2.2.2) and FMI 3.0.2 (section 2.4.3). Raises ValueError for a unit UNITS
    does not define."""
    unknown = sorted(u for u in used if u not in UNITS)
    if unknown:
        raise ValueError(f"unit {unknown[0]!r} has no definition in gyrowheel.fmu_build.model_description.UNITS")
    units = ET.SubElement(root, "UnitDefinitions")
    for name in sorted(used):
        base, displays = UNITS[name]
        unit = ET.SubElement(units, "Unit", {"name": name})
        ET.SubElement(unit, "BaseUnit", {k: str(e) for k, e in base.items()})
        for dname, factor in displays.items():
            ET.SubElement(unit, "DisplayUnit", {"name": dname, "factor": _fmt(factor)})


def write_log_categories_and_experiment(root: ET.Element, exp: Experiment, categories: dict[str, str]) -> None:
    """<LogCategories> ({name: description}) and <DefaultExperiment>: the same elements in FMI
    2.0.4 (sections 2.2.4, 2.2.5) and FMI 3.0.2 (sections 2.4.5, 2.4.6)."""
    cats = ET.SubElement(root, "LogCategories")
    for name, desc in categories.items():
        ET.SubElement(cats, "Category", {"name": name, "description": desc})

    # The scene's tolerance: importers that forward DefaultExperiment's tolerance to
    # fmi2SetupExperiment / fmi3EnterInitializationMode (PyFMI, OMSimulator, fmpy) get the
    # scene's accuracy; without it they forward their own 1e-4. A rel_tol set explicitly still
    # wins (docs/fmi.md, "Tolerances").
    ET.SubElement(root, "DefaultExperiment", {
        "startTime": _fmt(exp.start_time), "stopTime": _fmt(exp.stop_time),
        "tolerance": _fmt(exp.rel_tol), "stepSize": _fmt(exp.output_interval),
    })


def _unknown_attrs(index: int, deps: tuple[int, ...] | None) -> dict[str, str]:
    attrs = {"index": str(index)}
    if deps is not None:
        attrs["dependencies"] = " ".join(str(d) for d in deps)
    return attrs
