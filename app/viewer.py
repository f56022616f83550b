"""One browser's view of the shared run: the iteration it shows, whether it follows the newest, and what it
draws of that iteration (its own 3-D scene, status, plots and legend).

A viewer follows the newest iteration until its person scrubs back (slider, keys J/K); it then stays there
while the run goes on, until the slider reaches the end again or Follow newest (key L) is ticked. The
scene's view settings (layers shown, sizes, opacities) are the shared View tab's, copied in at connect.
"""
from __future__ import annotations

import html
import warnings

import viser

from skelcore.verdict import explanation_markdown, failed_criteria

from . import layout
from .analysis import Plots
from .scene import SceneView
from .status import verdict_headline

# What viser says when an update reaches a browser that closed while its view was being brought up to date (the
# analysis and skeleton threads work on what each viewer shows): the update is dropped, which is all there is to do.
CLOSED_BROWSER = "Queued a GuiUpdateMessage on a closed connection"


def quiet_closed_browsers() -> None:
    """No warning for an update that reaches a browser just closed (CLOSED_BROWSER)."""
    warnings.filterwarnings("ignore", message=CLOSED_BROWSER, category=UserWarning)


# viser's markdown tables draw their cells unpadded: "100.0%" ran into "at least 90%"
VERDICT_STYLE = "<style>.verdict th, .verdict td { padding: 0 4px; }</style>"
# The headline never takes a third line, whatever the browser's font (status.HEADLINE_CHARS keeps it to two in
# ours): one more pushed the histograms past a 720 px window. Cut short, it ends in an ellipsis and its hover says it
HEADLINE_STYLE = ("<style>.headline p { display: -webkit-box; -webkit-line-clamp: 2; -webkit-box-orient: vertical;"
                  " overflow: hidden; }</style>")


class Viewer:
    def __init__(self, client: viser.ClientHandle, order: float, notes_order: float,
                 settings: dict[str, dict] | None = None):
        """order: where the viewer's run widgets go (layout.RunControls.viewer_order), notes_order: its notes on the
        cloud (layout.Layout.notes_order); settings: the View tab's {"visible"|"sizes"|"opacity": {layer: value}}
        this viewer starts with."""
        self.client = client
        self.ui = layout.build_viewer(client.gui, order, notes_order)
        self._zero_mark = self.ui.timeline._marks  # viser's marks are set at creation (a private prop after it)
        self.view = SceneView(client.scene)
        if settings is not None:
            for name in ("visible", "sizes", "opacity"):
                getattr(self.view, name).update(settings[name])
        self.shown = 0  # index into the run's history of the iteration on screen
        self.following = True
        self.closed = False
        self.drawn: dict[str, tuple] = {}  # stage -> (run, index) of its last push

    @property
    def id(self) -> int:
        return self.client.client_id

    def showing(self, run, index: int) -> bool:
        """Whether history[index] of `run` is still what this viewer shows (an analysis may land late)."""
        return not self.closed and self.drawn.get("points", (None, None)) == (run, index)

    def look_at(self, index: int, newest: int) -> None:
        """Take the person's choice of iteration: the newest follows the run, an earlier one stays."""
        self.follow(index >= newest)

    def follow(self, following: bool) -> None:
        self.following = following
        self.ui.follow.value = following

    def set_timeline(self, count: int, index: int) -> None:
        timeline = self.ui.timeline
        timeline.max = max(1, count - 1)
        timeline.value = index
        timeline.disabled = count < 2
        # with one iteration the slider still spans 0..1 (viser's needs max > min): mark only the 0, not an end at 1
        timeline._marks = self._zero_mark if count < 2 else None  # None: viser marks both ends

    def show_plots(self, plots: Plots, verdict: dict, hint: str = "") -> None:
        """The histograms and the convergence plot (serialised once, shared by every viewer), the verdict (and
        `hint`, see show_verdict)."""
        handles = (self.ui.plots.hist_theta, self.ui.plots.hist_kappa, self.ui.plots.convergence)
        for handle, figure, text in zip(handles, plots.figures, plots.json):
            handle._figure = figure
            handle._plotly_json_str = text  # viser's figure setter would serialise it again for each viewer
        self.show_verdict(verdict, hint)

    def show_verdict(self, verdict: dict, hint: str = "") -> None:
        """The explanation table in the Verdict tab, its headline above the histograms, `hint` after it (what to
        try, app.status.hold_inside_hint)."""
        table = explanation_markdown(verdict)
        head, _, rest = table.partition("\n")
        shown = f"{head}\n\n**{hint}**\n{rest}" if hint else table  # the tab says it under its title too
        self.ui.plots.verdict.content = f'{VERDICT_STYLE}<div class="verdict">\n\n{shown}\n\n</div>'
        names = [c["name"] for c in failed_criteria(verdict)]
        whole = " · ".join(filter(None, [head.replace("**", ""), names and f"failed: {', '.join(names)}", hint]))
        self.ui.plots.verdict_line.content = (f'{HEADLINE_STYLE}<div class="headline" title="{html.escape(whole)}">'
                                              f'\n\n{verdict_headline(head, names, hint)}\n\n</div>')

    def show_comparison(self, note: str, convergence, theta, kappa, shown: bool = True) -> None:
        plots = self.ui.plots
        plots.compare_note.content = note
        plots.compare_convergence.figure, plots.compare_theta.figure, plots.compare_kappa.figure = (
            convergence, theta, kappa)
        plots.show_compare_plots(shown)

    def clear_comparison(self) -> None:
        """The Compare tab as it is before any pin: the hint, no plots."""
        self.show_comparison(layout.COMPARE_HINT, *(layout.empty_plot(title) for title in layout.COMPARE_TITLES),
                             shown=False)

    def close(self) -> None:
        self.closed = True
