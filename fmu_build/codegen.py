"""C code of one model: CasADi-generated functions plus model_desc.c (GW_MODEL).

gw_funcs.c comes from casadi.CodeGenerator, rewritten by gyrowheel.fmu_build.casadi_c so that every
function in it is static and warning-clean; model_desc.c is the constant the runtime reads
(c_src/gw_model.h), `static const gw_model GW_MODEL`, written from the same variable table as
modelDescription.xml.  Both are parts of the FMU's single translation unit c_src/gw_fmu.c
(gw_fmu3.c in an FMI 3 FMU; it includes them ahead of the runtime); compiled on their own
they are empty.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import casadi as ca

from gyrowheel.fmu_build.casadi_c import UNITY_GUARD_CLOSE, UNITY_GUARD_OPEN, make_internal
from gyrowheel.fmu_build.codegen_cache import cached_generation
from gyrowheel.fmu_build.scene import SOLVERS, Experiment
from gyrowheel.taylor.graph import TaylorUnsupportedError
from gyrowheel.taylor.kernel_c import KERNEL_FILE, TaylorKernel, write_taylor_kernel
from gyrowheel.fmu_build.variables import KIND, TYPE, Variable
from gyrowheel.model.hoist import split_parameters
from gyrowheel.model.spec import ModelSpec

FUNCTION_FILE = "gw_funcs"
DESC_FILE = "model_desc.c"
SLOTS = ("init", "ode", "out", "evt", "chk", "nom", "jac", "dir", "dini", "upd", "ode_pre")
EVENT_ACTION = {"terminate": "GW_EVENT_TERMINATE", "warn": "GW_EVENT_WARN", "update": "GW_EVENT_UPDATE"}


def optimised(fn: ca.Function) -> ca.Function:
    """Same function with common subexpressions merged (casadi.cse)."""
    ins = fn.sx_in()
    outs = ca.cse(fn.call(ins))
    return ca.Function(fn.name(), ins, outs, fn.name_in(), fn.name_out())


def initial_unknowns(table: list[Variable]) -> list[Variable]:
    """The Real InitialUnknowns of modelDescription.xml, in its order (FMI 2.0.4 section 2.2.8):
    calculated outputs, states and state derivatives; the rows of `dini`. FMI 3's array outputs
    are not among them: their elements are states and outputs."""
    return [v for v in table if v.type == "Real" and v.initial in ("calculated", "approx") and v.kind != "array"
            and (v.causality == "output" or v.kind in ("state", "derivative"))]


def initial_expressions(spec: ModelSpec, table: list[Variable]) -> ca.SX:
    """The InitialUnknowns as functions of (t, s, u, p): x replaced by init(s, p)."""
    y = [e for _, e in spec.outputs]
    rows = []
    for v in initial_unknowns(table):
        if v.kind == "derivative":
            rows.append(spec.ode[v.index])
        elif v.kind == "state":
            rows.append(spec.x[v.index])
        else:
            rows.append(y[v.out_index if v.kind == "start" else v.index])
    return ca.substitute(ca.vertcat(*rows), spec.x, spec.init) if rows else ca.SX(0, 1)


def init_jacobian(spec: ModelSpec, table: list[Variable]) -> ca.Function | None:
    """gw_dini(t, s, u, p) -> D0 = d v / d [s; p; u], v the InitialUnknowns (dense, column-major).

    The partial derivatives fmi2GetDirectionalDerivative answers in Initialization Mode, where
    the knowns are the exact start values, the parameters and the inputs (FMI 2.0.4 sections
    2.1.9, 2.2.8). Only the advertised rows and columns are generated; CasADi computes only the
    structural non-zeros, which are exactly the InitialUnknowns' `dependencies`."""
    v0 = initial_expressions(spec, table)
    if v0.numel() == 0:
        return None
    knowns = ca.vertcat(spec.s, spec.p, spec.u)
    return ca.Function("gw_dini", [spec.t, spec.s, spec.u, spec.p],
                       [ca.densify(ca.jacobian(v0, knowns))], ["t", "s", "u", "p"], ["D0"])


def hoisted(spec: ModelSpec) -> dict[str, ca.Function]:
    """spec.functions() with the parameter-only subexpressions of ode and of the event indicators
    evt moved to ode_pre(p) -> c (model/hoist.py): ode(t, x, u, p, c) and evt(t, x, u, p, c),
    c evaluated by the runtime once per parameter change (the fall event sin(beta) - sin(beta_min)
    then costs one sine per call, not two).  Both are split together, so a value both use is
    hoisted once; when anything is hoisted both take c (each may leave some of it unused)."""
    fns = spec.functions()
    evt = "evt" in fns
    rows = ca.vertcat(spec.ode, *[e.expr for e in spec.events]) if evt else spec.ode
    c, rows_c, c_sym = split_parameters(ca.cse(rows), [spec.t, spec.x, spec.u], spec.p)
    if c.numel() > 0:
        nx, txupc = spec.x.numel(), [spec.t, spec.x, spec.u, spec.p, c_sym]
        fns["ode"] = ca.Function("gw_ode", txupc, [rows_c[:nx]], ["t", "x", "u", "p", "c"], ["xdot"])
        if evt:
            fns["evt"] = ca.Function("gw_evt", txupc, [rows_c[nx:]], ["t", "x", "u", "p", "c"], ["e"])
        fns["ode_pre"] = ca.Function("gw_ode_pre", [spec.p], [c], ["p"], ["c"])
    return fns


def generate_functions(spec: ModelSpec, out_dir: Path, table: list[Variable] | None = None
                       ) -> dict[str, ca.Function]:
    """Write gw_funcs.c (static functions only); return the functions by slot name.

    ode comes split into ode_pre(p) and ode(t, x, u, p, c) when that hoists anything (hoisted);
    with the variable table, also `dini`, the partial derivatives of Initialization Mode."""
    functions = hoisted(spec)
    if table is not None and (dini := init_jacobian(spec, table)) is not None:
        functions["dini"] = dini
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{FUNCTION_FILE}.c"
    return cached_generation(functions, path, lambda: _generate(functions, path))


def _generate(functions: dict[str, ca.Function], path: Path) -> dict[str, ca.Function]:
    """Write `path` (gw_funcs.c) from `functions` merged by optimised(); those by slot name."""
    fns = {slot: optimised(f) for slot, f in functions.items()}
    cwd = Path.cwd()
    try:  # CodeGenerator writes into the working directory
        os.chdir(path.parent)
        cg = ca.CodeGenerator(path.name, {"with_header": False, "with_export": False})
        for f in fns.values():
            cg.add(f)
        cg.generate()
    finally:
        os.chdir(cwd)
    keep = {n for f in fns.values() for n in (f.name(), f.name() + "_work")}
    path.write_text(make_internal(path.read_text(), keep))
    return fns


def taylor_ode(fns: dict[str, ca.Function]) -> ca.Function:
    """ode(t, x, u, p) -> xdot whole: a hoisted ode(t, x, u, p, c) with c = ode_pre(p) put back.

    The Taylor kernel hoists on its own (its constants: the nodes depending on u and p only,
    computed once per integration call), so it takes the unsplit expression graph."""
    ode = fns["ode"]
    if ode.n_in() == 4:
        return ode
    t, x, u, p = ode.sx_in()[:4]
    xdot = ode(t, x, u, p, fns["ode_pre"](p))
    return ca.Function("gw_ode_whole", [t, x, u, p], [ca.cse(xdot)], ["t", "x", "u", "p"], ["xdot"])


NO_KERNEL = ("built without a Taylor kernel (build it from a scene with solver = \"taylor\", "
             "or with the Taylor kernel: gyrowheel build --taylor, build_fmu(..., taylor=True))")


def kernel_choice(solver: str, taylor: bool | None, modes: bool = False) -> bool | None:
    """Whether a build generates the Taylor kernel, for the scene's solver, the build option
    `taylor` (build_fmu's argument, `gyrowheel build --taylor / --no-taylor`, [build] taylor) and
    whether the model switches modes at events (modes: it has update events, the contact modes).
    True: the kernel, an operation without a recurrence an error (solver taylor, taylor=True);
    False: none (taylor=False; by default every solver but taylor, and auto in a model with
    modes, which integrates with dop853 there; the generated C stays as without solver taylor);
    None: the kernel where the model's operations allow it (solver auto in a model without
    modes: it then integrates with taylor, docs/accuracy.md "Solver auto").
    Raises ArgumentError naming `taylor` for taylor=False with solver taylor."""
    if solver == "taylor":
        if taylor is False:
            from gyrowheel.errors import ArgumentError
            raise ArgumentError('taylor: false leaves out the Taylor kernel that the scene\'s solver = "taylor" '
                                "needs: name another solver or build with the kernel", argument="taylor")
        return True
    if taylor is not None:
        return bool(taylor)
    return None if solver == "auto" and not modes else False


def generate_taylor(fns: dict[str, ca.Function], model: str, out_dir: Path,
                    wanted: bool | None) -> TaylorKernel | str:
    """Write gw_taylor_model.h (solver `taylor`); the kernel, or why the model has none.

    Only an FMU that asks for it gets the kernel (wanted, kernel_choice: True, or None for
    where the model allows it): it adds C to compile (docs/taylor.md, build time), so an FMU
    without it builds as fast as without solver taylor and carries a gw_taylor_model.h of one
    comment.  wanted True and an operation without a recurrence raises
    TaylorUnsupportedError naming it; wanted None returns that message instead (the FMU's
    solver auto then integrates with dop853).
    """
    if wanted is False:
        (out_dir / KERNEL_FILE).write_text(f"/* no Taylor kernel: {NO_KERNEL} */\n")
        return NO_KERNEL
    try:
        return write_taylor_kernel(taylor_ode(fns), model, out_dir, fns.get("evt"))
    except TaylorUnsupportedError as exc:
        if wanted:
            raise
        why = f"no Taylor kernel: {exc}"
        (out_dir / KERNEL_FILE).write_text("/* " + why.replace("*/", "* /") + " */\n")
        return why


def _c_string(text: str) -> str:
    return json.dumps(text)  # a JSON string literal is a valid C string literal for our texts


def _c_doubles(values) -> str:
    return "{" + ", ".join(repr(float(v)) for v in values) + "}" if values else "{0.0}"


def _c_strings(values) -> str:
    return "{" + ", ".join(_c_string(v) for v in values) + "}" if values else "{\"\"}"


def _taylor_slot(taylor: TaylorKernel | str | None) -> str:
    if isinstance(taylor, TaylorKernel):
        return (f"    .taylor = {{gw_tl1_jet, gw_tl1_cst, {taylor.n_var}, {taylor.n_cst}, 0}},")
    why = taylor if isinstance(taylor, str) else NO_KERNEL
    return f"    .taylor = {{0, 0, 0, 0, {_c_string(why)}}},"


def _arrays_c(arrays: list[Variable]) -> tuple[str, str]:
    """The C of FMI 3's array variables (gw_array of c_src/gw_model.h): the element tables and
    the array table, and GW_MODEL's fields naming them; both empty without arrays (FMI 2)."""
    if not arrays:
        return "", ""
    source = {"x": "GW_ARRAY_X", "y": "GW_ARRAY_Y"}
    lines, rows = [], []
    for v in sorted(arrays, key=lambda v: v.vr):
        (src,) = {s for s, _ in v.elements}  # every element of an array from one vector
        lines.append(f"static const int gwm_{v.name}_index[] = {{{', '.join(str(i) for _, i in v.elements)}}};")
        rows.append(f"    {{{v.vr}u, {_c_string(v.name)}, {len(v.elements)}, {source[src]}, gwm_{v.name}_index}},")
    text = "\n".join(lines) + "\nstatic const gw_array gwm_arrays[] = {\n" + "\n".join(rows) + "\n};\n"
    return text, f"\n    .n_arrays = {len(arrays)},\n    .arrays = gwm_arrays,"


def write_model_desc(spec: ModelSpec, table: list[Variable], exp: Experiment, identifier: str,
                     guid: str, fns: dict[str, ca.Function], out_dir: Path,
                     taylor: TaylorKernel | str | None = None, unity: str = "gw_fmu.c") -> Path:
    """model_desc.c: the static GW_MODEL constant of c_src/gw_model.h (after gw_funcs.c in the
    unit `unity`: gw_fmu.c, or gw_fmu3.c in an FMI 3 FMU). Every row of `table` is a variable
    of the map, an FMI 3 event indicator's (kind "indicator") as GW_VAR_INDICATOR, its index
    the event's, except the FMI 3 array outputs (kind "array"): those are GW_MODEL.arrays, each
    element's index into x or y (_arrays_c)."""
    rows = sorted((v for v in table if v.kind != "array"), key=lambda v: v.vr)
    var_lines = []
    for v in rows:
        var_lines.append(
            f"    {{{v.vr}u, {_c_string(v.name)}, {TYPE[v.type]}, {KIND[v.kind]}, {v.index}, "
            f"{v.out_index}, {1 if v.quantity.tunable else 0}, {v.state_index}}},")
    slots = []
    for slot in SLOTS:
        if slot in fns:
            name = fns[slot].name()
            slots.append(f"    .{slot} = {{{name}, {name}_work}},")
        else:
            slots.append(f"    .{slot} = {{0, 0}},")
    n = {"nx": spec.x.numel(), "ns": spec.s.numel(), "nu": spec.u.numel(), "np": spec.p.numel(),
         "ny": len(spec.outputs), "ne": len(spec.events), "nc": len(spec.checks)}
    init_row = {v.vr: k for k, v in enumerate(initial_unknowns(table))} if "dini" in fns else {}
    init_rows = ", ".join(str(init_row.get(v.vr, -1)) for v in rows)
    arrays_c, arrays_slot = _arrays_c([v for v in table if v.kind == "array"])
    text = f"""/* Generated by gyrowheel from scene model {spec.name!r}; do not edit.
 * Part of the single translation unit {unity}, after {FUNCTION_FILE}.c. */
{UNITY_GUARD_OPEN}
#include "gw_model.h"

static const double gwm_s_start[] = {_c_doubles([q.start for q in spec.starts])};
static const double gwm_u_start[] = {_c_doubles([q.start for q in spec.inputs])};
static const double gwm_p_start[] = {_c_doubles([q.start for q in spec.parameters])};
static const char *const gwm_x_names[] = {_c_strings(spec.x_names)};
static const char *const gwm_event_names[] = {_c_strings([e.name for e in spec.events])};
static const int gwm_event_actions[] = {{{", ".join(EVENT_ACTION[e.action] for e in spec.events) or "0"}}};
static const char *const gwm_check_messages[] = {_c_strings([c.message for c in spec.checks])};
static const int gwm_init_rows[] = {{{init_rows or "-1"}}};

static const gw_variable gwm_vars[] = {{
{chr(10).join(var_lines)}
}};
{arrays_c}
static const gw_model GW_MODEL = {{
    .identifier = {_c_string(identifier)},
    .token = {_c_string(guid)},
    .nx = {n["nx"]}, .ns = {n["ns"]}, .nu = {n["nu"]}, .np = {n["np"]},
    .ny = {n["ny"]}, .ne = {n["ne"]}, .nc = {n["nc"]},
    .s_start = gwm_s_start, .u_start = gwm_u_start, .p_start = gwm_p_start,
    .n_vars = {len(rows)},
    .vars = gwm_vars,
{chr(10).join(slots)}
    .x_names = gwm_x_names,
    .event_names = gwm_event_names,
    .event_actions = gwm_event_actions,
    .check_messages = gwm_check_messages,
    .default_solver = {SOLVERS[exp.solver]},
    .default_rel_tol = {exp.rel_tol!r},
    .default_abs_tol = {exp.abs_tol!r},
    .default_max_step = {exp.max_step_in_force!r},
    .n_init_rows = {len(init_row)},
    .init_rows = gwm_init_rows,
    .default_max_internal_steps = {float(exp.max_internal_steps)!r},
    .fixed_step_caveat = {_c_string(spec.fixed_step_caveat) if spec.fixed_step_caveat else "0"},
    .n_pre = {fns["ode_pre"].numel_out(0) if "ode_pre" in fns else 0},
{_taylor_slot(taylor)}{arrays_slot}
}};

{UNITY_GUARD_CLOSE}"""
    path = out_dir / DESC_FILE
    path.write_text(text)
    return path
