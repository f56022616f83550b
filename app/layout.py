"""Where the inspector's widgets live. Three places, so the plots stay readable beside the controls:

- the control panel (docked right): the run controls and status on top, then tabs Parameters | More | View | Files |
  Log, and Labels for a cloud with labels (Parameters: the weights and Restart; More: the less-used parameters; View
  and Files: tabs of their own; Labels: app.labels), below them the parameter changes waiting for a step or a
  restart and the notes on the run (open; a click on the title folds them). viser's panel is one scroll area: a box
  below the window's edge is reached by scrolling the run controls off its top, and a box being typed into is
  scrolled back into view when the text above it grows. So each tab, and each tab within one, fits a 1280x720 window
  under the run controls and the status at its longest (tabs, not folders: an open folder adds its height; the
  status keeps to a few lines, app.status), and what changes as a person types (the pending changes) or is seldom
  read (the notes) sits below the tabs;
- the plots panel (docked left): tabs Histograms (both histograms under a one-line verdict) | Convergence |
  Verdict (each criterion, threshold, value, pass or fail) | Compare; a new view of the metrics is one more
  `with panel.add_tab(...)` in `build_plots`;
- the legend, a small window floating over the 3-D view (bottom left), so it stays on screen.

The run, its parameters and the view settings are shared by every browser (`build`, on the server's GUI).
What shows one iteration is each browser's own (`build_viewer`, on that client's GUI): the iteration
slider, Follow newest, the status, the plots panel and the legend, so each browser can look at its own
iteration of the shared run. Each builder returns a plain dataclass of handles; app.inspector and
app.viewer wire them. The contraction's parameters are text boxes read as typed (app.words.typed_number): viser's
number box drops the "e" of 1e3 and leaves letters blank without a word, where a text box's value can be refused
in our words.
"""
from __future__ import annotations

from dataclasses import dataclass

import viser

from skelcore import report
from skelcore.display import DEFAULT_UP, UP_AXES
from skelcore.io import FORMATS as INPUT_FORMATS
from skelcore.params import ContractionParams

from .words import METHOD_LABELS, box_label, label, number_text

# px, fixed: viser sizes a docked panel in px only and tells the server no window size (its camera reports the
# canvas in device pixels). 470 is about the widest at which both histograms, under iteration 0's two-line
# verdict, fit a 720 px high window without the panel scrolling; dragged wider by a person, the plots follow.
PLOTS_WIDTH = 470
CONTROLS_WIDTH = 340
# The canvas between the two panels in the smallest window the inspector is laid out for, 1280x720 (width, height):
# a browser tells its canvas only once connected, so a cloud is first framed for this one (at 0.75, the canvas of
# a 1600x1000 window, the animal's head reached the controls' edge at 1280x720)
NARROWEST_CANVAS = (1280 - PLOTS_WIDTH - CONTROLS_WIDTH, 720)
HISTOGRAM_ASPECT = 0.62  # viser draws a plot width * aspect high
# Every figure in the plots panel takes a clear paper: viser draws a plot as wide as its card's outside (1 px borders
# included), so a white one would paint over the card's right border.
CARD = dict(paper_bgcolor="rgba(0,0,0,0)")
PIN, PIN_AGAIN = "Pin this run", "Pin this run instead"  # the Compare tab's button, before and after a pin
# the Play button's label: what a click does (on an ended run it shows the run again, from iteration 0)
PLAY, PAUSE, REPLAY = "Play", "Pause", "Replay"
COMPARE_TITLES = ("convergence, pinned and current", "final D_theta", "final delta_kappa")  # the Compare tab's plots
NO_ASSET = "(choose an asset)"  # the asset list's first entry while the cloud loaded is none of them
PROVISIONAL = "Show provisional"  # the View tab's checkbox that draws a skeleton before the cloud is curve-like
COMPARE_HINT = "Pin a run, change parameters or method, Restart: both runs show here."
RESOLUTIONS = ("1280x720", "800x600", "1600x1000", "1920x1080", "2560x1440")
LAYERS = ("original", "contracted", "skeleton", "removed")
# "removed": the input points a GLSkeleton reduction absorbed, drawn at their input places. After a few steps
# they are most of the input, and shown they would hide the contraction: on request only
HIDDEN_AT_START = ("removed",)
COLOUR_BY = ("plain", "D_theta", "delta_kappa", "label")  # "label" offered only for a cloud with labels
SHORTCUTS = {"N": "Step", "P": "Play / Pause", "J": "previous iteration", "K": "next iteration",
             "L": "follow the newest iteration", "F": "fit the view"}


@dataclass
class RunControls:
    title: viser.GuiMarkdownHandle
    step: viser.GuiButtonHandle
    play: viser.GuiButtonHandle
    end: viser.GuiButtonHandle
    reset: viser.GuiButtonHandle
    interval: viser.GuiTextHandle
    viewer_order: float  # where each browser's own iteration slider and status go: below Reset


@dataclass
class ViewerControls:
    """One browser's: the iteration it shows, whether it follows the newest, its status, plots and legend."""
    timeline: viser.GuiSliderHandle
    follow: viser.GuiCheckboxHandle
    status: viser.GuiMarkdownHandle
    notes_folder: viser.GuiFolderHandle
    notes: viser.GuiMarkdownHandle  # app.status.run_notes, below the tabs
    plots: "PlotWidgets"
    legend: viser.GuiHtmlHandle
    plots_panel: object
    legend_panel: object


@dataclass
class ParameterWidgets:
    method: viser.GuiDropdownHandle
    wl0: viser.GuiTextHandle  # every number in a text box (_typed)
    wh0: viser.GuiTextHandle
    sl: viser.GuiTextHandle
    wl_max: viser.GuiTextHandle
    k: viser.GuiTextHandle
    max_iterations: viser.GuiTextHandle
    termination: viser.GuiTextHandle
    hold_curves: viser.GuiCheckboxHandle
    hold_inside: viser.GuiCheckboxHandle
    radius: viser.GuiTextHandle
    restart: viser.GuiButtonHandle

    def number_boxes(self) -> dict[str, viser.GuiTextHandle]:
        """The contraction's number boxes by the ContractionParams field each holds."""
        return {"wl0": self.wl0, "wh0": self.wh0, "sl": self.sl, "wl_max": self.wl_max, "k": self.k,
                "max_iterations": self.max_iterations, "termination": self.termination}

    def contraction_handles(self) -> tuple:
        return (self.method, *self.number_boxes().values(), self.hold_curves, self.hold_inside)


@dataclass
class ViewWidgets:
    show: dict[str, viser.GuiCheckboxHandle]
    opacity: dict[str, viser.GuiSliderHandle]
    size: dict[str, viser.GuiSliderHandle]
    provisional: viser.GuiCheckboxHandle
    colouring: viser.GuiDropdownHandle
    colour_original: viser.GuiCheckboxHandle
    fit: viser.GuiButtonHandle
    up: viser.GuiDropdownHandle


@dataclass
class FileWidgets:
    asset: viser.GuiDropdownHandle
    load: viser.GuiButtonHandle
    upload: viser.GuiUploadButtonHandle
    downsample: viser.GuiButtonHandle
    resolution: viser.GuiDropdownHandle
    labels: viser.GuiCheckboxHandle
    transparent: viser.GuiCheckboxHandle
    save_on_server: viser.GuiCheckboxHandle
    screenshot: viser.GuiButtonHandle
    animation: viser.GuiButtonHandle
    bundle: viser.GuiButtonHandle


@dataclass
class PlotWidgets:
    verdict_line: viser.GuiMarkdownHandle  # the verdict in one line, above the histograms
    verdict: viser.GuiMarkdownHandle  # each criterion, its threshold, this iteration's value, pass or fail
    hist_theta: viser.GuiPlotlyHandle
    hist_kappa: viser.GuiPlotlyHandle
    convergence: viser.GuiPlotlyHandle
    pin: viser.GuiButtonHandle
    compare_note: viser.GuiMarkdownHandle
    compare_convergence: viser.GuiPlotlyHandle
    compare_theta: viser.GuiPlotlyHandle
    compare_kappa: viser.GuiPlotlyHandle

    def show_compare_plots(self, shown: bool) -> None:
        """The Compare tab's plots, hidden until a run is pinned: before, three empty frames said nothing."""
        for plot in (self.compare_convergence, self.compare_theta, self.compare_kappa):
            plot.visible = shown


@dataclass
class Layout:
    run: RunControls
    params: ParameterWidgets
    view: ViewWidgets
    files: FileWidgets
    log: viser.GuiMarkdownHandle
    pending: viser.GuiMarkdownHandle  # the parameter changes waiting for a step or a restart, below the tabs
    notes_order: float  # where each browser's notes on the run go: below the pending changes
    tabs: viser.GuiTabGroupHandle  # app.labels adds its "Labels" tab for a cloud with labels


def build(gui: viser.GuiApi, params: ContractionParams, sample_radius: float, *, play_interval: float,
          assets: tuple[str, ...], max_upload_mib: int, save_dir) -> Layout:
    gui.configure_theme(control_width="medium", dark_mode=False, show_share_button=False)
    gui.main_panel.dock_right()
    gui.main_panel.set_width(CONTROLS_WIDTH)
    run = build_run_controls(gui, play_interval)
    tabs = gui.add_tab_group()
    parameters = build_parameters(gui, tabs, params, sample_radius)
    pending = gui.add_markdown("", order=tabs.order + 0.2)
    with tabs.add_tab("View"):
        view = build_view(gui)
    with tabs.add_tab("Files"):
        files = build_files(gui, assets, max_upload_mib, save_dir)
    with tabs.add_tab("Log"):
        gui.add_markdown("Shortcuts: " + ", ".join(f"**{key}** {what}" for key, what in SHORTCUTS.items()))
        log = gui.add_markdown("")
    return Layout(run, parameters, view, files, log, pending, notes_order=tabs.order + 0.4, tabs=tabs)


def build_run_controls(gui: viser.GuiApi, play_interval: float) -> RunControls:
    title = gui.add_markdown("")
    step = gui.add_button("Step", hint="one iteration (key N)")
    play = gui.add_button(PLAY, hint="iterate until the run ends or Pause; once it has ended, replay it (key P)")
    # right under the Play it paces, not under Reset and the per-browser widgets that follow it
    # no hint: a box's tooltip stands over the row above it, here Step and Play, while the box has the focus
    interval = _typed(gui, "play_interval", play_interval)
    end = gui.add_button("Run to end", hint="iterate to the end, drawing only the last state")
    reset = gui.add_button("Reset", hint="back to iteration 0 with the parameters this run started with")
    return RunControls(title, step, play, end, reset, interval, viewer_order=reset.order)


def build_viewer(gui: viser.GuiApi, order: float, notes_order: float) -> ViewerControls:
    """One client's widgets (`gui`: client.gui), the run's ones placed just after `order`, the notes on the run at
    `notes_order`."""
    # a one-line hint: its tooltip covers the buttons above (Run to end, Reset) while the box has the focus
    timeline = gui.add_slider("Iteration", min=0, max=1, step=1, initial_value=0, disabled=True, marks=((0, "0"),),
                              hint="keys J and K", order=order + 0.2)
    follow = gui.add_checkbox("Follow newest", True, hint="show each new iteration as it is computed (key L)",
                              order=order + 0.4)
    status = gui.add_markdown("", order=order + 0.6)
    # Open: what was done to a person's data is read, not found; the last thing in the panel, it moves no control
    with gui.add_folder("About this run", order=notes_order, visible=False) as notes_folder:
        notes = gui.add_markdown("")
    plots_panel = gui.add_panel()
    plots = build_plots(gui, plots_panel)
    plots_panel.dock_left()
    plots_panel.set_width(PLOTS_WIDTH)
    legend_panel = gui.add_panel()
    with legend_panel.add_tab("Legend"):
        legend = gui.add_html("")
    legend_panel.float(x=12, y=-12, width=300)
    return ViewerControls(timeline, follow, status, notes_folder, notes, plots, legend, plots_panel, legend_panel)


def _typed(gui: viser.GuiApi, name: str, value: float, hint: str | None = None):
    """A text box: a number box, a slider's too, would turn a typed 1e-3 into -13 (viser's drops the "e") and
    leave letters blank without a word; words.typed_number reads it, and a refusal is said."""
    return gui.add_text(box_label(name), initial_value=number_text(value), hint=hint)


def build_parameters(gui: viser.GuiApi, tabs: viser.GuiTabGroupHandle, params: ContractionParams,
                     sample_radius: float) -> ParameterWidgets:
    """Tabs Parameters (the contraction schedule and Restart) and More (the rest): a tab, not a folder, so that
    with either one open every box fits a 1280x720 window under the run controls."""
    with tabs.add_tab("Parameters"):
        method = gui.add_dropdown(label("method"), tuple(METHOD_LABELS.values()),
                                  initial_value=METHOD_LABELS[params.method], hint="applies on Restart")
        wl0 = _typed(gui, "wl0", params.wl0 or 0.0)
        wh0 = _typed(gui, "wh0", params.wh0)
        sl = _typed(gui, "sl", params.sl)
        restart = gui.add_button("Restart with these parameters")
    with tabs.add_tab("More"):
        wl_max = _typed(gui, "wl_max", params.wl_max)
        k = _typed(gui, "k", params.k or 0, hint="applies on Restart")
        max_iterations = _typed(gui, "max_iterations", params.max_iterations)
        termination = _typed(gui, "termination", params.termination, hint="stop when the ring-size ratio falls by less")
        hold_curves = gui.add_checkbox(label("hold_curves"), params.hold_curves,
                                       hint="points the first step brought to a thin part's axis keep that W_L, and "
                                            "handles thinner than a skeleton ball stay in place: small handles and "
                                            "limb ends survive")
        hold_inside = gui.add_checkbox(label("hold_inside"), params.hold_inside,
                                       hint="points a step would take out of the original solid go to its medial "
                                            "surface instead: keeps a bore's loop that contraction closes (a tube "
                                            "taller than wide), with spurs")
        radius = _typed(gui, "sample_radius", sample_radius,
                        hint="skeleton ball radius, fraction of the bounding-box diagonal")
    return ParameterWidgets(method, wl0, wh0, sl, wl_max, k, max_iterations, termination, hold_curves, hold_inside,
                            radius, restart)


def build_view(gui: viser.GuiApi) -> ViewWidgets:
    """Fit view over tabs Layers | Colour | Opacity | Size | Up: tabs, not folders, so that with any one open the View
    tab fits a 1280x720 window under the run controls (its eight sliders unfolded did not)."""
    fit = gui.add_button("Fit view", hint="point the camera at the whole cloud (key F)")
    tabs = gui.add_tab_group()
    with tabs.add_tab("Layers"):
        show = {layer: gui.add_checkbox(f"Show {layer}", layer not in HIDDEN_AT_START) for layer in LAYERS}
        provisional = gui.add_checkbox(PROVISIONAL, False, order=show["skeleton"].order + 0.5,
                                       hint="draw the skeleton before the cloud is curve-like (it means little then)")
    with tabs.add_tab("Colour"):
        colouring = gui.add_dropdown("Colour by", COLOUR_BY, initial_value="plain",
                                     hint="per-point metric of the shown iteration, or the cloud's labels")
        colour_original = gui.add_checkbox("Colour original", False,
                                           hint="colour each original point by its metric value")
    opacity, size = {}, {}
    with tabs.add_tab("Opacity"):
        for layer in LAYERS:
            opacity[layer] = gui.add_slider(layer.capitalize(), min=0.05, max=1.0, step=0.05, initial_value=1.0,
                                            hint="share of the points drawn, faded to match")
    with tabs.add_tab("Size"):
        for layer in LAYERS:
            size[layer] = gui.add_slider(layer.capitalize(), min=0.2, max=5.0, step=0.1, initial_value=1.0)
    with tabs.add_tab("Up"):
        up = gui.add_dropdown("Up axis", tuple(UP_AXES), initial_value=DEFAULT_UP,
                              hint="the scene's up, which the camera orbits about (glTF files: +Y, by their format)")
    return ViewWidgets(show, opacity, size, provisional, colouring, colour_original, fit, up)


def build_files(gui: viser.GuiApi, assets: tuple[str, ...], max_upload_mib: int, save_dir) -> FileWidgets:
    """Tabs Open | Export | Export settings, so that with any one open the Files tab fits a 1280x720 window under the
    run controls (the exports and their settings unfolded did not)."""
    tabs = gui.add_tab_group()
    with tabs.add_tab("Open"):
        names = assets or ("(no bundled assets)",)
        asset = gui.add_dropdown("Bundled asset", names, disabled=not assets)
        load = gui.add_button("Load asset", disabled=not assets)
        # the file picker offers the formats the engine reads (a name it cannot read is still refused in words)
        upload = gui.add_upload_button("Upload cloud", mime_type=",".join(INPUT_FORMATS),
                                       hint=f"{' '.join(INPUT_FORMATS)}, at most {max_upload_mib} MiB")
        downsample = gui.add_button("Load downsampled", visible=False,
                                    hint="the last cloud too large for this server, voxel-downsampled")
    with tabs.add_tab("Export"):
        screenshot = gui.add_button("Screenshot", hint="a PNG framed on the object")
        animation = gui.add_button("Export animation", hint="a GIF and an MP4 of the run, one frame per iteration")
        bundle = gui.add_button("Export bundle", hint="zip: screenshot, skeleton, contracted points, metrics, plots")
    with tabs.add_tab("Export settings"):
        resolution = gui.add_dropdown("Resolution", RESOLUTIONS, initial_value=RESOLUTIONS[0])
        labels = gui.add_checkbox("Burn in labels", True,
                                  hint="iteration, method and verdict in the picture, and the colour bar")
        transparent = gui.add_checkbox("Transparent background", False)
        # greyed out without --save-dir, its label says why (a hint shows only on hovering); the hyphens do not wrap
        save_on_server = gui.add_checkbox(
            "Also save on server" if save_dir else "Also save on server (needs \u2011\u2011save\u2011dir)", False,
            disabled=save_dir is None,
            hint=f"into {save_dir}" if save_dir else "start skel-inspect with --save-dir to enable")
    return FileWidgets(asset, load, upload, downsample, resolution, labels, transparent, save_on_server, screenshot, animation,
                       bundle)


def empty_plot(title: str):
    """A plot with nothing to show yet, on the plots panel's clear paper."""
    return report.empty_figure(title).update_layout(CARD)


def build_plots(gui: viser.GuiApi, panel) -> PlotWidgets:
    def plot(title: str, aspect: float) -> viser.GuiPlotlyHandle:
        return gui.add_plotly(empty_plot(title), aspect=aspect, config=report.PLOTLY_CONFIG)

    with panel.add_tab("Histograms"):
        verdict_line = gui.add_markdown("")
        hist_theta = plot("D_theta", HISTOGRAM_ASPECT)
        hist_kappa = plot("delta_kappa", HISTOGRAM_ASPECT)
    with panel.add_tab("Convergence"):
        convergence = plot("convergence", 1.15)
    with panel.add_tab("Verdict"):
        verdict = gui.add_markdown("")
    with panel.add_tab("Compare"):
        pin = gui.add_button(PIN, hint="keep this run to compare the next ones with it")
        compare_note = gui.add_markdown(COMPARE_HINT)
        compare_convergence = plot(COMPARE_TITLES[0], 1.15)
        compare_theta = plot(COMPARE_TITLES[1], HISTOGRAM_ASPECT)
        compare_kappa = plot(COMPARE_TITLES[2], HISTOGRAM_ASPECT)
    widgets = PlotWidgets(verdict_line, verdict, hist_theta, hist_kappa, convergence, pin, compare_note,
                          compare_convergence, compare_theta, compare_kappa)
    widgets.show_compare_plots(False)
    return widgets
