"""Energy and diagnostics outputs: kinetic, potential, dissipated, actuator work, contact point.

dissipated_energy integrates the power of every dissipative effect (a state of its
own), actuator_work that of the Gyrover motors, so that
energy(t) + dissipated_energy(t) - actuator_work(t) = energy(0).
"""
from __future__ import annotations

from gyrowheel.model.context import WheelContext
from gyrowheel.model.effects.base import Effect
from gyrowheel.model.spec import Quantity


class Energy(Effect):
    name = "energy"
    summary = "kinetic, potential, dissipated energy and power, actuator work, contact-point position"

    def apply(self, ctx: WheelContext) -> None:
        late = ctx.late
        ctx.output(Quantity("kinetic_energy", "J", "kinetic energy T"), late["T"])
        ctx.output(Quantity("potential_energy", "J", "potential energy V"), late["V"])
        kinds = {f.kind for f in ctx.forces}
        if "dissipative" in kinds:
            ctx.output(Quantity("dissipated_power", "W", "power lost to dissipative effects (>= 0)"), late["P_diss"])
            st = ctx.state(Quantity("dissipated_energy", "J", "energy lost to dissipative effects since the start",
                                    0.0))
            st.derivative, st.nominal = late["P_diss"], ctx.energy_scale()
        if "actuator" in kinds:
            ctx.output(Quantity("actuator_power", "W", "power delivered by the actuators"), late["P_act"])
            st = ctx.state(Quantity("actuator_work", "J", "work done by the actuators since the start", 0.0))
            st.derivative, st.nominal = late["P_act"], ctx.energy_scale()
        ctx.output(Quantity("contact_x", "m", "contact point x"), ctx.kin.contact[0])
        ctx.output(Quantity("contact_y", "m", "contact point y"), ctx.kin.contact[1])
