"""scipy's DOP853 with its own event location (studies/scipy_reference.py) on the CasADi model of
a set of effects, from start values, until lift-off: the reference of the stiction tests whose
wheel breaks away and lifts off."""
from __future__ import annotations

import numpy as np

from gyrowheel.model.build import build_model
from gyrowheel.studies.scipy_reference import solve_hybrid


def to_lift_off(effects: dict, start: dict, t_end: float):
    """(t_lift or None, x at the end, [(t, event name)] switches) at rtol 1e-12, atol 1e-14."""
    spec = build_model(effects=effects)
    fns = spec.functions()
    p = np.array([start.get(q.name, q.start) for q in spec.parameters])
    x0 = np.array(fns["init"]([start.get(q.name, q.start) for q in spec.starts], p)).ravel()
    lift = [e.name for e in spec.events].index("lift_off")
    return solve_hybrid(spec, x0, p, t_end, stop=lambda t, x: float(fns["evt"](t, x, [], p)[lift]),
                        rtol=1e-12, atol=1e-14)
