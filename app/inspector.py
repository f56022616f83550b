"""The viser inspector: GUI panels and scene for one Session shared by every connected browser.

GUI callbacks are `async`, so they run on viser's event loop in the order the browser sent them; they
only read widget values and queue jobs. Engine calls (step, play, restart, load, export) run on one
worker thread, in that order, so a weight changed just before a Step click is used by that step. The
points of a new state are drawn at once; its metrics, histograms and skeleton follow from an analysis
thread that always works on the state shown last, so a slow skeleton never holds up the run.
"""
from __future__ import annotations

import re
import threading
import time
from pathlib import Path

import viser

from skelcore import report
from skelcore.errors import InputError, ParameterError, TooLargeError
from skelcore.io import FORMATS as INPUT_FORMATS, load, load_bytes
from skelcore.memory import INSPECTOR_SHARE, budget_bytes
from skelcore.params import METHODS
from skelcore.pipeline import write_atomic
from skelcore.verdict import explanation_markdown

from . import export
from .labels import LabelPanel
from .scene import COLOUR_RANGES, SceneView, colour_values, legend_html
from .session import Session
from .upload_guard import UploadGuard
from .worker import Latest, Worker

MAX_UPLOAD_BYTES = 64 * 1024 * 1024
RESOLUTIONS = ("1280x720", "1920x1080", "800x600", "2560x1440")
COLOUR_MODES = ("plain", *COLOUR_RANGES, "label")
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
        self.drawn: dict[str, tuple] = {}  # stage -> (run, index, perf_counter) of its last push
        self.step_clicked = 0.0
        self._drawn_changed = threading.Condition()
        self.worker = Worker(self._report_error)
        self.analyst = Latest(self._analyse,
                              lambda message, client: self._report_error(message, client, pause=False))
        self.upload_guard = UploadGuard(server, max_upload_bytes, self._upload_refused)
        self.offer = None  # (what, read) of a too large cloud offered voxel-downsampled
        server.gui.configure_theme(control_width="large", dark_mode=False)
        self._build_gui()
        self.worker.submit(self._draw_new_run)

    def open(self, cloud) -> None:
        """Replace the session's cloud (a validated skelcore.io.Cloud), as an upload does."""
        self.worker.pause()
        self.worker.submit(lambda: self._load(lambda: cloud))

    def wait_idle(self, timeout: float | None = None) -> bool:
        """Block until queued engine jobs and the analysis of the shown state are done (for tests, benches)."""
        return self.worker.wait_idle(timeout) and self.analyst.wait_idle(timeout)

    def close(self) -> None:
        self.upload_guard.close()
        self.worker.close()
        self.analyst.close()

    # ------------------------------------------------------------------ GUI
    def _build_gui(self) -> None:
        gui = self.server.gui
        self.title = gui.add_markdown("")
        with gui.add_folder("Run"):
            self.step_button = gui.add_button("Step", hint="one iteration")
            self.play_button = gui.add_button("Play", hint="iterate until the run ends or Pause")
            self.end_button = gui.add_button("Run to end", hint="iterate to the end, drawing only the last state")
            self.interval = gui.add_slider("Play interval (s)", min=0.0, max=2.0, step=0.05,
                                           initial_value=PLAY_INTERVAL,
                                           hint="least time between two iterations during Play, to watch them")
            self.reset_button = gui.add_button("Reset",
                                               hint="back to iteration 0 with the parameters this run started with")
            self.timeline = gui.add_slider("Iteration", min=0, max=1, step=1, initial_value=0, disabled=True)
            self.status = gui.add_markdown("")
        with gui.add_folder("Metrics"):
            self.verdict = gui.add_markdown("")
            self.hist_theta = gui.add_plotly(report.empty_figure("D_theta"), aspect=1.4)
            self.hist_kappa = gui.add_plotly(report.empty_figure("delta_kappa"), aspect=1.4)
            self.convergence = gui.add_plotly(report.empty_figure("convergence"), aspect=1.4)
        with gui.add_folder("Parameters"):
            params = self.session.params
            self.method = gui.add_dropdown("Method", METHODS, initial_value=params.method,
                                           hint="applies on Restart")
            self.wl0 = gui.add_number("W_L0 (0 = auto)", initial_value=params.wl0 or 0.0, min=0.0, step=0.01)
            self.wh0 = gui.add_slider("W_H0", min=0.1, max=10.0, step=0.1, initial_value=params.wh0)
            self.sl = gui.add_slider("s_L", min=1.0, max=10.0, step=0.1, initial_value=params.sl)
            self.wl_max = gui.add_number("W_L cap", initial_value=params.wl_max, min=1.0, step=1.0)
            self.k = gui.add_number("k (0 = auto)", initial_value=params.k or 0, min=0, max=200, step=1,
                                    hint="applies on Restart")
            self.max_iterations = gui.add_number("Max iterations", initial_value=params.max_iterations,
                                                 min=1, max=1000, step=1)
            self.termination = gui.add_number("Termination", initial_value=params.termination, min=0.0001,
                                              max=1.0, step=0.0001, hint="stop when the ring-size ratio falls by less")
            self.radius = gui.add_slider("Sample radius", min=0.005, max=0.1, step=0.005,
                                         initial_value=self.session.skeleton_params.sample_radius,
                                         hint="skeleton ball radius, fraction of the bounding-box diagonal")
            self.restart_button = gui.add_button("Restart with these parameters")
        with gui.add_folder("View") as view_folder:
            self.show = {layer: gui.add_checkbox(f"Show {layer}", True)
                         for layer in ("original", "contracted", "skeleton")}
            self.show["removed"] = gui.add_checkbox(
                "Show removed", True, hint="GLSkeleton: input points absorbed by the reduction, at their original places")
            self.size = {layer: gui.add_slider(f"{layer.capitalize()} size", min=0.2, max=5.0, step=0.1,
                                               initial_value=1.0)
                         for layer in ("original", "contracted", "skeleton")}
            self.colouring = gui.add_dropdown("Colour contracted by", COLOUR_MODES, initial_value="plain")
            self.legend = gui.add_html("")
            gui.add_markdown("Skeleton nodes: <span style='color:#1e6eff'>&#9679;</span> end, "
                             "<span style='color:#ff9600'>&#9679;</span> junction, "
                             "<span style='color:#282828'>&#9679;</span> path; "
                             "<span style='color:#8c46dc'>&#9679;</span> removed point (GLSkeleton)")
        self.labels = LabelPanel(gui, self.session, self.worker.submit, self._labels_changed,
                                 order=view_folder.order + 0.5)
        with gui.add_folder("Load"):
            names = tuple(self.assets) or ("(no bundled assets)",)
            self.asset = gui.add_dropdown("Bundled asset", names, disabled=not self.assets)
            self.load_button = gui.add_button("Load asset", disabled=not self.assets)
            self.upload = gui.add_upload_button(
                "Upload cloud", hint=f"{' '.join(INPUT_FORMATS)}, at most {self.max_upload_bytes // 2**20} MiB")
            self.downsample_button = gui.add_button("Load downsampled", visible=False,
                                                    hint="the last cloud too large for this server, voxel-downsampled")
        with gui.add_folder("Export"):
            self.resolution = gui.add_dropdown("Resolution", RESOLUTIONS, initial_value=RESOLUTIONS[0])
            self.save_on_server = gui.add_checkbox(
                "Also save on server", False, disabled=self.save_dir is None,
                hint="into the folder skel-inspect was given with --save-dir" if self.save_dir
                else "start skel-inspect with --save-dir to enable")
            self.shot_button = gui.add_button("Screenshot")
            self.bundle_button = gui.add_button("Export bundle")
        with gui.add_folder("Log", expand_by_default=False):
            self.log = gui.add_markdown("")
        self._wire()

    def _wire(self) -> None:
        submit = self.worker.submit

        @self.step_button.on_click
        async def _(event: viser.GuiEvent) -> None:
            self.step_clicked = time.perf_counter()  # when the server got the click (app.bench reads it)
            self.worker.pause()
            submit(lambda: self._step(event.client), event.client)

        @self.play_button.on_click
        async def _(event: viser.GuiEvent) -> None:
            if self.worker.playing:
                self.worker.pause()
                self.play_button.label = "Play"
                submit(self._update_status)
            else:
                self.play_button.label = "Pause"
                self.worker.play(lambda: self._tick(full=True), event.client, float(self.interval.value))

        @self.end_button.on_click
        async def _(event: viser.GuiEvent) -> None:
            if not self.worker.playing:
                self.play_button.label = "Pause"
                self.worker.play(lambda: self._tick(full=False), event.client)

        @self.reset_button.on_click
        async def _(event: viser.GuiEvent) -> None:
            self.worker.pause()
            submit(lambda: self._restart(self.session.start_params), event.client)

        @self.restart_button.on_click
        async def _(event: viser.GuiEvent) -> None:
            self.worker.pause()
            submit(lambda: self._restart(self._panel_params()), event.client)

        @self.timeline.on_update
        async def _(event: viser.GuiEvent) -> None:
            if event.client is not None:  # a person moved it (our own updates come with no client)
                self.worker.pause()
                index = int(self.timeline.value)
                submit(lambda: self._show(index), event.client)

        for handle in (self.method, self.wl0, self.wh0, self.sl, self.wl_max, self.k, self.max_iterations,
                       self.termination):
            handle.on_update(self._on_parameter)

        @self.radius.on_update
        async def _(event: viser.GuiEvent) -> None:
            if event.client is not None:
                radius = float(self.radius.value)
                submit(lambda: self._set_radius(radius), event.client)

        for box in (*self.show.values(), *self.size.values()):
            box.on_update(self._on_view_change)

        @self.colouring.on_update
        async def _(event: viser.GuiEvent) -> None:
            if event.client is not None:
                mode = self.colouring.value
                submit(lambda: self._set_colouring(mode), event.client)

        @self.load_button.on_click
        async def _(event: viser.GuiEvent) -> None:
            path = self.assets.get(self.asset.value)
            if path is not None:  # only names of files the server listed itself
                self.worker.pause()
                submit(lambda: self._load(lambda voxel=None: load(path, voxel_size=voxel, budget=_budget()),
                                          event.client), event.client)

        @self.upload.on_upload
        async def _(event: viser.GuiEvent) -> None:
            upload = self.upload.value
            if len(upload.content) > self.max_upload_bytes:
                self._notify(event.client, "Upload refused",
                             f"{upload.name}: {len(upload.content) / 2**20:.1f} MiB exceeds the cap of "
                             f"{self.max_upload_bytes / 2**20:.0f} MiB")
                return
            self.worker.pause()
            submit(lambda: self._load(lambda voxel=None: load_bytes(upload.content, upload.name, voxel_size=voxel,
                                                                    budget=_budget()), event.client), event.client)

        @self.downsample_button.on_click
        async def _(event: viser.GuiEvent) -> None:
            if self.offer is not None:
                voxel, read = self.offer
                self.worker.pause()
                submit(lambda: self._load(lambda: read(voxel), event.client), event.client)

        @self.shot_button.on_click
        async def _(event: viser.GuiEvent) -> None:
            submit(lambda: self._send_screenshot(event.client), event.client)

        @self.bundle_button.on_click
        async def _(event: viser.GuiEvent) -> None:
            submit(lambda: self._send_bundle(event.client), event.client)

    async def _on_parameter(self, event: viser.GuiEvent) -> None:
        if event.client is None:
            return
        try:
            params = self._panel_params()
        except ParameterError as error:
            self._notify(event.client, "Parameter refused", str(error))
            return
        self.worker.submit(lambda: self._tune(params), event.client)

    async def _on_view_change(self, event: viser.GuiEvent) -> None:
        if event.client is None:
            return
        visible = {layer: bool(box.value) for layer, box in self.show.items()}
        sizes = {layer: float(slider.value) for layer, slider in self.size.items()}

        def apply() -> None:
            for layer in visible:
                if visible[layer] != self.view.visible[layer]:
                    self.view.set_visible(layer, visible[layer])
                    if layer == "skeleton" and visible[layer]:  # computed only while it is shown
                        self.analyst.request((self.session.run, self.shown))
            for layer in sizes:
                if sizes[layer] != self.view.sizes[layer]:
                    self.view.set_size(layer, sizes[layer])
        self.worker.submit(apply, event.client)

    def _panel_params(self):
        """The parameters the panel shows, on top of the run's (fields the panel lacks stay)."""
        return self.session.params.replace(
            method=self.method.value, k=int(self.k.value) or None, wl0=float(self.wl0.value) or None,
            wh0=float(self.wh0.value), sl=float(self.sl.value), wl_max=float(self.wl_max.value),
            max_iterations=int(self.max_iterations.value), termination=float(self.termination.value))

    def _show_params(self, params) -> None:
        """Put a run's parameters into the panel (no client: the callbacks ignore it)."""
        self.method.value = params.method
        self.wl0.value = params.wl0 or 0.0
        self.wh0.value = params.wh0
        self.sl.value = params.sl
        self.wl_max.value = params.wl_max
        self.k.value = params.k or 0
        self.max_iterations.value = params.max_iterations
        self.termination.value = params.termination

    # ------------------------------------------------------------------ jobs (worker thread only)
    def _step(self, client) -> None:
        if self.session.step() is None:
            self._notify(client, "Run has ended", f"{self.session.latest.message}. Reset or Restart to run again.",
                         color="yellow")
            return
        self._show(len(self.session.history) - 1)

    def _tick(self, full: bool) -> bool:
        """One Play / Run-to-end iteration; False ends the loop. A pause lands between two stages."""
        state = self.session.step(paused=lambda: not self.worker.playing)
        going = state is not None and not self.session.finished
        if not going:
            self.play_button.label = "Play"
        if state is not None:
            self._show(len(self.session.history) - 1, full=full or not going)
        return going

    def _tune(self, params) -> None:
        message = self.session.tune(params)
        if message:
            self._update_status()

    def _restart(self, params) -> None:
        self.session.restart(params)
        self._show_params(self.session.params)
        self._draw_new_run(frame=False)

    def _load(self, read, client=None) -> None:
        try:
            cloud = read()  # an InputError leaves the session as it was
        except TooLargeError as error:
            self.offer = (error.voxel_size, read)
            self.downsample_button.label = f"Load downsampled (voxel {error.voxel_size:g})"
            self.downsample_button.visible = True
            raise InputError(f"{error}: press '{self.downsample_button.label}' in Load") from None
        self.offer = None
        self.downsample_button.visible = False
        self.session.load(cloud)
        self._draw_new_run(frame=True)
        if cloud.notes:
            self._notify(client, f"Loaded {Path(cloud.name).name}", "; ".join(cloud.notes), color="blue")

    def _set_radius(self, radius: float) -> None:
        self.session.set_skeleton_params(self.session.skeleton_params.replace(sample_radius=radius))
        self.analyst.request((self.session.run, self.shown))

    def _set_colouring(self, mode: str) -> None:
        self.colour_by = mode
        self.legend.content = (legend_html(mode) if mode in COLOUR_RANGES
                               else self.labels.legend_html() if mode == "label" else "")
        if mode not in COLOUR_RANGES:
            self._set_fixed_colours(self.session.run, self.shown)
        self.analyst.request((self.session.run, self.shown))

    def _set_fixed_colours(self, run, index: int) -> None:
        """Colours that need no metrics: plain, or by label."""
        colours = self.labels.colours(run.history[index].point_ids) if self.colour_by == "label" else None
        self.view.set_colours((run, index), colours, self.colour_by)

    def _labels_changed(self) -> None:
        if self.colour_by == "label":
            self.legend.content = self.labels.legend_html()
        self._update_status()

    def _draw_new_run(self, frame: bool = False) -> None:
        cloud = self.session.cloud
        self.title.content = (f"**skelcore inspector** &middot; {Path(cloud.name).name} "
                              f"&middot; {len(cloud.points):,} points")
        self.view.load(cloud.points)
        self.view.frame_camera(self.server.initial_camera)
        if frame:
            for client in self.server.get_clients().values():
                self.view.frame_camera(client.camera)
        self.labels.refresh()
        if self.colour_by == "label":
            self.legend.content = self.labels.legend_html()
        self._show(len(self.session.history) - 1)  # iteration 0, or the end of a finished run opened as such

    def _show(self, index: int, full: bool = True) -> None:
        """Draw history[index]: the points and the status now; metrics, plots and skeleton follow from
        the analysis thread (full=False: points only, as Run to end does on its way)."""
        session = self.session
        index = max(0, min(index, len(session.history) - 1))
        run, state = session.run, session.history[index]
        self.shown = index
        with self.server.atomic():
            self.view.show_points((run, index), state.points)
            self.view.show_removed((run, index), self.session.cloud.points[state.removed_ids])
            if self.colour_by not in COLOUR_RANGES:
                self._set_fixed_colours(run, index)
            self._update_status()
        self.server.flush()
        self._mark("points", run, index)
        if full:
            self.analyst.request((run, index))

    def _current(self, run, index: int) -> bool:
        return run is self.session.run and index == self.shown

    def _analyse(self, request) -> None:
        """Analysis thread: metrics, plots and colours of a shown state, then its skeleton."""
        run, index = request
        if not self._current(run, index):
            return
        history = self.session.metrics_upto(index, run)
        verdict = self.session.verdict(index, run)
        figures = (report.histogram_figure(history[-1], "d_theta", iteration=run.history[index].iteration),
                   report.histogram_figure(history[-1], "delta_kappa", iteration=run.history[index].iteration),
                   report.convergence_figure(history))
        mode, colours = self.colour_by, None
        if mode in COLOUR_RANGES:
            colours = colour_values(report.per_point_values(history[-1], mode), mode)
        if not self._current(run, index):
            return
        with self.server.atomic():
            self.hist_theta.figure, self.hist_kappa.figure, self.convergence.figure = figures
            self.verdict.content = explanation_markdown(verdict)
            if mode in COLOUR_RANGES and mode == self.colour_by:  # other modes are set when the points are
                self.view.set_colours((run, index), colours, mode)
        self.server.flush()
        self._mark("plots", run, index)
        if not self.view.visible["skeleton"]:
            self.view.clear_skeleton()  # hidden: computed when shown again
            return
        skeleton = self.session.skeleton(index, run)
        if self._current(run, index):
            self.view.show_skeleton(skeleton.nodes_array(), skeleton.edges_array(), skeleton.degrees())
            self.server.flush()
            self._mark("skeleton", run, index)
        # The skeleton's own checks complete the verdict once it exists.
        verdict = self.session.verdict(index, run, with_skeleton=index > 0)
        if self._current(run, index):
            self.verdict.content = explanation_markdown(verdict)
            self.server.flush()

    # ------------------------------------------------------------------ panels
    def _update_status(self) -> None:
        session, index = self.session, self.shown
        state, latest = session.history[index], session.latest
        self.timeline.max = max(1, len(session.history) - 1)
        self.timeline.value = index
        self.timeline.disabled = len(session.history) < 2
        if latest.termination:
            run = f"ended at iteration {latest.iteration}: {latest.message}"
        elif self.worker.playing:
            run = "running"
        else:
            run = "paused" if len(session.history) > 1 else "ready"
        notice = self.view.notice(state.n_points)
        removed = len(state.owner) - state.n_points
        counts = (f"{state.n_points:,} points retained, {removed:,} removed" if removed
                  else f"{state.n_points:,} points")
        self.status.content = "\n\n".join(filter(None, [
            f"**Iteration {state.iteration}** of {latest.iteration} computed &middot; {counts}",
            notice and f"_{notice}_",
            f"W_L = {state.wl:.4g} &middot; W_H in [{state.wh.min():.3g}, {state.wh.max():.3g}] "
            f"&middot; ring-size ratio a_t = {state.ring_ratio:.4f}",
            f"Run {run}",
        ]))
        self.log.content = "\n".join(f"- {line}" for line in session.log[-LOG_LINES:])

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

    # ------------------------------------------------------------------ export
    def _render(self, client: viser.ClientHandle | None) -> bytes:
        client = client or next(iter(self.server.get_clients().values()), None)
        if client is None:
            raise InputError("screenshot: no browser is connected to render the view")
        width, height = (int(v) for v in self.resolution.value.split("x"))
        rgba = client.get_render(height, width, transport_format="png", timeout=120)
        return export.png_bytes(rgba)

    def _stem(self) -> str:
        """The name of exported files: the cloud's, made safe for any file system and shortened."""
        name = re.sub(r"[^A-Za-z0-9._-]+", "_", Path(self.session.cloud.name).stem).strip("._-")
        return f"{name[:SAVE_NAME_LENGTH] or 'cloud'}-it{self.session.history[self.shown].iteration:03d}"

    def _send_screenshot(self, client) -> None:
        png = self._render(client)
        name = f"{self._stem()}.png"
        self._deliver(client, name, png)

    def _send_bundle(self, client) -> None:
        png = self._render(client)
        data = export.bundle(self.session, self.shown, png)
        self._deliver(client, f"{self._stem()}.zip", data)

    def _deliver(self, client, name: str, data: bytes) -> None:
        if client is not None:
            client.send_file_download(name, data, save_immediately=True)
        if self.save_dir is not None and self.save_on_server.value:
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

    def _upload_refused(self, client_id: int, name: str, reason: str) -> None:
        client = self.server.get_clients().get(client_id)
        if client is not None:
            self._notify(client, "Upload refused", f"{Path(name).name}: {reason}")

    def _report_error(self, message: str, client, pause: bool = True) -> None:
        """A failed engine job stops Play; a failed analysis (skeleton, metrics) only says so. Server
        paths in the message are cut to their last part: no server path reaches a browser."""
        message = without_paths(message)
        if pause:
            self.worker.pause()
            self.play_button.label = "Play"
        self.session.note(f"error: {message}")
        self._notify(client, "Error", message)
        self._update_status()


def without_paths(message: str) -> str:
    """`message` with every absolute path cut to its file name."""
    return re.sub(r"(?<![\w.])/(?:[^\s/:;,'\"()]+/)+([^\s/:;,'\"()]*)", r"\1", message)


def _budget() -> int:
    """The memory a run in the inspector may take: a smaller share of the machine than the command line's."""
    return budget_bytes(INSPECTOR_SHARE)
