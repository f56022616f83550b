"""The viser inspector: GUI panels and scene for one Session shared by every connected browser.

GUI callbacks are `async`, so they run on viser's event loop in the order the browser sent them; they
only read widget values and queue jobs. Engine calls (step, play, restart, load, export) run on one
worker thread, in that order, so a weight changed just before a Step click is used by that step. The
points of a new state are drawn at once; its metrics, histograms and skeleton follow from an analysis
thread that always works on the state shown last, so a slow skeleton never holds up the run. Anything
slower than about a second says so (app.progress). Widgets live in app.layout.
"""
from __future__ import annotations

import re
import threading
import time
from pathlib import Path

import numpy as np
import viser

from skelcore import display, pipeline, report
from skelcore.errors import InputError, NonFiniteError, ParameterError, TooLargeError
from skelcore.io import load, load_bytes
from skelcore.memory import INSPECTOR_SHARE, budget_bytes
from skelcore.pipeline import write_atomic
from skelcore.verdict import explanation_markdown

from . import compare, export, layout
from .labels import LabelPanel
from .progress import PROGRESS_AFTER, Activity
from .scene import COLOUR_RANGES, SceneView, auto_opacity, colour_values, legend_html
from .session import Session
from .upload_guard import UploadGuard
from .uploads import UploadNotices
from .worker import Latest, Worker

MAX_UPLOAD_BYTES = 64 * 1024 * 1024
LOG_LINES = 8
SAVE_NAME_LENGTH = 80  # characters of a cloud's name kept in the names of exported files
PLAY_INTERVAL = 0.25  # seconds: a small cloud contracts in a blink; Play paces it so it can be watched


class Inspector:
    def __init__(self, server: viser.ViserServer, session: Session, *, assets: dict[str, Path] | None = None,
                 save_dir: Path | None = None, max_upload_bytes: int = MAX_UPLOAD_BYTES):
        self.server = server
        self.session = session
        self.assets = dict(assets or {})
        self.save_dir = save_dir
        self.max_upload_bytes = max_upload_bytes
        self.view = SceneView(server.scene)
        self.shown = 0  # index into session.history of the iteration on screen
        self.colour_by = "plain"
        self.colour_original = False
        self.pinned: compare.Pinned | None = None
        self.drawn: dict[str, tuple] = {}  # stage -> (run, index, perf_counter) of its last push
        self._curve_shares: dict[int, tuple] = {}  # id(state) -> (state, curve-like share); the state keeps its id
        self.step_clicked = 0.0
        self._drawn_changed = threading.Condition()
        self.activity = Activity(self._progress_notice, self._update_status)
        self.worker = Worker(self._report_error)
        self.analyst = Latest(self._analyse,
                              lambda message, client: self._report_error(message, client, pause=False))
        self.upload_guard = UploadGuard(server, max_upload_bytes, self._upload_refused)
        self.uploads = UploadNotices(server)  # viser's "uploaded successfully" never shows: we say what happened
        self.offer = None  # (voxel size, read) of a too large cloud offered voxel-downsampled
        self.ui = layout.build(server.gui, session.params, session.sample_radius, play_interval=PLAY_INTERVAL,
                               assets=tuple(self.assets), max_upload_mib=max_upload_bytes // 2**20, save_dir=save_dir)
        self.labels = LabelPanel(server.gui, session, self.worker.submit, self._labels_changed,
                                 order=self.ui.labels_order)
        self._wire()
        self.worker.submit(lambda: self._draw_new_run(frame=True))

    def open(self, cloud) -> None:
        """Replace the session's cloud (a validated skelcore.io.Cloud), as an upload does."""
        self._pause()
        self.worker.submit(lambda: self._load(lambda voxel=None, drop=False: cloud))

    def wait_idle(self, timeout: float | None = None) -> bool:
        """Block until queued engine jobs and the analysis of the shown state are done (for tests, benches)."""
        return self.worker.wait_idle(timeout) and self.analyst.wait_idle(timeout)

    def close(self) -> None:
        self.upload_guard.close()
        self.worker.close()
        self.analyst.close()

    # ------------------------------------------------------------------ wiring
    def _wire(self) -> None:
        ui, submit = self.ui, self.worker.submit

        def on(handle, job, *, pause: bool = False, person_only: bool = False, method="on_click"):
            """Queue job(event) for a widget event; person_only: skip the updates we make ourselves."""
            async def callback(event) -> None:
                if person_only and event.client is None:
                    return
                if pause:
                    self._pause()
                job(event)
            getattr(handle, method)(callback)

        on(ui.run.step, self._on_step)
        on(ui.run.play, lambda event: self._toggle_play(event.client))
        on(ui.run.end, lambda event: self._start_play(event.client, full=False))
        on(ui.run.reset, lambda e: submit(lambda: self._restart(self.session.start_params), e.client), pause=True)
        on(ui.params.restart, lambda e: self._on_restart(e.client), pause=True)
        on(ui.run.timeline, lambda e: self._view_iteration(int(ui.run.timeline.value), e.client),
           person_only=True, method="on_update")
        on(ui.run.follow, lambda e: self._follow(e.client), person_only=True, method="on_update")
        for handle in ui.params.contraction_handles():
            on(handle, self._on_parameter, person_only=True, method="on_update")
        on(ui.params.radius, lambda e: submit(lambda: self._set_radius(float(ui.params.radius.value)), e.client),
           person_only=True, method="on_update")
        for handle in (*ui.view.show.values(), *ui.view.size.values(), *ui.view.opacity.values(), ui.view.provisional):
            on(handle, lambda e: submit(self._apply_view, e.client), person_only=True, method="on_update")
        for handle in (ui.view.colouring, ui.view.colour_original):
            on(handle, lambda e: submit(self._set_colouring, e.client), person_only=True, method="on_update")
        on(ui.view.fit, lambda e: self._fit(e.client))
        on(ui.files.load, self._on_load_asset)
        on(ui.files.upload, self._on_upload, method="on_upload")
        on(ui.files.downsample, self._on_downsample)
        on(ui.files.screenshot, lambda e: submit(lambda: self._send_screenshot(e.client), e.client))
        on(ui.files.animation, lambda e: submit(lambda: self._send_animation(e.client), e.client))
        on(ui.files.bundle, lambda e: submit(lambda: self._send_bundle(e.client), e.client))
        on(ui.plots.pin, lambda e: submit(lambda: self._pin(e.client), e.client))
        gui = self.server.gui
        shortcuts = {"N": self._on_step, "P": lambda event: self._toggle_play(event.client),
                     "J": lambda event: self._view_iteration(self.shown - 1, event.client, pause=True),
                     "K": lambda event: self._view_iteration(self.shown + 1, event.client, pause=True),
                     "F": lambda event: self._fit(event.client)}
        for key, job in shortcuts.items():
            command = gui.add_command(layout.SHORTCUTS[key].capitalize(), hotkey=key)
            on(command, job, method="on_trigger")

    def _on_step(self, event) -> None:
        self.step_clicked = time.perf_counter()  # when the server got the click (app.bench reads it)
        self._pause()
        self.worker.submit(lambda: self._step(event.client), event.client)

    def _toggle_play(self, client) -> None:
        if self.worker.playing:
            self._pause()
            self.worker.submit(self._update_status)
        else:
            self._start_play(client, full=True)

    def _start_play(self, client, full: bool) -> None:
        if self.worker.playing:
            return
        self.ui.run.play.label = "Pause"
        self.worker.play(lambda: self._tick(full=full), client, float(self.ui.run.interval.value) if full else 0.0)

    def _pause(self) -> None:
        """Every stop of Play goes through here, so the button always tells what a click will do."""
        self.worker.pause()
        self.ui.run.play.label = "Play"

    def _on_restart(self, client) -> None:
        try:
            params = self._panel_params()
        except ParameterError as error:
            self._notify(client, "Parameter refused", str(error))
            return
        self.worker.submit(lambda: self._restart(params), client)

    def _on_parameter(self, event) -> None:
        try:
            params = self._panel_params()
        except ParameterError as error:
            self._notify(event.client, "Parameter refused", str(error))
            return
        self.worker.submit(lambda: self._tune(params), event.client)

    def _on_load_asset(self, event) -> None:
        path = self.assets.get(self.ui.files.asset.value)
        if path is not None:  # only names of files the server listed itself
            self._pause()
            read = lambda voxel=None, drop=False: load(path, drop_nonfinite=drop, voxel_size=voxel,  # noqa: E731
                                                       budget=_budget())
            self.worker.submit(lambda: self._load(read, event.client, f"Loading {path.name}"),
                               event.client)

    def _on_upload(self, event) -> None:
        upload = self.ui.files.upload.value
        if len(upload.content) > self.max_upload_bytes:
            self._notify(event.client, "Upload refused",
                         f"{upload.name}: {len(upload.content) / 2**20:.1f} MiB exceeds the cap of "
                         f"{self.max_upload_bytes / 2**20:.0f} MiB")
            return
        self._pause()
        read = lambda voxel=None, drop=False: load_bytes(upload.content, upload.name,  # noqa: E731
                                                         drop_nonfinite=drop, voxel_size=voxel, budget=_budget())
        self.worker.submit(lambda: self._load(read, event.client, f"Reading {upload.name}", at_once=True), event.client)

    def _on_downsample(self, event) -> None:
        if self.offer is not None:
            voxel, read = self.offer
            self._pause()
            self.worker.submit(lambda: self._load(lambda _=None, drop=False: read(voxel, drop), event.client,
                                                  "Loading downsampled"), event.client)

    def _panel_params(self):
        """The parameters the panel shows, on top of the run's (fields the panel lacks stay)."""
        p = self.ui.params
        return self.session.params.replace(
            method=p.method.value, k=int(p.k.value) or None, wl0=float(p.wl0.value) or None,
            wh0=float(p.wh0.value), sl=float(p.sl.value), wl_max=float(p.wl_max.value),
            max_iterations=int(p.max_iterations.value), termination=float(p.termination.value))

    def _show_params(self, params) -> None:
        """Put a run's parameters into the panel (no client: the callbacks ignore it)."""
        p = self.ui.params
        p.method.value = params.method
        p.wl0.value = params.wl0 or 0.0
        p.wh0.value, p.sl.value, p.wl_max.value = params.wh0, params.sl, params.wl_max
        p.k.value = params.k or 0
        p.max_iterations.value, p.termination.value = params.max_iterations, params.termination

    # ------------------------------------------------------------------ jobs (worker thread only)
    def _step(self, client) -> None:
        session = self.session
        if session.step() is None:
            self._notify(client, "Run has ended", f"{session.latest.message}. Reset or Restart to run again.",
                         color="yellow")
            return
        newest = len(session.history) - 1
        if self.shown < newest - 1:
            self._notify(client, "Stepped from the newest iteration",
                         f"You were viewing iteration {session.history[self.shown].iteration}; Step continues the "
                         f"run from iteration {session.history[newest - 1].iteration}, so the view moves to "
                         f"iteration {session.latest.iteration}.", color="blue")
        self._show(newest)

    def _tick(self, full: bool) -> bool:
        """One Play / Run-to-end iteration; False ends the loop."""
        state = self.session.step(paused=lambda: not self.worker.playing)  # a pause lands between two stages
        going = state is not None and not self.session.finished
        if not going:
            self.ui.run.play.label = "Play"
        if state is not None and (self.ui.run.follow.value or not going):
            self._show(len(self.session.history) - 1, full=full or not going)
        elif state is not None:
            self._update_status()
        return going

    def _tune(self, params) -> None:
        if self.session.tune(params):
            self._update_status()

    def _restart(self, params) -> None:
        with self.activity.busy(None, "Restarting", "computing the one-rings of iteration 0"):
            self.session.restart(params)
        self._show_params(self.session.params)
        self._draw_new_run(frame=False)

    def _load(self, read, client=None, what: str = "Loading", at_once: bool = False) -> None:
        """at_once: say so at once (an upload: viser's progress bar has just gone)."""
        try:
            with self.activity.busy(client, what, f"{what.lower()} and computing its one-rings",
                                    after=0.0 if at_once else PROGRESS_AFTER):
                cloud = read()  # an InputError leaves the session as it was
                self.session.load(cloud)
        except NonFiniteError as error:
            self._offer_to_drop(client, error, read, what)
            return
        except TooLargeError as error:
            self.offer = (error.voxel_size, read)
            self.ui.files.downsample.label = f"Load downsampled (voxel {error.voxel_size:g})"
            self.ui.files.downsample.visible = True
            raise InputError(f"{error}: press '{self.ui.files.downsample.label}' in Files") from None
        self.offer = None
        self.ui.files.downsample.visible = False
        self._draw_new_run(frame=True)
        if cloud.notes:
            self._notify(client, f"Loaded {Path(cloud.name).name}", "; ".join(cloud.notes), color="blue")

    def _offer_to_drop(self, client, error: NonFiniteError, read, what: str) -> None:
        """A file with a few NaN/Inf rows: ask whether to load it without them."""
        self._notify(client, "Points with NaN or Inf", str(error))
        if client is None:
            return
        with client.gui.add_modal("Points with NaN or Inf") as modal:
            client.gui.add_markdown(f"{error}. Load the file without these {error.count:,} points?")
            drop = client.gui.add_button(f"Drop {error.count:,} points and load")
            cancel = client.gui.add_button("Cancel", color="gray")

        @drop.on_click
        async def _(event) -> None:
            modal.close()
            self.worker.submit(lambda: self._load(lambda: read(drop=True), client, what, at_once=True), client)

        @cancel.on_click
        async def _(event) -> None:
            modal.close()

    def _set_radius(self, radius: float) -> None:
        self.session.set_sample_radius(radius)
        self.analyst.request((self.session.run, self.shown))

    def _set_colouring(self) -> None:
        self.colour_by = self.ui.view.colouring.value
        self.colour_original = bool(self.ui.view.colour_original.value)
        if self.colour_by not in COLOUR_RANGES:
            self._set_fixed_colours(self.session.run, self.shown)
        self._update_legend()
        self.analyst.request((self.session.run, self.shown))

    def _set_fixed_colours(self, run, index: int) -> None:
        """Colours that need no metrics: plain, or by label."""
        colours = self.labels.colours(run.history[index].point_ids) if self.colour_by == "label" else None
        self.view.set_colours((run, index), colours, self.colour_by)

    def _labels_changed(self) -> None:
        self._update_legend()
        self._update_status()

    def _apply_view(self) -> None:
        v = self.ui.view
        for layer in layout.LAYERS:
            if bool(v.show[layer].value) != self.view.visible[layer]:
                self.view.set_visible(layer, bool(v.show[layer].value))
            if float(v.size[layer].value) != self.view.sizes[layer]:
                self.view.set_size(layer, float(v.size[layer].value))
            if float(v.opacity[layer].value) != self.view.opacity[layer]:
                self.view.set_opacity(layer, float(v.opacity[layer].value))
        self.analyst.request((self.session.run, self.shown))  # the skeleton is drawn only when it is wanted
        self._update_status()

    def _draw_new_run(self, frame: bool = False) -> None:
        cloud = self.session.cloud
        self.ui.run.title.content = (f"**skelcore inspector** &middot; {Path(cloud.name).name} "
                                     f"&middot; {len(cloud.points):,} points")
        if cloud.points is not self.view._source:  # a new cloud: dense ones start thinned
            opacity = auto_opacity(len(cloud.points))
            self.ui.view.opacity["original"].value = opacity
            self.ui.view.size["original"].value = 1.0 if opacity == 1 else 0.7
            self.view.opacity["original"], self.view.sizes["original"] = opacity, self.ui.view.size["original"].value
        self.ui.run.follow.value = True  # a new run: its iterations are shown as they come
        self.view.load(cloud.points)
        self.view.frame_camera(self.server.initial_camera)
        if frame:
            for client in self.server.get_clients().values():
                self._fit(client)
        self.labels.refresh()
        self._update_legend()
        self._show(len(self.session.history) - 1)  # iteration 0, or the end of a finished run opened as such

    def _view_iteration(self, index: int, client, pause: bool = False) -> None:
        if pause:
            self._pause()
        index = max(0, min(index, len(self.session.history) - 1))
        if index != len(self.session.history) - 1:
            self.ui.run.follow.value = False  # looking back: new iterations no longer pull the view along
        self.worker.submit(lambda: self._show(index), client)

    def _follow(self, client) -> None:
        if self.ui.run.follow.value:
            self.worker.submit(lambda: self._show(len(self.session.history) - 1), client)

    def _show(self, index: int, full: bool = True) -> None:
        """Draw history[index]: the points and the status now; metrics, plots and skeleton follow from
        the analysis thread (full=False: points only, as Run to end does on its way)."""
        session = self.session
        index = max(0, min(index, len(session.history) - 1))
        run, state = session.run, session.history[index]
        self.shown = index
        with self.server.atomic():
            self.view.show_points((run, index), state.points)
            self.view.show_removed((run, index), session.cloud.points[state.removed_ids])
            if self.colour_by not in COLOUR_RANGES:
                self._set_fixed_colours(run, index)
            if self.view.skeleton_drawn:
                self.view.clear_skeleton()  # another iteration's skeleton would mislead
            self._update_status()
        self.server.flush()
        self._mark("points", run, index)
        if full:
            self.analyst.request((run, index))

    def _current(self, run, index: int) -> bool:
        return run is self.session.run and index == self.shown

    # ------------------------------------------------------------------ analysis thread
    def _analyse(self, request) -> None:
        """Metrics, plots and colours of a shown state, then its skeleton."""
        run, index = request
        if not self._current(run, index):
            return
        state = run.history[index]
        with self.activity.busy(None, "Measuring", f"metrics of iteration {state.iteration}", notify=False):
            history = self.session.metrics_upto(index, run)
            verdict = self.session.verdict(index, run)
            figures = (_compact(report.histogram_figure(history[-1], "d_theta", iteration=state.iteration, fit=True)),
                       _compact(report.histogram_figure(history[-1], "delta_kappa", iteration=state.iteration,
                                                        fit=True)),
                       report.convergence_figure(history).update_layout(height=None))
            colours = original_colours = None
            note = ""
            if self.colour_by in COLOUR_RANGES:
                quantity = report.measure_key(self.colour_by)
                values = display.values_for_all_points(history[-1], state.points, quantity)
                colours = colour_values(values.values, self.colour_by)
                if values.carried:
                    note = (f"{values.measured:,} points measured; the other {values.carried:,} show the value "
                            f"of their nearest measured point")
                if self.colour_original:
                    on_original = np.full(len(run.cloud.points), np.nan)
                    on_original[state.point_ids] = values.values
                    original_colours = colour_values(on_original, self.colour_by)
        if not self._current(run, index):
            return
        provisional = pipeline.skeleton_is_provisional(state)
        with self.server.atomic():
            self.ui.plots.hist_theta.figure, self.ui.plots.hist_kappa.figure, self.ui.plots.convergence.figure = figures
            self._show_verdict(verdict)
            if quantity_mode := (self.colour_by if self.colour_by in COLOUR_RANGES else None):
                self.view.set_colours((run, index), colours, quantity_mode, original_colours)
            self._update_legend(note, provisional)
            if self.pinned is not None:
                self._draw_comparison(state, history)
        self.server.flush()
        self._mark("plots", run, index)
        wanted = self.view.visible["skeleton"] and (not provisional or self.ui.view.provisional.value)
        if not wanted:
            self.view.clear_skeleton()
            return
        with self.activity.busy(None, "Skeleton", f"skeleton of iteration {state.iteration}", notify=False):
            skeleton = self.session.skeleton(index, run)
        if self._current(run, index):
            self.view.show_skeleton(skeleton.nodes_array(), skeleton.edges_array(), skeleton.degrees(), provisional)
            self.server.flush()
            self._mark("skeleton", run, index)
        # The skeleton's own checks complete the verdict once it exists.
        verdict = self.session.verdict(index, run, with_skeleton=index > 0)
        if self._current(run, index):
            self._show_verdict(verdict)
            self.server.flush()

    def _show_verdict(self, verdict: dict) -> None:
        """The explanation table in the Verdict tab, its headline above the histograms."""
        table = explanation_markdown(verdict)
        self.ui.plots.verdict.content = table
        self.ui.plots.verdict_line.content = f"{table.splitlines()[0] if table else ''} _(criteria: Verdict tab)_"

    def _update_legend(self, note: str = "", provisional: bool | None = None) -> None:
        if provisional is None:
            history = self.session.history  # a new run may be shorter than the index shown last
            provisional = pipeline.skeleton_is_provisional(history[min(self.shown, len(history) - 1)])
        quantity = self.colour_by if self.colour_by in COLOUR_RANGES else None
        self.ui.legend.content = legend_html(quantity, note, provisional=provisional and self.ui.view.provisional.value,
                                             pinned=self.pinned is not None,
                                             extra=self.labels.legend_html() if self.colour_by == "label" else "")

    # ------------------------------------------------------------------ compare
    def _pin(self, client) -> None:
        state = self.session.latest
        with self.activity.busy(client, "Pinning", f"metrics and skeleton of iteration {state.iteration}"):
            self.pinned = compare.pin(self.session)
        self.view.show_ghost(*(self.pinned.skeleton or (None, None)))
        self.ui.plots.pin.label = "Pin this run instead"
        self.session.note(f"pinned the run at iteration {state.iteration} for comparison")
        self._update_legend()
        self.analyst.request((self.session.run, self.shown))

    def _draw_comparison(self, state, history) -> None:
        plots = self.ui.plots
        (plots.compare_note.content, plots.compare_convergence.figure, plots.compare_theta.figure,
         plots.compare_kappa.figure) = compare.comparison(self.pinned, state, history)

    # ------------------------------------------------------------------ status
    def _update_status(self) -> None:
        session = self.session
        history = session.history  # a restart may replace the run meanwhile: read it once
        index = min(self.shown, len(history) - 1)
        state, latest = history[index], history[-1]
        timeline = self.ui.run.timeline
        timeline.max = max(1, len(history) - 1)
        timeline.value = index
        timeline.disabled = len(history) < 2
        doing = self.activity.text()
        if doing:
            run = f"busy: {doing}…"
        elif latest.termination:
            run = f"ended at iteration {latest.iteration}: {latest.message}"
        elif self.worker.playing:
            run = "running"
        else:
            run = "paused" if len(history) > 1 else "ready"
        notice = self.view.notice(state.n_points)
        removed = len(state.owner) - state.n_points
        counts = (f"{state.n_points:,} points retained, {removed:,} removed" if removed
                  else f"{state.n_points:,} points")
        provisional = pipeline.skeleton_is_provisional(state)
        skeleton_note = ""
        if provisional and self.view.visible["skeleton"]:
            skeleton_note = ("skeleton drawn provisionally: the cloud has not contracted yet"
                             if self.ui.view.provisional.value else
                             "no skeleton yet: the cloud has not contracted (View: Provisional skeleton)")
        cleaning = session.run.cloud.cleaning or {}
        removed_by_cleaning = (f"cleaning removed {cleaning['outliers_removed']:,} outliers and "
                               f"{cleaning['stray_removed']:,} stray points of {cleaning['input_points']:,}"
                               if cleaning.get("kept", 0) < cleaning.get("input_points", 0) else "")
        self.ui.run.status.content = "\n\n".join(filter(None, [
            f"**Iteration {state.iteration}** of {latest.iteration} computed &middot; {counts}",
            notice and f"_{notice}_",
            removed_by_cleaning,
            f"W_L = {state.wl:.4g} &middot; W_H in [{state.wh.min():.3g}, {state.wh.max():.3g}] "
            f"&middot; ring-size ratio a_t = {state.ring_ratio:.4f} "
            f"&middot; curve-like {self._curve_share(state, session.run.cloud):.0%}",
            skeleton_note and f"_{skeleton_note}_",
            session.pending and f"**Pending:** {session.pending}",
            f"Run {run}",
        ]))
        self.ui.log.content = "\n".join(f"- {line}" for line in session.log[-LOG_LINES:])

    def _curve_share(self, state, cloud) -> float:
        """The shown state's curve-like share (skelcore.pipeline.state_curve_share), computed once per state."""
        if len(self._curve_shares) > 256:  # states of old runs
            self._curve_shares.clear()
        if id(state) not in self._curve_shares:
            self._curve_shares[id(state)] = (state, pipeline.state_curve_share(state, cloud))
        return self._curve_shares[id(state)][1]

    def _mark(self, stage: str, run, index: int) -> None:
        with self._drawn_changed:
            self.drawn[stage] = (run, index, time.perf_counter())
            self._drawn_changed.notify_all()

    def wait_drawn(self, stage: str, after: float, index: int | None = None,
                   timeout: float | None = None) -> tuple[int, float] | None:
        """Block until `stage` ('points', 'plots', 'skeleton') was pushed after perf_counter `after` (for
        history[index], or any state); (index, time) of that push, or None after `timeout` seconds."""
        def done() -> bool:
            pushed = self.drawn.get(stage)
            return pushed is not None and pushed[2] > after and index in (None, pushed[1])

        with self._drawn_changed:
            if not self._drawn_changed.wait_for(done, timeout):
                return None
            return self.drawn[stage][1], self.drawn[stage][2]

    # ------------------------------------------------------------------ view and export
    def _client(self, client) -> viser.ClientHandle:
        client = client or next(iter(self.server.get_clients().values()), None)
        if client is None:
            raise InputError("export: no browser is connected to render the view")
        return client

    def _fit(self, client) -> None:
        """Frame the whole cloud in this client's view, keeping its viewing direction."""
        if client is None:
            return
        camera = client.camera
        framing = display.framing_camera(self.session.cloud.points, camera.look_at - camera.position, camera.fov,
                                         camera.aspect or 1.0, export.FRAME_FILL, up=camera.up_direction)
        camera.position = framing.position
        camera.look_at = framing.look_at

    def _size(self) -> tuple[int, int]:
        width, height = (int(v) for v in self.ui.files.resolution.value.split("x"))
        return width, height

    def _render(self, client, index: int) -> bytes:
        width, height = self._size()
        client = self._client(client)
        rgba = client.get_render(height, width, transport_format="png", timeout=120,
                                 **export.framed_camera(self.session.cloud.points, client.camera, width, height))
        labels = (export.caption(self.session.cloud.name, self.session.history[index],
                                 self.session.verdict(index)["label"]) if self.ui.files.labels.value else [])
        return export.png_bytes(rgba, labels, bool(self.ui.files.transparent.value))

    def _stem(self, suffix: str | None = None) -> str:
        """The name of exported files: the cloud's, made safe for any file system and shortened."""
        name = re.sub(r"[^A-Za-z0-9._-]+", "_", Path(self.session.cloud.name).stem).strip("._-")
        suffix = suffix or f"it{self.session.history[self.shown].iteration:03d}"
        return f"{name[:SAVE_NAME_LENGTH] or 'cloud'}-{suffix}"

    def _send_screenshot(self, client) -> None:
        with self.activity.busy(client, "Screenshot", "rendering the screenshot"):
            png = self._render(client, self.shown)
        self._deliver(client, f"{self._stem()}.png", png)

    def _send_bundle(self, client) -> None:
        with self.activity.busy(client, "Export bundle", "rendering and writing the bundle"):
            png = self._render(client, self.shown)
            data = export.bundle(self.session, self.shown, png)
        self._deliver(client, f"{self._stem()}.zip", data)

    def _send_animation(self, client) -> None:
        """One frame per iteration of the run so far, from one framed camera, the iteration burned in."""
        session, shown = self.session, self.shown
        client = self._client(client)
        width, height = self._size()
        run = session.run
        camera = export.framed_camera(run.cloud.points, client.camera, width, height)
        frames = []
        labels = self.ui.files.labels.value
        with self.activity.busy(client, "Export animation", f"rendering {len(session.history)} frames"):
            self.view.clear_skeleton()
            try:
                for index, state in enumerate(run.history):
                    self.view.show_points((run, index), state.points)
                    self.view.show_removed((run, index), run.cloud.points[state.removed_ids])
                    self.server.flush()
                    rgba = client.get_render(height, width, transport_format="png", timeout=120, **camera)
                    frames.append(export.compose(rgba, export.caption(run.cloud.name, state) if labels else []))
            finally:
                self._show(shown)
            files = export.animation_files(frames)
        stem = self._stem("run")
        for extension, data in files.items():
            self._deliver(client, f"{stem}.{extension}", data)

    def _deliver(self, client, name: str, data: bytes) -> None:
        if client is not None:
            client.send_file_download(name, data, save_immediately=True)
        if self.save_dir is not None and self.ui.files.save_on_server.value:
            try:
                self.save_dir.mkdir(parents=True, exist_ok=True)
            except OSError as error:
                raise InputError(f"cannot create the save folder ({error.strerror})") from None
            write_atomic(self.save_dir / name, lambda path: path.write_bytes(data))  # a full disk keeps what was saved
            self.session.note(f"saved {name} on the server")

    # ------------------------------------------------------------------ messages
    def _notify(self, client, title: str, body: str, color: str = "red") -> None:
        clients = [client] if client is not None else list(self.server.get_clients().values())
        for target in clients:
            target.add_notification(title, body, color=color, auto_close_seconds=15.0)

    def _progress_notice(self, client, title: str, body: str):
        target = client or next(iter(self.server.get_clients().values()), None)
        if target is None:
            return None
        return target.add_notification(title, body[:1].upper() + body[1:] + "…", loading=True,
                                       with_close_button=False)

    def _upload_refused(self, client_id: int, name: str, reason: str) -> None:
        client = self.server.get_clients().get(client_id)
        if client is not None:
            self._notify(client, "Upload refused", f"{Path(name).name}: {reason}")

    def _report_error(self, message: str, client, pause: bool = True) -> None:
        """A failed engine job stops Play; a failed analysis (skeleton, metrics) only says so. Server
        paths in the message are cut to their last part: no server path reaches a browser."""
        message = without_paths(message)
        if pause:
            self._pause()
        self.session.note(f"error: {message}")
        self._notify(client, "Error", message)
        self._update_status()


def _compact(histogram):
    """A histogram for the narrow plots panel: its title names the measure, so the axis title goes and the
    legend takes its place below the ticks."""
    return histogram.update_layout(height=None, margin=dict(l=45, r=10, t=55, b=40), xaxis_title=None,
                                   legend=dict(y=-0.13, yanchor="top"))


def without_paths(message: str) -> str:
    """`message` with every absolute path cut to its file name."""
    return re.sub(r"(?<![\w.])/(?:[^\s/:;,'\"()]+/)+([^\s/:;,'\"()]*)", r"\1", message)


def _budget() -> int:
    """The memory a run in the inspector may take: a smaller share of the machine than the command line's."""
    return budget_bytes(INSPECTOR_SHARE)
