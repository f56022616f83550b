"""What each browser sees of the shared run: its Viewer's points, status, legend, plots, colours and skeleton
of the iteration it shows, each pushed as soon as it is ready.

The points and the status go out at once, from the thread that asks (the engine worker). The plots,
verdict and colours follow from an analysis thread, the skeleton from a skeleton thread; each thread
works, for each viewer, on the newest thing it asked for (app.worker.Latest), and app.analysis keeps the
results so viewers on one iteration share them. A result that lands after its viewer moved on is dropped.
"""
from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np

from skelcore import display
from skelcore.formats import Y_UP_FORMATS
from skelcore.skeleton import beyond_solid_notes

from . import compare, layout, status
from .analysis import Analyses
from .colours import COLOUR_RANGES
from .labels import LabelPanel
from .layout import Layout
from .playback import Playback
from .progress import Activity
from .scene import INITIAL_DIRECTION, fit_client_camera, frame_camera
from .session import Session
from .viewer import Viewer
from .worker import ErrorHandler, Latest, Worker

LOG_LINES = 8  # of the session log, in the Log tab


class Presenter:
    def __init__(self, session: Session, ui: Layout, activity: Activity, worker: Worker, on_error: ErrorHandler,
                 server=None, playback: Playback | None = None):
        """server: the viser server whose scene's up the View tab's Up axis sets (None: tests without one);
        playback: whether a person paused the run (None: tests without one)."""
        self.session, self.ui, self.activity, self.worker, self.server = session, ui, activity, worker, server
        self.playback = playback
        # the up axis a person chose last: a cloud whose format fixes none opens with it
        self._chosen_up = display.DEFAULT_UP
        self.labels: LabelPanel | None = None  # set once built (it needs the worker)
        self.viewers: dict[int, Viewer] = {}  # by client id
        self.colour_by = "plain"
        self.colour_original = False
        self.pinned: compare.Pinned | None = None
        self.drawn: dict[str, tuple] = {}  # stage -> (run, index, perf_counter) of its last push, any viewer
        self._drawn_changed = threading.Condition()
        # Status updates come from every thread (the worker, the analysis threads, each busy block's start and end):
        # reading the run's state and pushing its words happen under one lock, so that an update read earlier
        # is never pushed after a later one (a finished job's "busy" would stay on screen)
        self._status_lock = threading.RLock()
        self.analyses = Analyses(session)
        self.analyst = Latest(self._analyse, on_error)
        self.skeletons = Latest(self._draw_skeleton, on_error)

    def wait_idle(self, timeout: float | None = None) -> bool:
        return self.analyst.wait_idle(timeout) and self.skeletons.wait_idle(timeout)

    def close(self) -> None:
        self.analyst.close()
        self.skeletons.close()

    def viewer(self, client) -> Viewer | None:
        return None if client is None else self.viewers.get(client.client_id)

    def all(self) -> list[Viewer]:
        return list(self.viewers.values())

    def view_settings(self) -> dict[str, dict]:
        v = self.ui.view
        return {"visible": {layer: bool(v.show[layer].value) for layer in layout.LAYERS},
                "sizes": {layer: float(v.size[layer].value) for layer in layout.LAYERS},
                "opacity": {layer: float(v.opacity[layer].value) for layer in layout.LAYERS}}

    def set_fixed_colours(self, viewer: Viewer, run, index: int) -> None:
        """Colours that need no metrics: plain, or by label."""
        colours = self.labels.colours(run.history[index].point_ids) if self.colour_by == "label" else None
        viewer.view.set_colours((run, index), colours, self.colour_by)

    def show(self, viewer: Viewer, index: int, full: bool = True) -> None:
        """Draw history[index] in one viewer: the points and the status now; plots, colours and skeleton follow
        from the analysis threads (full=False: points only, as Run to end does on its way)."""
        session = self.session
        index = max(0, min(index, len(session.history) - 1))
        run, state = session.run, session.history[index]
        viewer.shown = index
        client = viewer.client
        with client.atomic():
            viewer.view.show_points((run, index), state.points)
            viewer.view.show_removed((run, index), session.cloud.points[state.removed_ids])
            if self.colour_by not in COLOUR_RANGES:
                self.set_fixed_colours(viewer, run, index)
            if viewer.view.skeleton_drawn:
                viewer.view.clear_skeleton()  # another iteration's skeleton would mislead
            self.update_status(viewer)
        client.flush()
        self.mark("points", viewer, run, index)
        if full:
            self.analyst.request((viewer, run, index), client, key=viewer.id)
            self.skeletons.request((viewer, run, index), client, key=viewer.id)

    def _skeleton_wanted(self, viewer: Viewer, readiness) -> bool:
        """Whether a viewer draws the skeleton of a state of this readiness: shown, and final or provisional
        ones asked for."""
        return viewer.view.visible["skeleton"] and (not readiness.provisional or self.ui.view.provisional.value)

    def draw_frame(self, viewer: Viewer, run, index: int) -> None:
        """history[index] drawn at once in one viewer as its view settings draw it (colours of that iteration,
        skeleton when wanted): what `show` and the analysis threads draw in turn, for a frame of an animation."""
        state = run.history[index]
        colours = (self.analyses.colours(run, index, self.colour_by, self.colour_original)
                   if self.colour_by in COLOUR_RANGES else None)
        readiness = self.analyses.readiness(run, index)
        wanted = self._skeleton_wanted(viewer, readiness)
        skeleton = self.session.skeleton(index, run) if wanted else None
        with viewer.client.atomic():
            viewer.view.show_points((run, index), state.points)
            viewer.view.show_removed((run, index), run.cloud.points[state.removed_ids])
            if colours is None:
                self.set_fixed_colours(viewer, run, index)
            else:
                viewer.view.set_colours((run, index), colours.contracted, self.colour_by, colours.original)
            if skeleton is None:
                viewer.view.clear_skeleton()
            else:
                viewer.view.show_skeleton(skeleton.nodes_array(), skeleton.edges_array(), skeleton.degrees(),
                                          readiness.provisional)
        viewer.client.flush()

    def picture_notes(self, viewer: Viewer, run, index: int) -> list[str]:
        """What a picture of run.history[index] in a viewer says of the skeletons drawn: why its own is
        provisional, when it draws a provisional one, and which run the pinned one in green is."""
        readiness = self.analyses.readiness(run, index)
        notes = []
        if readiness.provisional and self._skeleton_wanted(viewer, readiness):
            notes.append(f"skeleton provisional: {readiness.reason(run.history[index])}")
        pinned = self.pinned
        if pinned is not None and pinned.skeleton is not None:  # drawn with every frame (Viewer.show_ghost)
            notes.append(f"in green, {pinned.name}")
        return notes

    def prepare_ahead(self) -> None:
        """The plots of the state computed ahead (Session.look_ahead), so that Step pushes them at once."""
        run = self.session.run
        ahead = run.ahead
        if ahead is not None and ahead.iteration > run.history[-1].iteration:
            self.analyses.plots(run, len(run.history))

    def reanalyse(self) -> None:
        for viewer in self.all():
            if "points" in viewer.drawn:
                run, index = viewer.drawn["points"]
                self.analyst.request((viewer, run, index), viewer.client, key=viewer.id)
                self.skeletons.request((viewer, run, index), viewer.client, key=viewer.id)

    # ------------------------------------------------------------------ analysis threads
    def _plots_wanted(self, viewer: Viewer, run, index: int, points: tuple | None) -> bool:
        """Whether the plots of history[index], just computed, still go to a viewer whose points show `points`
        ((run, index) of viewer.drawn): they show that state, or the viewer follows a playing run past it and its
        plots are older. When a computation outlasts an iteration, waiting for the state shown would leave the
        plots behind until the run stops; the newest ready ones trail the points by one computation at most."""
        if viewer.closed or points is None or points[0] is not run:
            return False
        plots = viewer.drawn.get("plots")
        return points[1] == index or (self.worker.playing and viewer.following and points[1] > index
                                      and (plots is None or plots[0] is not run or plots[1] < index))

    def _analyse(self, request) -> None:
        """Plots, verdict and colours of what a viewer shows."""
        viewer, run, index = request
        if not viewer.showing(run, index):  # it shows a later state, whose request is waiting
            return
        state, session = run.history[index], self.session
        with self.activity.busy(None, "Measuring", f"metrics of iteration {state.iteration}", notify=False):
            plots = self.analyses.plots(run, index)
            self.analyses.readiness(run, index)  # the curve-like share, for the status and legend below
            colour_by = self.colour_by
            colours = (self.analyses.colours(run, index, colour_by, self.colour_original)
                       if colour_by in COLOUR_RANGES else None)
            # the skeleton's checks, when the skeleton thread has already made them
            verdict = session.verdict(index, run, with_skeleton=(index, session.skeleton_params) in run.evidence)
            comparison = (compare.comparison(self.pinned, state, session.metrics_upto(index, run), verdict,
                                             run.history[:index + 1])
                          if self.pinned is not None else None)
        points = viewer.drawn.get("points")
        if not self._plots_wanted(viewer, run, index, points):
            return
        if points[1] != index:  # drawn late: the status and legend speak of the points shown
            self.analyses.readiness(run, points[1])
        hint = self._hold_hint(verdict, run, index)  # before the atomic block: it may read the solid (0.1-0.4 s)
        with viewer.client.atomic():
            viewer.show_plots(plots, verdict, hint)
            if colours is not None:
                viewer.view.set_colours((run, index), colours.contracted, colour_by, colours.original)
            self.update_legend(viewer, "" if colours is None else colours.note)
            self.update_status(viewer)  # the curve-like share is known now
            if comparison is not None:
                viewer.show_comparison(*comparison)
        viewer.client.flush()
        self.mark("plots", viewer, run, index)

    def _draw_skeleton(self, request) -> None:
        """A viewer's skeleton, when wanted (shown, and final or provisional ones asked for), then the verdict
        with the skeleton's checks."""
        viewer, run, index = request
        if not viewer.showing(run, index):
            return
        readiness = self.analyses.readiness(run, index)
        wanted = self._skeleton_wanted(viewer, readiness)
        if not wanted:
            viewer.view.clear_skeleton()
            return
        state = run.history[index]
        with self.activity.busy(None, "Skeleton", f"skeleton of iteration {state.iteration}", notify=False):
            skeleton = self.session.skeleton(index, run)
        if viewer.showing(run, index):
            viewer.view.show_skeleton(skeleton.nodes_array(), skeleton.edges_array(), skeleton.degrees(),
                                      readiness.provisional)
            viewer.client.flush()
            self.mark("skeleton", viewer, run, index)
            if skeleton.gap > skeleton.radius:  # the notes say so once a skeleton has read the surface
                self.update_status(viewer)
        verdict = self.session.verdict(index, run, with_skeleton=index > 0)  # the skeleton's checks complete it
        pinned = self.pinned
        if viewer.showing(run, index):
            hint = self._hold_hint(verdict, run, index)
            with viewer.client.atomic():
                viewer.show_verdict(verdict, hint)
                if pinned is not None:  # the Compare tab names the same verdict; its figures stand
                    viewer.ui.plots.compare_note.content = compare.comparison_note(pinned, state, verdict,
                                                                                   run.history[:index + 1])
            viewer.client.flush()

    def _hold_hint(self, verdict: dict, run, index: int) -> str:
        """What to try when the skeleton of history[index], if made, keeps fewer loops than the solid has."""
        if (index, self.session.skeleton_params) not in run.evidence:
            return ""
        return status.hold_inside_hint(verdict, run.state(index), lambda: self.session.solid_loops(index, run),
                                       mesh=run.cloud.solid_loops is not None)

    # ------------------------------------------------------------------ view settings
    def set_colouring(self) -> None:
        """The View tab's colouring, for every viewer."""
        self.colour_by = self.ui.view.colouring.value
        self.colour_original = bool(self.ui.view.colour_original.value)
        for viewer in self.all():
            if self.colour_by not in COLOUR_RANGES:
                self.set_fixed_colours(viewer, self.session.run, viewer.shown)
            self.update_legend(viewer)
        self.reanalyse()

    def offer_colourings(self, labelled: bool) -> None:
        """Colour by "label" only for a cloud with labels; a view coloured by labels the new cloud lacks turns plain."""
        colouring = self.ui.view.colouring
        options = tuple(option for option in layout.COLOUR_BY if labelled or option != "label")
        if colouring.options != options:
            colouring.options = options  # viser puts the value on the first option when it is gone
            if self.colour_by != colouring.value:
                self.set_colouring()

    def labels_changed(self) -> None:
        """New label weights: the legends and statuses name them."""
        for viewer in self.all():
            self.update_legend(viewer)
        self.update_statuses()

    def apply_view(self) -> None:
        """The View tab's layers, sizes and opacities, for every viewer (out-of-range boxes put back in range)."""
        for handle in (*self.ui.view.size.values(), *self.ui.view.opacity.values()):
            # the box beside a slider takes any number: a size of 1000 froze every browser drawing it
            value = float(handle.value)
            kept = min(max(value, handle.min), handle.max) if value == value else 1.0  # NaN: as every layer starts
            if kept != value:
                handle.value = kept
        settings = self.view_settings()
        for viewer in self.all():
            view = viewer.view
            for layer in layout.LAYERS:
                if settings["visible"][layer] != view.visible[layer]:
                    view.set_visible(layer, settings["visible"][layer])
                if settings["sizes"][layer] != view.sizes[layer]:
                    view.set_size(layer, settings["sizes"][layer])
                if settings["opacity"][layer] != view.opacity[layer]:
                    view.set_opacity(layer, settings["opacity"][layer])
        self.reanalyse()  # the skeleton is drawn only when it is wanted
        self.update_statuses()

    # ------------------------------------------------------------------ status and legend
    def update_statuses(self) -> None:
        with self._status_lock:
            playing = self._play_button()
            for viewer in self.all():
                self._update_status(viewer, playing)
            # newest first: at 1280x720 the tab shows the first few lines without scrolling the controls away
            self.ui.log.content = "\n".join(f"- {line}" for line in reversed(self.session.log[-LOG_LINES:]))

    def update_status(self, viewer: Viewer) -> None:
        with self._status_lock:
            self._update_status(viewer, self._play_button())

    def _play_button(self) -> bool:
        """Whether the run plays, read once for the Play button and the statuses pushed with it (app.playback)."""
        playing = self.worker.playing
        self.ui.run.play.label = (layout.PAUSE if playing else layout.REPLAY if self.session.finished
                                  else layout.PLAY)
        return playing

    def _update_status(self, viewer: Viewer, playing: bool) -> None:
        session = self.session
        run = session.run  # a restart may replace the run meanwhile: read it once
        history = run.history
        index = min(viewer.shown, len(history) - 1)
        viewer.set_timeline(len(history), index)
        readiness = self.analyses.readiness(run, index, compute=False)
        viewer.ui.status.content = status.status_markdown(
            session, index, run=status.run_state(history, self.activity.text(), playing,
                                                      run.ahead if session.ready_ahead else None,
                                                      paused=self.playback is not None and self.playback.paused,
                                                      weights=run.weights),
            readiness=readiness,
            skeleton=status.skeleton_note(readiness, viewer.view.visible["skeleton"], self.ui.view.provisional.value),
            following=viewer.following)
        self.ui.pending.content = status.pending_markdown(session)
        # a sparse cloud, small separate pieces: known once a skeleton of the run has read its surface
        said = [] if run.surface is None else run.surface[2].scale_notes(session.sample_radius)
        shown = run.skeletons.get((index, session.run_options(run).skeleton_params()))  # drawn: its cuts said
        said += [] if shown is None else beyond_solid_notes(shown, run.cloud.loops_at_most is not None)
        notes = status.run_notes(run, history[index], viewer.view.notice(history[index].n_points), said)
        viewer.ui.notes.content = notes
        viewer.ui.notes_folder.visible = bool(notes)

    def update_legend(self, viewer: Viewer, note: str = "") -> None:
        run = self.session.run
        index = min(viewer.shown, len(run.history) - 1)
        viewer.ui.legend.content = status.legend(
            self.colour_by, run.history[index], self.analyses.readiness(run, index, compute=False), note=note,
            visible=viewer.view.visible, original_coloured=self.colour_original,
            provisional_wanted=self.ui.view.provisional.value,
            pinned=self.pinned is not None and self.pinned.skeleton is not None, labels_html=self.labels.legend_html())

    def mark(self, stage: str, viewer: Viewer, run, index: int) -> None:
        viewer.drawn[stage] = (run, index)
        with self._drawn_changed:
            self.drawn[stage] = (run, index, time.perf_counter())
            self._drawn_changed.notify_all()

    def wait_drawn(self, stage: str, after: float, index: int | None = None,
                   timeout: float | None = None) -> tuple[int, float] | None:
        """Block until `stage` ('points', 'plots', 'skeleton') was pushed to a viewer after perf_counter `after`
        (for history[index], or any state); (index, time) of that push, or None after `timeout` seconds."""
        def done() -> bool:
            pushed = self.drawn.get(stage)
            return pushed is not None and pushed[2] > after and index in (None, pushed[1])

        with self._drawn_changed:
            if not self._drawn_changed.wait_for(done, timeout):
                return None
            return self.drawn[stage][1], self.drawn[stage][2]

    def up_of(self, cloud) -> str:
        """The up axis a newly loaded cloud opens with: +Y for glTF, whose format fixes it, else the last chosen."""
        return "+Y" if Path(cloud.name).suffix.lower() in Y_UP_FORMATS else self._chosen_up

    def turn_up(self, axis: str, chosen: bool = False) -> bool:
        """Make `axis` (skelcore.display.UP_AXES) the scene's up, `chosen` by a person or by the cloud's format:
        every browser's camera then orbits about it, framed anew from above and aside (the first view's direction
        turned with the scene). Whether it changed."""
        self._chosen_up = axis if chosen else self._chosen_up
        if not chosen and axis == self.ui.view.up.value:
            return False
        up = display.UP_AXES[axis]
        self.ui.view.up.value = axis
        if self.server is not None:
            self.server.scene.set_up_direction(up)
            frame_camera(self.server.initial_camera, self.session.cloud.points, up=up)
        for viewer in self.all():
            viewer.client.camera.up_direction = up
            self.fit(viewer.client, display.turned_up(INITIAL_DIRECTION, up))
        return True

    def fit(self, client, direction=None) -> None:
        """Frame the whole cloud in this client's view, keeping its viewing direction (or looking along
        `direction`): the original points and the contracted ones of the iteration shown (a step can fling some
        out of the original's box)."""
        if client is None:
            return
        viewer, run = self.viewer(client), self.session.run
        points = self.session.cloud.points
        if viewer is not None and 0 < viewer.shown < len(run.history):
            points = np.concatenate([points, run.state(viewer.shown).points])
        fit_client_camera(client.camera, points, display.display_origin(self.session.cloud.points), direction)
