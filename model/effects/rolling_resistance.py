"""Rolling resistance: energy lost per metre of rim rolled over the ground, proportional to the load.

The rim advances over the ground at the rate gamma_dot (the spin relative to the
frame {l, m, n} whose l points at the contact): the contact point moves R gamma_dot
along the rim. The resistance dissipates c_rr F_n per metre rolled, so its power is
-c_rr F_n R |gamma_dot| and its generalised force acts on gamma, at most c_rr R F_n.
In straight rolling this is the familiar force c_rr F_n at the contact (torque c_rr R F_n).
A couple about the axle would instead act on omega . n = gamma_dot + alpha_dot cos(beta),
which vanishes for a wheel spinning on a fixed centre (Euler's disk) although its rim rolls.
F_n is solved together with the accelerations (it depends on them). Two laws (scene key `law`):
- "stiction" (default): Coulomb with true stiction (model/stiction.py): Q_gamma =
  -c_rr R F_n sign(gamma_dot) while rolling; when gamma_dot reaches 0 and the torque needed to
  hold the rim is within c_rr R F_n, the rim sticks (gamma_dot = 0 exactly, the holding torque
  solved with the accelerations) until that torque exceeds the limit. A wheel on a slope
  gentler than atan(c_rr) stands still.
- "smoothed": Q_gamma = -c_rr R F_n tanh(gamma_dot / rr_omega_eps), viscous below
  rr_omega_eps: cheaper, no events, but it never sticks (a wheel on such a slope creeps at
  R rr_omega_eps atanh(tan(slope) / c_rr)).
"""
from __future__ import annotations

from gyrowheel.model.context import WheelContext
from gyrowheel.model.effects.coulomb import CoulombLaw
from gyrowheel.model.spec import Quantity


class RollingResistance(CoulombLaw):
    name = "rolling_resistance"
    uses_normal_load = True
    smoothing = "rr_omega_eps"
    summary = "resistance c_rr F_n to the rolling of the rim, with true stiction (power -c_rr F_n R |gamma_dot|)"

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return [
            Quantity("c_rr", "1", "rolling-resistance coefficient (force / normal load)", 0.01, minimum=0.0),
            Quantity("rr_omega_eps", "rad/s", "law smoothed: rolling rate below which the resistance fades (tanh)",
                     0.01, minimum=1e-9),
        ]

    def apply(self, ctx: WheelContext) -> None:
        p = self.declare(ctx)
        gamma_dot = ctx.qd[4]
        tau = self.coulomb(ctx, p, "rolling", gamma_dot, p["c_rr"] * ctx.par["R"] * ctx.Fn, "rolling resistance")
        ctx.force(tau, gamma_dot, "dissipative")
        ctx.output(Quantity("rolling_resistance_torque", "N.m",
                            "generalised force on the spin coordinate gamma (N.m per rad), not a torque about an "
                            "axis; the holding force while stuck"), tau)
