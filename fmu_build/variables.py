"""The one variable table: every FMI variable of an FMU, with its C location.

modelDescription.xml and the C value-reference map (model_desc.c) are both
written from this table, so the two cannot disagree.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from gyrowheel.fmu_build.scene import MAX_INTERNAL_STEPS_RANGE, SOLVERS, TOLERANCE_RANGES, Experiment
from gyrowheel.model.spec import ModelSpec, Quantity

# The variables every FMU keeps (docs/interface.md); [outputs] keep cannot remove them.
REQUIRED_OUTPUTS = ("x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot", "gamma_dot",
                    "z", "vx", "vy", "energy")

# C enums of c_src/gw_model.h
KIND = {"param": "GW_VAR_PARAM", "start": "GW_VAR_START", "input": "GW_VAR_INPUT",
        "output": "GW_VAR_OUTPUT", "setting": "GW_VAR_SETTING", "event": "GW_VAR_EVENT",
        "state": "GW_VAR_STATE", "derivative": "GW_VAR_DERIVATIVE", "indicator": "GW_VAR_INDICATOR"}
TYPE = {"Real": "GW_REAL", "Integer": "GW_INTEGER", "Boolean": "GW_BOOLEAN", "Enumeration": "GW_ENUM"}
SETTING_INDEX = {"solver": 0, "rel_tol": 1, "abs_tol": 2, "max_step": 3, "max_internal_steps": 4}


@dataclass
class Variable:
    """One row: FMI attributes plus where the runtime keeps the value."""

    vr: int
    quantity: Quantity
    type: str  # Real, Integer, Boolean, Enumeration
    causality: str
    variability: str
    initial: str | None
    kind: str  # key of KIND
    index: int
    out_index: int = -1
    declared_type: str | None = None
    dependencies: tuple[int, ...] | None = None  # value references (= 1-based rows), for ModelStructure
    initial_dependencies: tuple[int, ...] | None = None
    state_index: int = -1  # the continuous state this variable is (start or state kinds)
    derivative_of: int | None = None  # derivative kind: 1-based index of the state's variable
    # array kind (FMI 3 only): where each element lives, ("x", state index) or ("y", output index)
    elements: tuple[tuple[str, int], ...] = ()

    @property
    def name(self) -> str:
        return self.quantity.name

    @property
    def start(self):
        return self.quantity.start


# FMI 3 array variable of the contact_forces effect: its outputs, in this order
CONTACT_FORCE = ("F_long", "F_lat", "F_n")

# the FMI 3.0 calls that take the place of the FMI 2.0 calls the settings' descriptions name
FMI3_CALLS = {"fmi2SetupExperiment": "fmi3EnterInitializationMode", "fmi2DoStep": "fmi3DoStep"}


def solver_settings(exp: Experiment, fmi: int = 2) -> list[tuple[Quantity, str, str | None]]:
    """The runtime's own parameters (docs/interface.md, "Solver settings"), their descriptions
    naming the calls of FMI version `fmi` (2 or 3: FMI3_CALLS)."""
    settings = _solver_settings(exp)
    if fmi == 3:
        for q, _, _ in settings:
            for old, new in FMI3_CALLS.items():
                q.description = q.description.replace(old, new)
    return settings


def _solver_settings(exp: Experiment) -> list[tuple[Quantity, str, str | None]]:
    return [
        (Quantity("solver", "", "internal Co-Simulation integrator", SOLVERS[exp.solver]), "Enumeration", "Solver"),
        (Quantity("rel_tol", "1", "relative error tolerance of adaptive solvers, in [2.2204460492503131e-15, 1] (10 eps to 1); "
                  "when not set, a tolerance passed to fmi2SetupExperiment replaces it",
                  exp.rel_tol, minimum=TOLERANCE_RANGES["rel_tol"][0], maximum=TOLERANCE_RANGES["rel_tol"][1]),
         "Real", None),
        (Quantity("abs_tol", "1", "absolute error tolerance of adaptive solvers, 0 or in [1e-30, 1], "
                  "scaled by each state's nominal value; 0: follow rel_tol (rel_tol / 100); when not "
                  "set, scaled with a tolerance passed to fmi2SetupExperiment (0 stays 0)",
                  exp.abs_tol, minimum=0.0, maximum=TOLERANCE_RANGES["abs_tol"][1]), "Real", None),
        (Quantity("max_step", "s", "upper bound of internal steps; the fixed step of euler and rk4",
                  exp.max_step_in_force), "Real", None),
        (Quantity("max_internal_steps", "", "budget of internal steps (accepted and rejected) of one "
                  "fmi2DoStep, from 1 to 2147483647: a step needing more is refused up front or stopped, "
                  "state kept at its start",
                  exp.max_internal_steps, minimum=MAX_INTERNAL_STEPS_RANGE[0], maximum=MAX_INTERNAL_STEPS_RANGE[1]),
         "Integer", None),
    ]


def enumeration_type_name(name: str) -> str:
    """The declared type of an Enumeration output: its name in CamelCase (contact_mode ->
    ContactMode)."""
    return "".join(part.capitalize() for part in name.split("_"))


def enumeration_types(table: list[Variable]) -> dict[str, list[tuple[str, int]]]:
    """The Enumeration types the outputs of `table` declare, {type name: [(item, value)]},
    values 0, 1, ... in the order of Quantity.items; the solver setting's Solver is not among
    them (model_description.solver_items). Raises ValueError if two outputs declare one type
    with different items."""
    types: dict[str, list[tuple[str, int]]] = {}
    for v in table:
        if v.kind != "output" or not v.quantity.items:
            continue
        items = [(item, value) for value, item in enumerate(v.quantity.items)]
        if types.setdefault(v.declared_type, items) != items:
            raise ValueError(f"output {v.name}: Enumeration type {v.declared_type} declared with other items")
    return types


def _depends(expr: ca.SX, syms: ca.SX) -> list[bool]:
    """Which elements of syms the expression depends on (structurally)."""
    if syms.numel() == 0:
        return []
    return [bool(d) for d in ca.which_depends(expr, syms, 1, False)]


def build_table(spec: ModelSpec, exp: Experiment, keep: list[str] | None = None, fmi: int = 2,
                arrays: bool = True) -> list[Variable]:
    """All variables, value references 1.., in the order of modelDescription.xml.

    spec: the model; exp: the solver settings' defaults; keep: the outputs to expose (None:
    all; the required ones always), ValueError naming an unknown one; fmi: 2 or 3, the FMI
    version of the FMU. FMI 3 appends, after the FMI 2 rows (whose value references it keeps),
    one local Float64 per event indicator, `<event>_indicator` (kind "indicator", index the
    event's: FMI 3.0.2 section 2.4.8, <EventIndicator> names variables, not a count), then,
    with `arrays`, the array outputs (kind "array", _arrays): the quantities that are vectors,
    each element the value of a scalar variable of the FMU.
    Returns the rows, row i having value reference i + 1."""
    rows: list[Variable] = []

    def add(**kw):
        rows.append(Variable(vr=len(rows) + 1, **kw))

    for i, q in enumerate(spec.parameters):
        add(quantity=q, type="Real", causality="parameter",
            variability="tunable" if q.tunable else "fixed", initial="exact", kind="param", index=i)
    for q, typ, declared in solver_settings(exp, fmi):
        add(quantity=q, type=typ, causality="parameter", variability="fixed", initial="exact",
            kind="setting", index=SETTING_INDEX[q.name], declared_type=declared)
    for i, q in enumerate(spec.inputs):
        add(quantity=q, type="Real", causality="input", variability="continuous", initial=None,
            kind="input", index=i)
    start_names = {q.name: i for i, q in enumerate(spec.starts)}
    if keep is not None:
        known = {q.name for q, _ in spec.outputs}
        unknown = [k for k in keep if k not in known]
        if unknown:
            raise ValueError(f"[outputs] keep: unknown output {unknown[0]!r}; valid: {', '.join(sorted(known))}")
    for j, (q, _) in enumerate(spec.outputs):
        if keep is not None and q.name not in keep and q.name not in REQUIRED_OUTPUTS:
            continue
        if q.items:  # a mode: changes only at events (FMI 2.0.4 section 2.2.7, variability discrete)
            add(quantity=q, type="Enumeration", causality="output", variability="discrete",
                initial="calculated", kind="output", index=j, declared_type=enumeration_type_name(q.name))
        elif q.name in start_names:
            add(quantity=q, type="Real", causality="output", variability="continuous", initial="exact",
                kind="start", index=start_names[q.name], out_index=j)
        else:
            add(quantity=q, type="Real", causality="output", variability="continuous",
                initial="calculated", kind="output", index=j)
    for k, ev in enumerate(spec.events):
        add(quantity=ev.flag, type="Boolean", causality="output", variability="discrete",
            initial="calculated", kind="event", index=k)
    _states(spec, rows, add)
    if fmi == 3:
        for k, ev in enumerate(spec.events):
            add(quantity=Quantity(f"{ev.name}_indicator", "1", f"event indicator of {ev.name}: the event "
                                  "fires when it goes from > 0 to <= 0"),
                type="Real", causality="local", variability="continuous", initial="calculated",
                kind="indicator", index=k)
        if arrays:
            _arrays(spec, rows, add)
    _structure(spec, rows)
    return rows


def _states(spec: ModelSpec, rows: list[Variable], add) -> None:
    """Every continuous state as a variable (its start variable, else a local) and its derivative."""
    by_name = {r.name: r for r in rows if r.kind == "start"}
    state_rows = []
    for i, name in enumerate(spec.x_names):
        row = by_name.get(name)
        if row is not None:
            row.state_index = i
        else:
            add(quantity=Quantity(name, _unit_of_state(spec, name), "internal continuous state"),
                type="Real", causality="local", variability="continuous", initial="calculated",
                kind="state", index=i, state_index=i)
            row = rows[-1]
        state_rows.append(row)
    for i, row in enumerate(state_rows):
        unit = row.quantity.unit
        add(quantity=Quantity(f"der({row.name})", per_second(unit), f"time derivative of {row.name}"),
            type="Real", causality="local", variability="continuous", initial="calculated",
            kind="derivative", index=i, derivative_of=rows.index(row) + 1)


def _arrays(spec: ModelSpec, rows: list[Variable], add) -> None:
    """The FMI 3 array outputs (FMI 3.0.2 section 2.4.7.2, one <Dimension>): x_state, the
    continuous state vector, and contact_force, [F_long, F_lat, F_n], when the FMU has the
    contact_forces effect's outputs (each element a scalar variable of the FMU, rows: the
    partial derivatives of an array are its elements')."""
    add(quantity=Quantity("x_state", "", "continuous state vector [" + ", ".join(spec.x_names) + "]"),
        type="Real", causality="output", variability="continuous", initial="calculated", kind="array",
        index=-1, elements=tuple(("x", i) for i in range(spec.x.numel())))
    names = {q.name: j for j, (q, _) in enumerate(spec.outputs)}
    kept = {r.name for r in rows if r.causality == "output"}
    if all(n in names and n in kept for n in CONTACT_FORCE):
        add(quantity=Quantity("contact_force", "N", "contact force (ground on wheel) ["
                              + ", ".join(CONTACT_FORCE) + "]: along the heading, across it, normal"),
            type="Real", causality="output", variability="continuous", initial="calculated", kind="array",
            index=-1, elements=tuple(("y", names[n]) for n in CONTACT_FORCE))


def _unit_of_state(spec: ModelSpec, name: str) -> str:
    """The unit of state `name`: the model's declaration (ModelSpec.x_units). Raises ValueError
    for a model that declares none."""
    if len(spec.x_units) != len(spec.x_names):
        raise ValueError(f"model {spec.name}: no unit declared for its states (ModelSpec.x_units)")
    return spec.x_units[spec.x_names.index(name)]


def per_second(unit: str) -> str:
    """The unit of a time derivative (unit / s) in modelDescription's notation: m -> m/s,
    rad/s -> rad/s2, m/s -> m/s2, J -> W, N.s -> N, 1 (or none) -> 1/s; ValueError for a unit
    it cannot write."""
    if unit in ("", "1"):
        return "1/s"
    if unit.endswith("/s"):
        return unit + "2"
    if unit.endswith("/s2"):
        raise ValueError(f"no unit for the derivative of {unit}")
    return {"J": "W", "N.s": "N", "N.m.s": "N.m"}.get(unit, unit + "/s")


def _structure(spec: ModelSpec, rows: list[Variable]) -> None:
    """Exact ModelStructure dependencies from CasADi's sparsity (FMI 2.0.4 section 2.2.8).

    Outputs and Derivatives: the knowns of Event/Continuous-Time Mode and of communication
    points, i.e. continuous states and inputs. InitialUnknowns: the knowns of Initialization
    Mode, i.e. the variables with initial = "exact" (start values, parameters) and inputs, on
    which the unknown depends once x is replaced by init(s, p); a calculated state is an
    unknown there, never a known. Every list is sorted and without repeats.
    """
    by_kind_index = {(r.kind, r.index): i + 1 for i, r in enumerate(rows)}
    state_var = {r.state_index: i + 1 for i, r in enumerate(rows) if r.state_index >= 0}
    y = [e for _, e in spec.outputs]
    x0 = spec.init
    for row in rows:
        if row.causality != "output" and row.kind not in ("derivative", "state", "indicator"):
            continue
        if row.kind == "array":
            expr = ca.vertcat(*[spec.x[i] if src == "x" else y[i] for src, i in row.elements])
        elif row.kind in ("event", "indicator"):
            expr = spec.events[row.index].expr
        elif row.kind == "derivative":
            expr = spec.ode[row.index]
        elif row.kind == "state":
            expr = spec.x[row.index]
        else:
            expr = y[row.out_index if row.kind == "start" else row.index]
        # knowns: inputs (Co-Simulation and Model Exchange) and continuous states (Model Exchange)
        deps = {state_var[i] for i, d in enumerate(_depends(expr, spec.x)) if d and row.kind != "state"}
        deps |= {by_kind_index[("input", i)] for i, d in enumerate(_depends(expr, spec.u)) if d}
        row.dependencies = tuple(sorted(deps))
        if row.initial == "calculated" and row.kind != "indicator":  # no InitialUnknown
            at_start = ca.substitute(expr, spec.x, x0)
            deps = {by_kind_index[("start", i)] for i, d in enumerate(_depends(at_start, spec.s))
                    if d and ("start", i) in by_kind_index}
            deps |= {by_kind_index[("param", i)] for i, d in enumerate(_depends(at_start, spec.p)) if d}
            deps |= {by_kind_index[("input", i)] for i, d in enumerate(_depends(at_start, spec.u)) if d}
            row.initial_dependencies = tuple(sorted(deps))
