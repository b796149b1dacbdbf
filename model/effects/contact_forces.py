"""Contact forces by back-substitution (Kelly's "complete" formulation).

The ground force on the system follows from Newton's law for all bodies once the
accelerations are known: F = sum(m_i a_i) - sum(m_i) g - (forces of the air).
Outputs: normal force F_n, longitudinal F_long (along the heading (cos a, sin a)),
lateral F_lat (in the ground plane, to the left of the heading), and the friction use
|F_t| / F_n (-1 while F_n <= 0: friction is undefined off the ground).
Events: lift-off (F_n reaches 0) and slip (|F_t| reaches mu F_n), each "terminate",
"warn" or "ignore" (no event, no flag); rolling without slip and point contact stop being
valid there. A load-proportional law cannot go on past lift-off: with one, on_lift_off must be
"terminate" or "fly" (gyrowheel.model.effects.lift_off_conflict; the scene reader refuses the others).
on_slip = "slide": the wheel slides past the slip instead (model/contact_modes.py): a second contact
mode with Coulomb friction mu_k F_n at the contact, the switches located state events; start values
slip_long, slip_lat; outputs contact_mode, slip_long, slip_lat.
on_lift_off = "fly" (with on_slip = "slide" only: a landing wheel may slide): the wheel leaves the
ground where F_n reaches 0 and lands with an impact (model/contact_flight.py); parameter
restitution, start values height, vz; outputs height, vz, impact_impulse.
"""
from __future__ import annotations

import casadi as ca

from gyrowheel.model.contact_flight import declare_flight, flight_starts
from gyrowheel.model.contact_modes import declare_sliding
from gyrowheel.model.context import WheelContext
from gyrowheel.model.effects.base import Effect
from gyrowheel.model.kinematics import norm
from gyrowheel.model.spec import SPEED_OF_LIGHT, Quantity

ACTIONS = ("terminate", "warn", "ignore", "fly")
SLIP_ACTIONS = ("warn", "terminate", "ignore", "slide")


class ContactForces(Effect):
    name = "contact_forces"
    summary = "normal, longitudinal, lateral contact force and friction use; lift-off and slip events"

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return [Quantity("mu", "1", "friction coefficient for the slip check", 0.8, minimum=0.0),
                Quantity("mu_k", "1", "kinetic friction coefficient while sliding (on_slip = \"slide\"; "
                         "start value: the scene's mu when not given; <= mu)", 0.8, minimum=0.0),
                Quantity("restitution", "1", "coefficient of restitution at touchdown (on_lift_off = \"fly\"): "
                         "normal rebound speed / impact speed of a frictionless touchdown (the damping of the "
                         "touchdown's spring-damper contact, in its rigid limit)", 0.0, minimum=0.0, maximum=1.0)]

    @classmethod
    def starts(cls) -> list[Quantity]:
        return [Quantity("slip_long", "m/s", "slip velocity of the contact point along the heading", 0.0,
                         minimum=-SPEED_OF_LIGHT, maximum=SPEED_OF_LIGHT),
                Quantity("slip_lat", "m/s", "slip velocity of the contact point across the heading (left)", 0.0,
                         minimum=-SPEED_OF_LIGHT, maximum=SPEED_OF_LIGHT),
                *flight_starts()]

    @classmethod
    def choices(cls) -> dict[str, tuple[str, ...]]:
        return {"on_lift_off": ACTIONS, "on_slip": SLIP_ACTIONS}

    @classmethod
    def option_conflict(cls, options: dict) -> tuple[str, str] | None:
        """mu_k belongs to the sliding mode and may not exceed mu."""
        slide = options.get("on_slip") == "slide"
        if "mu_k" in options and not slide:
            return "mu_k", 'is the kinetic friction of on_slip = "slide"; remove it or set on_slip = "slide"'
        fly = options.get("on_lift_off") == "fly"
        if fly and not slide:
            return "on_lift_off", '"fly" needs on_slip = "slide" (a wheel that lands may slide)'
        if "restitution" in options and not fly:
            return "restitution", ('is the touchdown\'s restitution of on_lift_off = "fly"; remove it or set '
                                   'on_lift_off = "fly" (with on_slip = "slide")')
        if slide and options.get("on_lift_off", ACTIONS[0]) not in ("terminate", "fly"):
            return "on_lift_off", ('must be "terminate" or "fly" with on_slip = "slide": sliding friction, '
                                   'proportional to the normal force, would push once F_n < 0')
        mu = options.get("mu", cls.parameters()[0].start)
        if slide and options.get("mu_k", mu) > mu:
            where = "the scene's" if "mu" in options else "the default"
            return "mu_k", (f"must be <= mu (kinetic friction does not exceed static), got mu_k = {options['mu_k']!r} "
                            f"> mu = {mu!r} ({where})")
        return None

    def apply(self, ctx: WheelContext) -> None:
        slip = self.choice("on_slip")
        if slip == "ignore":  # mu is used by the slip check only
            self.options["_no_mu"] = True
        if slip != "slide":
            self.options["_no_mu_k"] = True
        elif "mu_k" not in self.options:  # mu_k defaults to the scene's mu
            self.options["mu_k"] = self.options.get("mu", self.parameters()[0].start)
        lift = self.choice("on_lift_off")
        if lift != "fly":
            self.options["_no_restitution"] = True
        p = self.declare(ctx)
        F = ctx.Fc
        a = ctx.q[2]
        F_n = F[2]
        F_long = F[0] * ca.cos(a) + F[1] * ca.sin(a)
        F_lat = -F[0] * ca.sin(a) + F[1] * ca.cos(a)
        F_t = norm(ca.vertcat(F_long, F_lat))  # derivative defined at F_t = 0 (kinematics.norm)
        ctx.output(Quantity("F_n", "N", "normal contact force (ground on wheel)"), F_n)
        ctx.output(Quantity("F_long", "N", "contact force along the heading"), F_long)
        ctx.output(Quantity("F_lat", "N", "contact force across the heading (to the left)"), F_lat)
        ctx.output(Quantity("friction_use", "1", "|F_t| / F_n, the friction coefficient needed (-1: F_n <= 0)"),
                   ca.if_else(F_n > 0, F_t / F_n, -1))
        if lift not in ("ignore", "fly"):
            ctx.events.append(("lift_off", F_n, lift,
                               Quantity("lifted_off", "", "true once the normal force has reached zero")))
        if slip == "slide":
            # only where mu passes its own range: each refusal once
            ctx.check_true(ca.logic_or(p["mu"] < 0, p["mu_k"] <= p["mu"]),
                           "mu_k must be <= mu (kinetic friction does not exceed static)")
            declare_sliding(ctx, p["mu"], p["mu_k"])
            if lift == "fly":
                declare_flight(ctx, p["restitution"])
        elif slip != "ignore":
            ctx.events.append(("slip", p["mu"] * F_n - F_t, slip,
                               Quantity("slipping", "", "true once the friction needed has exceeded mu")))
