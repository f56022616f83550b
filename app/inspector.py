"""The viser inspector: one Session (one run) shared by every connected browser, each browser its own Viewer.

The run, its parameters and the view settings are shared; each browser looks at its own iteration of the run
(app.viewer), following the newest by default. GUI callbacks are `async`, so they run on viser's event loop in
the order the browser sent them; they only read widget values and queue jobs. Engine calls (step, play,
restart, load, export) run on one worker thread, in that order; a weight being typed waits for the person to
stop typing (app.panel), and a Step click takes it first, so that step uses it. The points of a new state are
drawn at once; for each viewer, the plots and colours follow from an analysis thread and the skeleton from a
skeleton thread, both working on what that viewer shows last (app.analysis keeps the results, so viewers on
one iteration share them). Anything slower than about a second says so (app.progress). While nothing else
runs, the worker computes the next iteration ahead (Session.look_ahead), so that a Step shows it at once.
Widgets live in app.layout, what the parameter boxes say is taken in app.panel, exports in app.delivery,
what each viewer draws and the View tab's settings in app.presenter, status and legend words in app.status.
"""
from __future__ import annotations

import contextlib
import time
from pathlib import Path

import numpy as np
import viser

from skelcore.display import UP_AXES, see_through_size

from . import compare, layout, loop_events
from .delivery import Delivery
from .labels import LabelPanel
from .loading import Loader
from .messages import Messages, without_paths
from .panel import ParameterPanel
from .playback import Playback
from .presenter import Presenter
from .progress import Activity
from .scene import POINT_SIZES, auto_opacity, frame_camera
from .session import Session
from .upload_guard import UploadGuard
from .uploads import UploadNotices
from .viewer import Viewer, quiet_closed_browsers
from .worker import Worker
from .words import capped_text

MAX_UPLOAD_BYTES = 64 * 1024 * 1024
RUN_ENDED = "Run has ended"  # the notice a step past the end gets
PLAY_INTERVAL = 0.25  # seconds: a small cloud contracts in a blink; Play paces it so it can be watched


class Inspector:
    def __init__(self, server: viser.ViserServer, session: Session, *, assets: dict[str, Path] | None = None,
                 save_dir: Path | None = None, max_upload_bytes: int = MAX_UPLOAD_BYTES):
        loop_events.install(server)  # before any update goes out from the worker thread
        quiet_closed_browsers()
        self.server = server
        self.session = session
        self.assets = dict(assets or {})
        self.max_upload_bytes = max_upload_bytes
        self.shown = 0  # the iteration a browser following the newest shows
        self.step_clicked = 0.0
        self._source = None  # the original cloud the view settings were set for
        self.messages = Messages(server)
        self.activity = Activity(self.messages.progress, lambda: self.presenter.update_statuses())
        self.worker = Worker(self._report_error, on_idle=self._look_ahead)
        self.upload_guard = UploadGuard(server, max_upload_bytes, self.messages.upload_refused)
        self.uploads = UploadNotices(server)  # viser's "uploaded successfully" never shows: we say what happened
        self.ui = layout.build(server.gui, session.params, session.sample_radius, play_interval=PLAY_INTERVAL,
                               assets=tuple(self.assets), max_upload_mib=max_upload_bytes // 2**20, save_dir=save_dir)
        self.panel = ParameterPanel(self.ui.params, session, self.messages.notify, {
            "parameters": lambda params, client: self.worker.submit(lambda: self._tune(params, client), client),
            "radius": lambda radius, client: self.worker.submit(lambda: self._set_radius(radius), client)},
            self.messages.withdraw)
        self.playback = Playback(self.worker, self.ui.run, lambda: self.presenter.update_statuses())
        self.panel.add_part("interval", self.playback.interval_part())
        quiet = lambda message, client: self._report_error(message, client, pause=False)  # noqa: E731
        self.presenter = Presenter(session, self.ui, self.activity, self.worker, quiet, server, self.playback)
        restart = lambda button: self._on(button, lambda e: self._on_restart(e.client), pause=True)  # noqa: E731
        self.labels = self.presenter.labels = LabelPanel(server.gui, session, self.panel, self.worker.submit,
                                                         self.presenter.labels_changed, self.ui.tabs, restart)
        self.delivery = Delivery(session, self.ui.files, self.activity, save_dir, self.presenter.show,
                                 self.presenter.draw_frame, self.presenter.picture_notes)
        self.loader = Loader(session, self.ui.files, self.worker, self.playback, self.activity, self.messages,
                             self.assets, max_upload_bytes, lambda: self._draw_new_run(frame=True))
        self._notify = self.messages.notify
        self._wire()
        self.worker.submit(lambda: self._draw_new_run(frame=True))
        server.on_client_connect(self._connect)
        server.on_client_disconnect(self._disconnect)

    @property
    def drawn(self) -> dict[str, tuple]:
        """stage ('points', 'plots', 'skeleton') -> (run, index, perf_counter) of its last push to a browser."""
        return self.presenter.drawn

    def wait_drawn(self, *args, **kwargs):
        """Presenter.wait_drawn (for tests and app.bench)."""
        return self.presenter.wait_drawn(*args, **kwargs)

    def open(self, cloud) -> None:
        """Replace the session's cloud (a validated skelcore.io.Cloud), as an upload does."""
        self.loader.open(cloud)

    @property
    def offer(self):
        """(voxel size, read) of the last cloud too large for this server, offered voxel-downsampled."""
        return self.loader.offer

    def wait_idle(self, timeout: float | None = None) -> bool:
        """Block until queued engine jobs and the analyses of what viewers show are done (for tests, benches)."""
        return self.worker.wait_idle(timeout) and self.presenter.wait_idle(timeout)

    def close(self) -> None:
        self.upload_guard.close()
        self.worker.close()
        self.presenter.close()

    # ------------------------------------------------------------------ viewers
    def _connect(self, client: viser.ClientHandle) -> None:
        viewer = Viewer(client, self.ui.run.viewer_order, self.ui.notes_order, self.presenter.view_settings())
        self._wire_viewer(viewer)
        self.presenter.viewers[client.client_id] = viewer
        self.worker.submit(lambda: self._enter(viewer))

    def _disconnect(self, client: viser.ClientHandle) -> None:
        viewer = self.presenter.viewers.pop(client.client_id, None)
        if viewer is not None:
            viewer.close()

    def _enter(self, viewer: Viewer) -> None:
        self.presenter.update_legend(viewer)
        viewer.view.load(self.session.cloud.points)
        if self.presenter.pinned is not None:
            compare.show_pin([viewer], self.presenter.pinned)
        self.presenter.show(viewer, len(self.session.history) - 1)

    # ------------------------------------------------------------------ wiring
    def _wire(self) -> None:
        ui, submit = self.ui, self.worker.submit

        def on(handle, job, *, pause: bool = False, person_only: bool = False, typed: bool = False, method="on_click"):
            """Queue job(event) for a widget event; person_only: skip the updates we make ourselves; typed: the job
            acts on the parameters, so what is being typed into them is taken first."""
            async def callback(event) -> None:
                if person_only and event.client is None:
                    return
                if typed:
                    self.panel.flush()
                if pause:
                    self.playback.pause()
                job(event)
            getattr(handle, method)(callback)

        self._on = on
        on(ui.run.step, self._on_step, typed=True)
        on(ui.run.play, self._on_play, typed=True)
        on(ui.run.end, self._on_run_to_end, typed=True)
        on(ui.run.reset, lambda e: submit(lambda: self._restart(self.session.start_params, e.client), e.client),
           pause=True, typed=True)
        on(ui.params.restart, lambda e: self._on_restart(e.client), pause=True)
        for handle in ui.params.contraction_handles():  # a box is typed key by key; a list or switch is not
            typing = isinstance(handle, viser.GuiTextHandle)
            on(handle, lambda e, typing=typing: self.panel.changed("parameters", e.client, typing), person_only=True,
               method="on_update")
        for part, handle in (("radius", ui.params.radius), ("interval", ui.run.interval)):
            on(handle, lambda e, part=part: self.panel.changed(part, e.client, typing=True), person_only=True,
               method="on_update")
        for handle in (*ui.view.show.values(), *ui.view.size.values(), *ui.view.opacity.values(), ui.view.provisional):
            on(handle, lambda e: submit(self.presenter.apply_view, e.client), person_only=True, method="on_update")
        for handle in (ui.view.colouring, ui.view.colour_original):
            on(handle, lambda e: submit(self.presenter.set_colouring, e.client), person_only=True, method="on_update")
        on(ui.view.fit, lambda e: self.presenter.fit(e.client))
        on(ui.view.up, lambda e: submit(lambda: self.presenter.turn_up(ui.view.up.value, chosen=True), e.client),
           person_only=True, method="on_update")
        on(ui.files.load, self.loader.on_load_asset)
        on(ui.files.upload, self.loader.on_upload, method="on_upload")
        on(ui.files.downsample, self.loader.on_downsample)
        exports = ((ui.files.screenshot, self.delivery.screenshot), (ui.files.animation, self.delivery.animation),
                   (ui.files.bundle, self.delivery.bundle))
        for handle, job in exports:
            on(handle, lambda e, job=job: self._for_viewer(e.client, job))
        shortcuts = {"N": self._on_step, "P": self._on_play,
                     "J": lambda e: self._scrub(e.client, -1), "K": lambda e: self._scrub(e.client, +1),
                     "L": lambda e: self._follow(e.client), "F": lambda e: self.presenter.fit(e.client)}
        for key, job in shortcuts.items():
            command = self.server.gui.add_command(layout.SHORTCUTS[key].capitalize(), hotkey=key)
            on(command, job, typed=key in ("N", "P"), method="on_trigger")

    def _wire_viewer(self, viewer: Viewer) -> None:
        on = self._on
        on(viewer.ui.timeline, lambda e: self._view_iteration(viewer, int(viewer.ui.timeline.value)),
           person_only=True, method="on_update")
        on(viewer.ui.follow, lambda e: self._follow(e.client, bool(viewer.ui.follow.value)), person_only=True,
           method="on_update")
        on(viewer.ui.plots.pin, lambda e: self.worker.submit(lambda: self._pin(viewer), e.client))

    def _for_viewer(self, client, job) -> None:
        viewer = self.presenter.viewer(client)
        if viewer is not None:
            self.worker.submit(lambda: job(viewer), client)

    def _on_step(self, event) -> None:
        self.step_clicked = time.perf_counter()  # when the server got the click (app.bench reads it)
        self.playback.stepped()
        viewer = self.presenter.viewer(event.client)
        self.worker.submit(lambda: self._step(viewer, event.client), event.client)

    def _on_play(self, event) -> None:
        viewer = self.presenter.viewer(event.client)
        self.playback.toggle(lambda: self._play_tick(viewer), event.client)

    def _on_restart(self, client) -> None:
        params = self.panel.parameters(client)
        self.panel.flush()  # the sample radius being typed
        if params is not None:
            self.worker.submit(lambda: self._restart(params), client)

    # ------------------------------------------------------------------ jobs (worker thread only)
    def _step(self, viewer: Viewer | None, client) -> None:
        session = self.session
        with self._computing(client):
            state = session.step()
        if state is None:
            self._notify(client, RUN_ENDED, f"{session.latest.message}. Reset or Restart to run again.",
                         color="yellow")
            return
        newest = len(session.history) - 1
        if viewer is not None and viewer.shown < newest - 1:
            self._notify(client, "Stepped from the newest iteration",
                         f"You were viewing iteration {session.history[viewer.shown].iteration}; Step continues "
                         f"the run from iteration {session.history[newest - 1].iteration}, so your view moves to "
                         f"iteration {session.latest.iteration}.", color="blue")
        if viewer is not None:
            viewer.look_at(newest, newest)  # who steps watches the step
        self._advance(full=True)

    def _computing(self, client, notify: bool = True):
        """The status (and after a second a notification) while a step is computed; nothing when it is ready."""
        session = self.session
        if session.finished or session.ready_ahead:
            return contextlib.nullcontext()
        return self.activity.busy(client, "Step", f"computing iteration {session.latest.iteration + 1}", notify=notify)

    def _look_ahead(self) -> bool:
        """The idle task: the next iteration, its metrics, plots and (when a browser shows it) its skeleton,
        computed while the person looks, so that Step only shows them; a parameter change has them computed
        again."""
        if not self.session.looks_ahead:
            return True
        while not self.presenter.wait_idle(0.05):  # the plots and skeleton of what browsers show come first
            if self.worker.interrupted():
                return False
        skeleton = any(viewer.view.visible["skeleton"] for viewer in self.presenter.all())
        if not self.session.look_ahead(self.worker.interrupted, skeleton=skeleton,
                                       provisional=bool(self.ui.view.provisional.value)) or self.worker.interrupted():
            return False
        self.presenter.prepare_ahead()
        self.presenter.update_statuses()  # says the next iteration is ready
        return True

    def _tick(self, full: bool) -> bool:
        """One Play / Run-to-end iteration; False ends the loop."""
        with self._computing(None, notify=False):
            state = self.session.step(paused=lambda: not self.worker.playing)  # a pause lands between two stages
        going = state is not None and not self.session.finished
        if not going:
            self.playback.pause()
        if state is not None:
            self._advance(full=full or not going)
        return going

    def _play_tick(self, viewer: Viewer | None):
        """What Play does, read as it starts: on an ended run, nothing is left to compute: play it again."""
        if self.session.finished and viewer is not None:
            return lambda: self._replay_tick(viewer)
        return lambda: self._tick(True)

    def _replay_tick(self, viewer: Viewer) -> bool:
        """One iteration of Play on a finished run, in the browser that asked: the next iteration it has not
        shown, from the first when it shows the last; False ends the replay (at the last iteration, or once the
        run or the browser is gone)."""
        if not self.session.finished or viewer not in self.presenter.all():
            self.playback.pause()
            return False
        newest = len(self.session.history) - 1
        index = 0 if viewer.shown >= newest else viewer.shown + 1
        viewer.look_at(index, newest)
        self.presenter.show(viewer, index)
        if index >= newest:
            self.playback.pause()
        return index < newest

    def _advance(self, full: bool) -> None:
        """A new state: the viewers that follow show it, the others learn the run is longer."""
        self.shown = len(self.session.history) - 1
        for viewer in self.presenter.all():
            if viewer.following:
                self.presenter.show(viewer, self.shown, full)
            else:
                self.presenter.update_status(viewer)

    def _tune(self, params, client=None) -> None:
        if self.session.tune(params):
            self.presenter.update_statuses()
        for line in capped_text(params):
            self._notify(client, "Capped", line, color="yellow")

    def _restart(self, params, resetting=None) -> None:
        """Start again with `params`; `resetting`: the browser whose Reset drops the changes typed, told so."""
        dropped = resetting is not None and self.session.pending
        with self.activity.busy(None, "Restarting", "computing the one-rings of iteration 0"):
            self.session.restart(params)
        if dropped:
            self._notify(resetting, "Reset", f"back to iteration 0 with the parameters the run started with; the "
                         f"change typed ({dropped}) is dropped: Restart with these parameters starts with it",
                         color="yellow")
        self.panel.show(self.session.params)
        self._draw_new_run(frame=False)

    def _set_radius(self, radius: float) -> None:
        self.session.set_sample_radius(radius)
        self.presenter.reanalyse()

    def _draw_new_run(self, frame: bool = False) -> None:
        cloud = self.session.cloud
        self.messages.withdraw(RUN_ENDED)  # said of the run this one replaces
        # one line: the status' first line counts the points
        self.ui.run.title.content = f"**skelcore inspector** &middot; {Path(cloud.name).name}"
        if cloud.points is not self._source:  # a new cloud: dense ones start thinned
            # the same points loaded again (an asset reloaded) keep the pinned run to compare with
            reloaded = self._source is not None and np.array_equal(cloud.points, self._source)
            self._source = cloud.points
            if self.presenter.pinned is not None and not reloaded:  # its skeleton and metrics are another object's
                self._unpin()
            opacity = auto_opacity(len(cloud.points))
            self.ui.view.opacity["original"].value = opacity
            self.ui.view.size["original"].value = see_through_size(cloud.points, opacity, POINT_SIZES["original"])
            turned = self.presenter.turn_up(self.presenter.up_of(cloud))  # a new up frames every view anew
            frame = frame and not turned
        frame_camera(self.server.initial_camera, cloud.points, up=UP_AXES[self.ui.view.up.value])
        self.loader.select_loaded()
        self.labels.refresh()
        self.presenter.offer_colourings(cloud.labels is not None)
        self.shown = len(self.session.history) - 1  # iteration 0, or the end of a finished run opened as such
        settings = self.presenter.view_settings()
        for viewer in self.presenter.all():
            viewer.look_at(self.shown, self.shown)  # a new run: its iterations are shown as they come
            for name in ("sizes", "opacity"):
                getattr(viewer.view, name)["original"] = settings[name]["original"]
            viewer.view.load(cloud.points)
            if frame:
                self.presenter.fit(viewer.client)
            self.presenter.update_legend(viewer)
            self.presenter.show(viewer, self.shown)

    # ------------------------------------------------------------------ one viewer's iteration
    def _view_iteration(self, viewer: Viewer, index: int) -> None:
        newest = len(self.session.history) - 1
        index = max(0, min(index, newest))
        viewer.look_at(index, newest)
        self.worker.submit(lambda: self.presenter.show(viewer, index), viewer.client)

    def _scrub(self, client, by: int) -> None:
        viewer = self.presenter.viewer(client)
        if viewer is not None:
            self._view_iteration(viewer, viewer.shown + by)

    def _on_run_to_end(self, event) -> None:
        """Run to end, and show the asker the newest iteration as it comes: the end is what they asked to see (one
        scrubbed back, not following, stayed at an early iteration when the run ended)."""
        self._follow(event.client)
        self.playback.start(lambda: self._tick(False), event.client, full=False)

    def _follow(self, client, follow: bool = True) -> None:
        viewer = self.presenter.viewer(client)
        if viewer is None:
            return
        viewer.follow(follow)
        if follow:
            self.worker.submit(lambda: self.presenter.show(viewer, len(self.session.history) - 1), client)
        else:
            self.worker.submit(lambda: self.presenter.update_status(viewer), client)

    # ------------------------------------------------------------------ compare
    def _pin(self, viewer: Viewer) -> None:
        state = self.session.latest
        with self.activity.busy(viewer.client, "Pinning", f"metrics and skeleton of iteration {state.iteration}"):
            self.presenter.pinned = compare.pin(self.session)
        compare.show_pin(self.presenter.all(), self.presenter.pinned)
        self.session.note(f"pinned the run at iteration {state.iteration} for comparison")
        self.presenter.reanalyse()

    def _unpin(self) -> None:
        self.presenter.pinned = None
        compare.show_pin(self.presenter.all(), None)
        said = "the run compared with was of the cloud before"  # the Compare tab alone went blank without a word
        self.session.note(f"unpinned: {said}")
        self.messages.notify(None, "Unpinned", said, color="blue")

    def _report_error(self, message: str, client, pause: bool = True) -> None:
        """A failed engine job stops Play; a failed analysis (skeleton, metrics) only says so. Server
        paths in the message are cut to their last part: no server path reaches a browser."""
        message = without_paths(message)
        if pause:
            self.playback.pause()
        self.session.note(f"error: {message}")
        self._notify(client, "Error", message)
        self.presenter.update_statuses()
