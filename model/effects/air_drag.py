"""Air drag: a force on the centre and a torque on the spin.

F = -(c_lin + 1/2 rho_air cd_area |v|) v on the centre A (v its velocity);
tau = -1/2 rho_air cm_spin R^5 |w_z| w_z about the axle (w_z the axial rate).
|v| is sqrt(v . v + (1e-6 m/s)^2) so the force stays differentiable at rest. In flight the same
law acts on the free body's centre velocity and axial rate (AirDrag.law, model/flight.py).
"""
from __future__ import annotations

import casadi as ca

from gyrowheel.model.context import WheelContext
from gyrowheel.model.effects.base import Effect
from gyrowheel.model.kinematics import norm
from gyrowheel.model.spec import COEFFICIENT_MAX, Quantity


class AirDrag(Effect):
    name = "air_drag"
    summary = "linear + quadratic drag on the centre, quadratic drag torque on the spin"

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return [
            Quantity("rho_air", "kg/m3", "air density", 1.225, minimum=0.0, maximum=COEFFICIENT_MAX),
            Quantity("cd_area", "m2", "drag coefficient x frontal area", 0.02, minimum=0.0, maximum=COEFFICIENT_MAX),
            Quantity("c_lin", "N.s/m", "linear (viscous) drag coefficient", 0.0, minimum=0.0, maximum=COEFFICIENT_MAX),
            Quantity("cm_spin", "1", "spin drag moment coefficient", 0.01, minimum=0.0, maximum=COEFFICIENT_MAX),
        ]

    @staticmethod
    def law(p: dict, R: ca.SX):
        """The drag law as a function of (v_centre (3,), omega (3,), n (3,)), ground frame ->
        [(F (3,), v_centre), (tau, w_z)]: the force on the centre and the torque about the axle
        on the axial rate w_z = omega . n. The same law in contact and in flight (model/flight.py)."""
        def drag(v, omega, n):
            speed = ca.sqrt(ca.dot(v, v) + 1e-12)
            F = -(p["c_lin"] + 0.5 * p["rho_air"] * p["cd_area"] * speed) * v
            w_z = ca.dot(omega, n)
            tau = -0.5 * p["rho_air"] * p["cm_spin"] * R ** 5 * ca.fabs(w_z) * w_z
            return [(F, v), (tau, w_z)]
        return drag

    def apply(self, ctx: WheelContext) -> None:
        p = self.declare(ctx)
        drag = self.law(p, ctx.par["R"])
        (F, v), (tau, w_z) = drag(ctx.kin.centre_velocity, ctx.kin.omega, ctx.kin.n)
        ctx.force(F, v, "dissipative", point=True)
        ctx.force(tau, w_z, "dissipative")
        ctx.free_laws.append(drag)
        ctx.output(Quantity("drag_force", "N", "magnitude of the drag force on the centre (law with the smoothed "
                            "speed sqrt(v.v + (1e-6 m/s)^2))"), norm(F))
