"""scipy's DOP853 on a ModelSpec with its update events (the mode switches of stiction laws).

A reference for the runtime's integration and event handling, not for the model: the same generated
functions (ode, evt, upd), but scipy's integrator, dense output and root finder (used by
tests/test_hard_dynamics.py and examples/hard_cases.py). Every event with
action "update" is a terminal scipy event (direction -1); at its located time the state becomes
upd(t, x, u, p, k) and the integration restarts there. scipy's root may lie a hair before the
crossing (indicator still > 0); the point is then moved forward until the indicator is <= 0, as
the runtime takes the right end of its final bracket. `stop(t, x)` (optional) ends the run when it
goes from > 0 to <= 0, e.g. the fall.

API: ``solve_hybrid(spec, x0, p, t_end, u=(), stop=None, rtol=1e-12, atol=1e-14)
-> (t_stop or None, x at the end, [(t, event name)] switches)``.
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def solve_hybrid(spec, x0, p, t_end: float, u=(), stop=None, rtol: float = 1e-12, atol: float = 1e-14):
    fns = spec.functions()
    updates = [k for k, ev in enumerate(spec.events) if ev.action == "update"]

    def rhs(t, x):
        return np.array(fns["ode"](t, x, u, p)).ravel()

    def indicator(k):
        def g(t, x):
            return float(fns["evt"](t, x, u, p)[k])
        g.terminal, g.direction = True, -1
        return g

    events = [indicator(k) for k in updates]
    if stop is not None:
        def g_stop(t, x):
            return stop(t, x)
        g_stop.terminal, g_stop.direction = True, -1
        events.append(g_stop)
    t, x, switches = 0.0, np.asarray(x0, float), []
    while t < t_end:
        sol = solve_ivp(rhs, (t, t_end), x, method="DOP853", rtol=rtol, atol=atol, events=events)
        assert sol.status >= 0, sol.message
        if sol.status == 0:
            return None, sol.y[:, -1], switches
        fired = next(i for i, te in enumerate(sol.t_events) if len(te))
        t, x = float(sol.t_events[fired][0]), sol.y_events[fired][0]
        if stop is not None and fired == len(events) - 1:
            return t, x, switches
        k = updates[fired]
        step = 1e-15 * max(1.0, abs(t))
        while events[fired](t, x) > 0.0:  # onto the crossing's far side, as the runtime locates it
            x = solve_ivp(rhs, (t, t + step), x, method="DOP853", rtol=rtol, atol=atol).y[:, -1]
            t, step = t + step, 2 * step
        x = np.array(fns["upd"](t, x, u, p, k)).ravel()
        switches.append((t, spec.events[k].name))
    return None, x, switches
