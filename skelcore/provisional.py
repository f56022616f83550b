"""Whether a state's curve skeleton means anything yet: the curve-like share a contraction aims at, and the
words for a run that ended barely contracted. The inspector marks a skeleton provisional by them; a run's last
state is its result either way.
"""
from __future__ import annotations

from .contraction import IterationState
from .curveness import skeleton_scale_share
from .io import Cloud
from .params import ContractionParams
from .verdict import StabilityThresholds


def state_curve_share(state: IterationState, cloud: Cloud) -> float:
    """The share of a state's points that are curve-like (skelcore.curveness) at the skeleton's default sample
    radius, a fraction of the input cloud's object diagonal (the skeleton's own scale, which the
    contraction's stop rule, skelcore.stop_rules.goes_on, and the verdict also use)."""
    return skeleton_scale_share(state.points, cloud.diagonal)


def provisional_target(state: IterationState) -> float:
    """The curve-like share below which a state's skeleton is provisional: the share the contraction itself aims
    at (its params.curve_share; the owner's default when the run turned that aim off)."""
    return state.params.curve_share if state.params.curve_share > 0 else ContractionParams.curve_share


def skeleton_is_provisional(state: IterationState, share: float) -> bool:
    """True while the cloud is not curve-like enough for its curve skeleton to mean anything: fewer than
    provisional_target of its points are curve-like (`share`, from state_curve_share). Iteration 0 always is;
    a run's last state never is: its skeleton is the run's result."""
    if state.iteration == 0:
        return True
    return state.termination is None and share < provisional_target(state)


def barely_contracted(state: IterationState, share: float) -> str:
    """Why a run's last state is barely contracted, in a few words ("" when it is not, or `state` is not a run's
    last): the run stopped after fewer steps than a verdict needs to see a trend (StabilityThresholds.min_steps),
    or at the iteration limit with fewer than provisional_target of its points curve-like (`share`, from
    state_curve_share). A run that ends by its own rules is not: bulky shapes (blocks, a bunny, a mug) end their
    good runs well below the curve-like aim, on the ring-ratio rule or a rejected last step. Its skeleton is still
    the run's result (skeleton_is_provisional), so whoever shows it should say this."""
    if state.termination is None or state.iteration == 0:
        return ""
    target = provisional_target(state)
    steps = f"{state.iteration} step{'' if state.iteration == 1 else 's'}"
    if state.iteration < StabilityThresholds.min_steps:
        return f"stopped after {steps} with {share:.0%} of points curve-like ({target:.0%} aimed at)"
    if state.termination == "max_iterations" and share < target:
        return (f"stopped at the iteration limit after {steps} with {share:.0%} of points curve-like "
                f"({target:.0%} aimed at)")
    return ""
