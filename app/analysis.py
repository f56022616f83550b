"""What the inspector shows of one iteration besides its points: the histograms, the convergence plot and the
verdict, the per-point colours, the curve-like share that decides whether the skeleton is provisional.

Each is computed once per state of a run and kept for the few states browsers look at, so two browsers on
the same iteration share the work, and a figure is serialised once for all of them. The engine computes;
this only asks (app.session, skelcore.pipeline, skelcore.report, skelcore.display) and keeps.
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from skelcore import display, provisional, report

from .colours import COLOUR_RANGES, colour_values
from .layout import CARD
from .run import Run
from .session import Session

KEPT = 16  # states whose plots and colours are kept (browsers look at a few iterations at a time)


@dataclass(frozen=True)
class Plots:
    """The figures of one state (D_theta histogram, delta_kappa histogram, convergence) and their JSON."""
    figures: tuple
    json: tuple[str, ...]


@dataclass(frozen=True)
class Colours:
    contracted: np.ndarray | None  # (m,3) uint8, None: plain
    original: np.ndarray | None  # colours of the original positions, when asked for
    note: str  # what the legend says about them


@dataclass(frozen=True)
class Readiness:
    """Whether a state's skeleton means something yet, and why not."""
    share: float  # of the points, curve-like (skelcore.provisional.state_curve_share)
    provisional: bool
    barely_contracted: str  # why a run's last state is, in words; "" when it is not (skelcore.provisional)

    def reason(self, state) -> str:
        """The legend's words for a provisional skeleton ("" when it is not)."""
        if not self.provisional:
            return ""
        if state.iteration == 0:  # drawn in the colour the Legend names "contracted": it says what they are
            return "iteration 0 is the input itself, drawn as the contracted points"
        return f"{self.share:.0%} of points curve-like, {provisional.provisional_target(state):.0%} needed"


class Analyses:
    def __init__(self, session: Session):
        self.session = session
        self._lock = threading.Lock()
        self._kept: OrderedDict = OrderedDict()
        self._run: Run | None = None  # whose results are kept: a new run drops the old one's

    def _cached(self, run: Run, key, compute):
        with self._lock:
            if run is not self._run:
                self._kept.clear()
                self._run = run
            if key in self._kept:
                self._kept.move_to_end(key)
                return self._kept[key]
        value = compute()
        with self._lock:
            if run is not self._run or value is None:  # a new run began meanwhile
                return value
            self._kept[key] = value
            while len(self._kept) > KEPT * 4:
                self._kept.popitem(last=False)
        return value

    def readiness(self, run: Run, index: int, compute: bool = True) -> Readiness | None:
        """compute=False: None unless already known (the status does not wait for it)."""
        state = run.state(index)

        def compute() -> Readiness:
            share = provisional.state_curve_share(state, run.cloud)
            return Readiness(share, provisional.skeleton_is_provisional(state, share),
                             provisional.barely_contracted(state, share))
        # a run's last state is never provisional: a step rejected at the end replaces its state with the ended one
        return self._cached(run, ("readiness", index, state.termination), compute if compute else lambda: None)

    def plots(self, run: Run, index: int) -> Plots:
        """The figures of history[index], or of the state computed ahead (index len(history)): its histograms, and
        the convergence of the run so far with that iteration marked (scrubbed back, the later ones are still
        shown). Keyed by the state's parameters too (a state ahead computed again with others is another state;
        the same parameters give the same state) and by the last iteration plotted, which the state ahead shares
        with the newest state it becomes."""
        state = run.state(index)
        last = max(index, len(run.history) - 1)

        def compute() -> Plots:
            history = self.session.metrics_upto(last, run)
            histograms = [_compact(report.histogram_figure(history[index], measure, iteration=state.iteration,
                                                           fit=True, of_points=len(run.cloud.points)))
                          for measure in ("d_theta", "delta_kappa")]
            convergence = report.convergence_figure(history, shown=state.iteration if index < last else None)
            figures = (*histograms, convergence.update_layout(CARD, height=None))
            return Plots(figures, tuple(figure.to_json() for figure in figures))
        return self._cached(run, ("plots", index, state.params, last), compute)

    def colours(self, run: Run, index: int, quantity: str, on_original: bool) -> Colours:
        """Colours of one of COLOUR_RANGES' quantities, for every point (the sample's values carried to the
        rest, which the note says)."""
        state = run.state(index)

        def compute() -> Colours:
            measured = self.session.metrics(index, run)
            values = display.values_for_all_points(measured, state.points, report.measure_key(quantity))
            note = (f"{values.measured:,} points measured; the other {values.carried:,} show the value of their "
                    f"nearest measured point" if values.carried else "")
            original = None
            if on_original:
                per_input = np.full(len(run.cloud.points), np.nan)
                per_input[state.point_ids] = values.values
                original = colour_values(per_input, quantity)
            return Colours(colour_values(values.values, quantity), original, note)
        assert quantity in COLOUR_RANGES
        return self._cached(run, ("colours", index, state.params, quantity, on_original), compute)


def _compact(histogram):
    """A histogram for the narrow plots panel: its title names the measure, so the axis title goes and the
    legend takes its place below the ticks."""
    return histogram.update_layout(CARD, height=None, margin=dict(l=45, r=10, t=55, b=40), xaxis_title=None,
                                   legend=dict(y=-0.13, yanchor="top"))
