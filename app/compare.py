"""Compare runs: a pinned run kept beside the current one (its metrics, the skeleton of its last iteration),
and the figures that put the two side by side."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from skelcore import provisional, report
from skelcore.params import ContractionParams

from .layout import CARD, PIN, PIN_AGAIN
from .words import METHOD_LABELS, PARAMETER_LABELS, assignments

RUN_COLOURS = ("#8a8a8a", "#d1342f")  # pinned, current


@dataclass
class Pinned:
    """A run kept for comparison: its metrics up to the pinned iteration and that iteration's skeleton."""
    run: object  # app.run.Run
    name: str
    summary: dict  # report.run_summary
    skeleton: tuple[np.ndarray, np.ndarray] | None  # nodes, edges; None before the cloud has contracted


def show_pin(viewers, pinned: Pinned | None) -> None:
    """Each viewer (app.viewer.Viewer) draws the pinned run's skeleton in green and offers to pin again; with
    nothing pinned (None), no green skeleton, the Pin button as at first, and a blank Compare tab."""
    skeleton = None if pinned is None else pinned.skeleton
    for viewer in viewers:
        viewer.view.show_ghost(*(skeleton or (None, None)))
        viewer.ui.plots.pin.label = PIN if pinned is None else PIN_AGAIN
        if pinned is None:
            viewer.clear_comparison()


def describe(state, role: str, history=()) -> str:
    """"pinned: LBC, W_H0 1, s_L 3, Termination 0.001, iteration 4": the method, W_H0 and s_L, and every other
    panel parameter the run set away from its default, so that two runs that differ are named apart; those of
    `state`'s step, and where the run's `history` (its states up to `state`) started with others, from which
    iteration they held ("... iteration 6, retuned at iteration 5")."""
    p = state.params
    default = ContractionParams(method=p.method)
    changed = [name for name in PARAMETER_LABELS
               if name not in ("method", "wh0", "sl") and getattr(p, name) != getattr(default, name)]
    retuned = [later.iteration for earlier, later in zip(history, history[1:]) if later.params != earlier.params]
    return (f"{role}: {METHOD_LABELS[p.method]}, {assignments(p, ['wh0', 'sl', *changed])}, iteration "
            f"{state.iteration}" + (f", retuned at iteration {retuned[-1]}" if retuned else ""))


def pin(session) -> Pinned:
    """The session's run as it stands (its newest iteration)."""
    index, run, state = len(session.history) - 1, session.run, session.latest
    metrics = session.metrics_upto(index, run)
    skeleton = None
    if not provisional.skeleton_is_provisional(state, provisional.state_curve_share(state, run.cloud)):
        found = session.skeleton(index, run)
        skeleton = (found.nodes_array(), found.edges_array())
    name = describe(state, "pinned", session.history[:index + 1])
    # the verdict the Histograms tab shows for it: with the skeleton's checks where it has a skeleton
    judged = skeleton is not None or (index, session.skeleton_params) in run.evidence
    verdict = session.verdict(index, run, with_skeleton=index > 0 and judged)
    return Pinned(run, name, report.run_summary(name, metrics, verdict), skeleton)


def comparison(pinned: Pinned, state, history, verdict: dict | None = None,
               states=()) -> tuple[str, object, object, object]:
    """Markdown naming both runs, the overlaid convergence curves, the last histograms of both (D_theta,
    delta_kappa); `history`: the current run's metrics up to the shown `state`; `verdict`: its verdict as the
    Histograms tab shows it (with the skeleton's checks once made; None: from the metrics alone); `states`: the
    current run's states up to `state` (to say when it was retuned; see `describe`)."""
    current = report.run_summary(describe(state, "current", states), history, verdict)
    runs = [pinned.summary, current]
    convergence = report.convergence_comparison_figure(runs, title="Convergence: pinned and current",
                                                       colours=RUN_COLOURS).update_layout(CARD)
    theta, kappa = (report.final_histograms_figure(runs, key, title=f"{key_name}, last iteration", colours=RUN_COLOURS)
                    .update_layout(CARD, xaxis_title=None, legend=dict(y=-0.13, yanchor="top"))  # the title names it
                    for key, key_name in (("d_theta", "D_theta"), ("delta_kappa", "delta_kappa")))
    return comparison_note(pinned, state, current["verdict"], states), convergence, theta, kappa


def comparison_note(pinned: Pinned, state, verdict: dict, states=()) -> str:
    """Markdown naming the pinned run and the current one at `state` (`states`: its run's up to it), each with its
    verdict, and whether the pinned run's skeleton is drawn."""
    ghost = ("the pinned skeleton is drawn in green" if pinned.skeleton is not None else
             "no pinned skeleton is drawn: the run was pinned before its skeleton was final")
    return (f"**{pinned.name}** (grey, {_verdict_phrase(pinned.summary['verdict'])}) against "
            f"**{describe(state, 'current', states)}** (red, {_verdict_phrase(verdict)}); {ghost}.")


def _verdict_phrase(verdict: dict) -> str:
    # iteration 0 is the input: the verdict has no label there
    return "no verdict yet" if verdict["label"] is None else f"verdict {verdict['label']}"
