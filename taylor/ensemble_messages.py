"""The words of an ensemble run's messages (gyrowheel.taylor.ensemble.Ensemble.run): the FMU's
messages per trajectory, with the advice a run of the ensemble can follow."""
from __future__ import annotations

# the advice of the runtime's budget messages (c_src/gw_budget.c) names what an FMU's user
# sets; a run of the ensemble sets the communication steps through its grid, not the budget
BUDGET_ADVICE = (
    ("raise max_internal_steps or max_step, or shorten the communication step",
     "raise max_step, or shorten the communication steps: give run() a grid (the budget of "
     "max_internal_steps is per communication step; without a grid the run from t_start to t_end "
     "is one step)"),
    ("shorten the communication step or raise max_internal_steps",
     "shorten the communication steps: give run() a grid (the budget of max_internal_steps is per "
     "communication step; without a grid the run from t_start to t_end is one step), or a shorter "
     "t_end"),
    (" or stiff (try solver rosenbrock)", " or stiff (then simulate the FMU with solver rosenbrock: the "
     "ensemble runs solver taylor)"),
)


# solver taylor's series overflowing on a time scale below the smallest step (the FMU's message
# says "too stiff for an explicit method"): what simulate adds to it (gyrowheel.simulation's
# STIFF_NOTE), for a run that only has solver taylor
STIFF_ADVICE = ("; values this stiff (e.g. strong damping on a light wheel) need an implicit solver: simulate "
                "the FMU with solver rosenbrock (L-stable), or sweep it with --solver rosenbrock "
                "(the ensemble runs solver taylor only; docs/interface.md, \"Valid ranges\")")


def advice(message: str) -> str:
    """A trajectory's message with the budget's advice in the words of Ensemble.run, and the
    stiffness advice (STIFF_ADVICE) where the series overflowed on a too short time scale."""
    for fmu_words, run_words in BUDGET_ADVICE:
        message = message.replace(fmu_words, run_words)
    if "too stiff for an explicit method" in message and STIFF_ADVICE not in message:
        message += STIFF_ADVICE
    return message


def named_as_given(messages: list[str], in_degrees: dict[str, str]) -> list[str]:
    """The trajectories' messages with each start value given in degrees named as the caller gave
    it: in_degrees maps the start (beta) to the name given (beta_deg); the runtime names the
    state's start in radians ("start value beta is not finite (inf)")."""
    for name, given in in_degrees.items():
        said = f"start value {name} is not finite"
        messages = [m.replace(said, f"start value {name} (given as {given}) is not finite") for m in messages]
    return messages
