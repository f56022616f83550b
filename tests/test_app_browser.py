"""The inspector driven in a real browser: Debian's headless Chromium through Playwright.

One server (in this process, on a free 127.0.0.1 port) serves the whole module; each test starts from a
reset run. The checks of what a person sees (layout, Play label, framed screenshot, animation, compare,
progress, colours) run at 1600x1000 and at 1280x720, each in its own page; the other tests use one
1280x720 page. Server state is read directly; what the browser shows is read from its DOM and its canvas.
Waits poll with generous limits; nothing asserts on speed.
"""
from __future__ import annotations

import io
import re
import threading
import types
import zipfile

import numpy as np
import pytest

from browser_support import (ARTIFACTS, VIEWPORTS, browser_missing, button, canvas_image, click,
                             close_browser_notices, inside_viewport, launch, number_input, open_folder, open_tab,
                             open_viewer, overflows, save_page, scroll_to_top, set_value, shown_in_panel, status_line,
                             wait_until, write_ply)

pytestmark = [pytest.mark.browser, pytest.mark.skipif(browser_missing() is not None, reason=str(browser_missing()))]

# A slow, long run (W_L fixed at 1, s_L = 1): about 20 iterations, so Play has room to be paused.
RUN = dict(wl0=1.0, sl=1.0, max_iterations=200, termination=1e-4)


@pytest.fixture(scope="module")
def inspector():
    from skelcore.io import validate
    from skelcore.params import ContractionParams
    from skelcore.shapes import make_shape

    from app.main import serve

    cloud = validate(make_shape("torus", 1500).points, name="torus.xyz")
    server, inspector = serve(cloud, "127.0.0.1", 0, params=ContractionParams(**RUN))
    inspector.url = f"http://127.0.0.1:{server.get_port()}"
    inspector.module_cloud = cloud  # as loaded (the session holds it cleaned), to reopen after other clouds
    yield inspector
    inspector.close()
    server.stop()


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = launch(playwright)
        yield browser
        browser.close()


def _hide_skeleton(page, inspector) -> None:
    # The skeleton of a barely contracted surface is slow to extract: hidden, except where tested.
    open_tab(page, "View", "Layers")
    page.get_by_label("Show skeleton").uncheck()
    wait_until(lambda: not page.viewer.view.visible["skeleton"], "the skeleton hidden")
    open_tab(page, "Parameters")


@pytest.fixture(scope="module")
def page(browser, inspector):
    page = open_viewer(browser, inspector, inspector.url)
    _hide_skeleton(page, inspector)
    yield page
    page.context.close()


@pytest.fixture(scope="module", params=VIEWPORTS, ids=lambda size: f"{size['width']}x{size['height']}")
def sized(request, browser, inspector):
    """A page of the given size; the module's main page stays open too (two browsers share the run)."""
    page = open_viewer(browser, inspector, inspector.url, request.param)
    _hide_skeleton(page, inspector)
    page.size_name = f"{request.param['width']}x{request.param['height']}"
    yield page
    page.context.close()


def drawn(page, stage: str) -> int | None:
    """Index of the state whose `stage` ('points', 'plots', 'skeleton') was pushed last to this page, in the
    current run."""
    run, index = page.viewer.drawn.get(stage, (None, None))
    return index if run is page.inspector.session.run else None


def _reset(inspector, page) -> None:
    inspector.playback.pause()
    inspector.wait_idle()
    open_tab(page, "Parameters")
    click(page, "Reset")
    wait_until(lambda: len(inspector.session.history) == 1 and drawn(page, "plots") == 0
               and inspector.session.latest.params == inspector.session.start_params, "the reset run")
    inspector.wait_idle()


def _fresh_run(inspector, page, value):
    """A reset run, drawn in full, before the test; no internal error logged after it. Yields `value`."""
    _reset(inspector, page)
    yield value
    inspector.wait_idle()
    assert not [line for line in inspector.session.log if "internal error" in line]


@pytest.fixture
def fresh(inspector, page):
    """A reset run on the default page."""
    yield from _fresh_run(inspector, page, inspector)


@pytest.fixture
def fresh_sized(inspector, sized):
    """A reset run on the page of the parametrised window size."""
    yield from _fresh_run(inspector, sized, sized)


def shown_iteration(page) -> int | None:
    """The iteration number the status panel of this page shows."""
    text = status_line(page).inner_text()
    match = re.search(r"Iteration (\d+)", text)
    return int(match.group(1)) if match else None


def wait_shown(page, iteration: int) -> None:
    wait_until(lambda: shown_iteration(page) == iteration, f"the page to show iteration {iteration}")


def step(inspector, page, count: int = 1) -> None:
    for _ in range(count):
        expected = len(inspector.session.history) + 1
        click(page, "Step")
        wait_until(lambda: len(inspector.session.history) == expected, f"{expected} states")
    inspector.wait_idle()


def upload(page, path) -> None:
    """Upload `path` through the Files tab; notices left by earlier checks (an export's download) are closed
    first, so what the page shows next is this upload's."""
    close_browser_notices(page)
    open_tab(page, "Files", "Open")
    with page.expect_file_chooser() as chooser:
        click(page, "Upload cloud")
    chooser.value.set_files(str(path))


# ---------------------------------------------------------------- the checks, at both sizes

def test_play_then_step_leaves_a_play_button(fresh_sized, inspector):
    page = fresh_sized
    set_value(page, "Play interval (s)", 0.5)
    wait_until(lambda: inspector.playback.interval == 0.5, "the play interval")
    click(page, "Play")
    button(page, "Pause").wait_for()
    wait_until(lambda: len(inspector.session.history) >= 2, "Play to advance")
    click(page, "Step")  # pauses the run, and must say so
    button(page, "Play").wait_for()
    wait_until(lambda: not inspector.worker.playing, "the worker to stop")
    inspector.wait_idle()
    assert button(page, "Pause").count() == 0
    stopped_at = len(inspector.session.history)
    page.wait_for_timeout(1200)  # a Play still running would have stepped again by now
    assert len(inspector.session.history) == stopped_at
    click(page, "Play")  # the button does what it says: it starts Play again
    button(page, "Pause").wait_for()
    wait_until(lambda: len(inspector.session.history) > stopped_at, "Play to start again")
    set_value(page, "Iteration", 0)  # looking back is this browser's own: the run goes on
    wait_shown(page, 0)
    going = len(inspector.session.history)
    wait_until(lambda: len(inspector.session.history) > going or inspector.session.finished, "Play to go on")
    assert inspector.worker.playing or inspector.session.finished
    assert shown_iteration(page) == 0 and button(page, "Pause").count() + inspector.session.finished == 1
    click(page, "Reset")  # pauses too
    button(page, "Play").wait_for()
    wait_until(lambda: not inspector.worker.playing, "the worker to stop")


def _card_edges(page, card) -> list[np.ndarray]:
    """The darkest pixel of each row at the card's left edge and at its right edge (its 1 px border)."""
    import imageio.v3 as iio

    box = card.bounding_box()
    image = iio.imread(page.screenshot(), extension=".png")[..., :3]
    rows = slice(int(box["y"]) + 4, int(box["y"] + box["height"]) - 4)  # clear of the rounded corners
    return [image[rows, x - 1:x + 2].min(axis=(1, 2)) for x in (round(box["x"]), round(box["x"] + box["width"]) - 1)]


def _both_histograms_fit(page) -> None:
    """Both histograms inside the window, the plots panel without a scrollbar, and each wider than the 400 px
    they had in a 420 px panel (the 3-D view keeps room at 1280x720)."""
    plots = page.locator(".js-plotly-plot")
    wait_until(lambda: plots.count() >= 2 and all(inside_viewport(page, plots.nth(i)) for i in range(2)),
               "both histograms inside the window")
    assert not overflows(plots.first)
    for i in range(2):
        assert plots.nth(i).bounding_box()["width"] >= 440
    assert page.locator("canvas[data-engine]").first.bounding_box()["width"] >= 440


def test_both_histograms_and_the_run_controls_fit_the_window(fresh_sized, inspector):
    page = fresh_sized
    open_tab(page, "Histograms")
    page.get_by_text("No verdict.").first.wait_for()  # iteration 0: its verdict line takes two lines
    _both_histograms_fit(page)
    step(inspector, page)
    wait_until(lambda: drawn(page, "plots") == 1, "iteration 1 plotted")
    plots = page.locator(".js-plotly-plot")
    wait_until(lambda: "iteration 1" in plots.first.inner_text(), "the histograms of iteration 1")
    _both_histograms_fit(page)
    titles = [plots.nth(i).inner_text() for i in range(2)]
    assert "D_theta, iteration 1" in titles[0] and "delta_kappa, iteration 1" in titles[1]
    assert "target 0.5" in titles[0] and "target 0" in titles[1]  # the target is marked
    for name in ("Step", "Play"):
        assert inside_viewport(page, button(page, name))
    for i in range(2):  # the plot inside a card leaves its border whole: the right edge drawn like the left
        left, right = _card_edges(page, plots.nth(i).locator("xpath=.."))
        assert np.array_equal(right, left), (left, right)
    scroll_to_top(button(page, "Step"))
    set_value(page, "W_H0", 2)  # a weight tuned live: said below the tabs, nothing moves
    page.locator("strong", has_text="Pending").wait_for()
    for name in ("Step", "Restart with these parameters"):
        assert shown_in_panel(page, button(page, name))
    set_value(page, "W_H0", inspector.session.start_params.wh0)
    wait_until(lambda: not inspector.session.pending, "the weight back")
    # the histogram spans the values and the target (tests/test_report.py checks the fit itself)
    axis = page.viewer.ui.plots.hist_theta.figure.layout.xaxis.range
    values = inspector.session.metrics(1).d_theta
    assert axis[0] <= min(np.nanmin(values), 0.5) and max(np.nanmax(values), 0.5) <= axis[1] <= 1.0 + 1e-9
    # no two legend labels or titles overlap
    texts = page.locator(".js-plotly-plot").first.locator(".legendtext, .gtitle, .g-xtitle")
    boxes = [texts.nth(i).bounding_box() for i in range(texts.count())]
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            overlap = (min(a["x"] + a["width"], b["x"] + b["width"]) - max(a["x"], b["x"]) > 1
                       and min(a["y"] + a["height"], b["y"] + b["height"]) - max(a["y"], b["y"]) > 1)
            assert not overlap, (a, b)
    open_tab(page, "Convergence")
    page.locator(".js-plotly-plot", has_text="Convergence of the means").first.wait_for()
    open_tab(page, "Verdict")  # the table's cells keep apart ("100.0%" ran into "at least 90%")
    cell = page.locator(".verdict td").first
    assert cell.evaluate("cell => parseFloat(getComputedStyle(cell).paddingRight)") > 0
    open_tab(page, "Histograms")
    close_browser_notices(page)
    page.wait_for_timeout(300)
    save_page(page, f"browser-layout-{page.size_name}.png")


def test_a_long_verdict_headline_leaves_both_histograms_in_the_window(fresh_sized, inspector):
    """An unstable verdict naming long criteria, with what to try: its headline took a third line at 1280x720 and
    the plots panel scrolled. It keeps to two lines (app.status.HEADLINE_CHARS), and one longer still is clamped
    there, its whole text on hover."""
    page = fresh_sized
    open_tab(page, "Histograms")
    step(inspector, page)
    wait_until(lambda: drawn(page, "plots") == 1, "iteration 1 plotted")
    inspector.wait_idle()
    names = ["curve-like share of the cloud", "spread against the original", "points inside the original",
             "contraction steps taken", "skeleton loops"]
    criteria = [{"name": name, "value": "1", "threshold": "t", "passed": False, "severity": "unstable", "text": name}
                for name in names]
    headline = page.locator(".headline p").first
    for iteration, hint, clamped in ((12, "1 of the mesh's 2 loops kept: try More > Hold inside", False),
                                     (123, "12 of the solid's 15 loops kept: try More > Hold inside, or Restart "
                                           "with a smaller s_L", True)):
        page.viewer.show_verdict({"label": "unstable", "iteration": iteration, "criteria": criteria}, hint)
        wait_until(lambda: f"Iteration {iteration}: unstable" in headline.inner_text(), "the long headline")
        page.wait_for_timeout(300)
        _both_histograms_fit(page)
        height, line, full = headline.evaluate("p => [p.clientHeight, parseFloat(getComputedStyle(p).lineHeight),"
                                               " p.scrollHeight]")
        assert height <= 2 * line + 1 and (full > height + 1) == clamped, (height, line, full)
        assert hint in page.locator(".headline").first.get_attribute("title")
    close_browser_notices(page)
    save_page(page, f"browser-long-headline-{page.size_name}.png")


# The tabs within View and Files, and in each the widget lowest in it
INNER_TABS = {("View", "Layers"): "Show removed", ("View", "Colour"): "Colour original", ("View", "Opacity"): "Removed",
              ("View", "Size"): "Removed", ("Files", "Open"): "Upload cloud", ("Files", "Export"): "Export bundle",
              ("Files", "Export settings"): "Also save on server"}


def test_the_view_and_files_tabs_fit_under_the_run_controls(fresh_sized):
    """Every control of View and of Files, whichever tab within them is open, is in the window with Step and Play:
    nothing to scroll, so using one of them cannot scroll the run controls away."""
    page = fresh_sized
    for tabs, lowest in INNER_TABS.items():
        open_tab(page, *tabs)
        widget = page.get_by_role("button", name=lowest, exact=True).or_(page.locator("label:visible", has_text=lowest))
        for each in (button(page, "Step"), button(page, "Play"), widget.first):
            assert inside_viewport(page, each), (tabs, each)
        assert not overflows(button(page, "Step")), tabs
    open_tab(page, "Parameters")


def test_the_run_controls_and_restart_fit_the_window_beside_a_large_clouds_status(fresh_sized, inspector,
                                                                                   monkeypatch):
    """The status at its longest: a cloud contracted at reduced resolution, thinned in the view, no skeleton
    yet, a weight and the method pending. The notes on the run fold away below the tabs, with the pending
    changes, so nothing primary leaves the window."""
    page = fresh_sized
    monkeypatch.setattr(inspector.session, "point_budget", 500)  # a large cloud's multi-resolution, cheaply
    click(page, "Reset")
    wait_until(lambda: inspector.session.run.reduction is not None and drawn(page, "plots") == 0, "the reduced run")
    open_tab(page, "View", "Layers")
    page.get_by_label("Show skeleton").check()
    open_tab(page, "Opacity")
    set_value(page, "Contracted", 0.5)
    open_tab(page, "Parameters")
    step(inspector, page)
    page.get_by_label("Method").click()
    page.get_by_role("option", name="GLSkeleton").click()
    set_value(page, "W_H0", 2)
    page.get_by_text("Pending: W_H0 2 from iteration 2; Method GLSkeleton at restart").first.wait_for()
    page.get_by_text("(View: Show provisional)").first.wait_for()
    for name in ("Step", "Play", "Run to end", "Reset", "Restart with these parameters"):
        assert shown_in_panel(page, button(page, name)), name
    assert shown_in_panel(page, number_input(page, "Iteration"))
    # the play interval sits right under the Play it paces, above Run to end and this browser's iteration slider
    interval = page.locator("label", has_text="Play interval (s)").first
    assert inside_viewport(page, interval) and inside_viewport(page, number_input(page, "Play interval (s)"))
    play, row, end = (each.bounding_box() for each in (button(page, "Play"), interval, button(page, "Run to end")))
    assert play["y"] + play["height"] <= row["y"] < row["y"] + row["height"] <= end["y"]
    # the notes open below the controls, moving none of them
    page.get_by_text(f"{len(inspector.session.run.reduction.points):,} voxel centroids").wait_for()
    page.get_by_text("Showing 750 of 1,500 contracted points in the view").wait_for()
    close_browser_notices(page)
    save_page(page, f"browser-large-cloud-status-{page.size_name}.png")
    page.get_by_label("Method").click()
    page.get_by_role("option", name="LBC").click()
    set_value(page, "W_H0", inspector.session.start_params.wh0)
    open_tab(page, "View", "Opacity")
    set_value(page, "Contracted", 1)
    open_tab(page, "Layers")
    page.get_by_label("Show skeleton").uncheck()
    wait_until(lambda: not inspector.session.pending and not page.viewer.view.visible["skeleton"]
               and page.viewer.view.opacity["contracted"] == 1, "the module's settings")
    open_tab(page, "Parameters")


def _status(page):
    """This browser's status (the paragraph naming the iteration, and those after it)."""
    return status_line(page).locator("xpath=..")


def _the_panel_fits_under_the_status(page) -> None:
    """The run controls, this browser's iteration slider and the whole status in the window, and under them the lowest
    widget of every tab (and tab within one): nothing to scroll to, so nothing a person uses scrolls them away."""
    lowest = {("Parameters",): button(page, "Restart with these parameters"),
              ("More",): number_input(page, "Sample radius")}
    lowest.update({tabs: button(page, name).or_(page.locator("label:visible", has_text=name))
                   for tabs, name in INNER_TABS.items()})
    play = page.get_by_role("button", name=re.compile("^(Play|Replay)$"))  # Replay once the run has ended
    run_controls = (*(button(page, name) for name in ("Step", "Run to end", "Reset")), play,
                    number_input(page, "Play interval (s)"), number_input(page, "Iteration"))
    for tabs, widget in lowest.items():
        open_tab(page, *tabs)
        for each in (*run_controls, _status(page), widget.first):
            assert shown_in_panel(page, each), (tabs, each)
    open_tab(page, "Parameters")


def test_the_longest_status_leaves_the_run_controls_and_every_tab_in_the_window(fresh_sized, inspector, monkeypatch):
    """The status at its longest: a ball whose thin handles are held in place, contracted at reduced resolution, its
    run ended at the iteration limit barely contracted with a parameter retuned on the last step; then an earlier
    iteration looked back at, no skeleton yet. Each says its facts in a few short lines, so the run controls, the
    iteration slider, the status and every tab fit the window. The figures the run ended on and what holding a
    handle means are a click away below the tabs, why no skeleton is drawn and what a barely contracted cloud means
    for its skeleton in the legend."""
    from skelcore.io import validate
    from skelcore.solids import solid_shape

    page, session = fresh_sized, inspector.session
    monkeypatch.setattr(session, "point_budget", 5_000)  # a large cloud's multi-resolution, cheaply
    open_tab(page, "View", "Layers")
    page.get_by_label("Show skeleton").check()
    open_tab(page, "Parameters")
    # the default schedule and a low iteration limit, which the next cloud starts with: it ends barely contracted
    set_value(page, "W_L0 (0 = auto)", 0)
    set_value(page, "s_L", 3)
    open_tab(page, "More")
    set_value(page, "Max iterations", 3)
    wait_until(lambda: session.params.wl0 is None and session.params.sl == 3 and session.params.max_iterations == 3,
               "the default schedule, 3 iterations at most")
    inspector.open(validate(solid_shape("thin_handled_ball", 10_000).points, name="handles.xyz"))
    try:
        wait_until(lambda: session.cloud.name == "handles.xyz" and drawn(page, "plots") == 0, "the ball with handles")
        assert session.run.reduction is not None
        step(inspector, page, 2)
        set_value(page, "Termination", 0.001)  # retuned for the last step: the run's end carries a figure
        wait_until(lambda: session.pending, "the termination pending")
        step(inspector, page)
        latest = session.latest
        assert latest.termination == "max_iterations" and latest.anchored > 0 and "retuned" in latest.message
        page.get_by_text("Barely contracted:").first.wait_for()
        _the_panel_fits_under_the_status(page)
        page.get_by_text(f"{latest.anchored:,} held on thin handles").first.wait_for()
        page.get_by_text("barely contracted: the skeleton may not follow the shape").first.wait_for()  # the legend
        assert "run ended: the maximum number of iterations was reached" in _status(page).inner_text()
        close_browser_notices(page)
        save_page(page, f"browser-longest-status-ended-{page.size_name}.png")
        set_value(page, "Iteration", 2)
        page.get_by_text("not following the newest (key L)").first.wait_for()
        page.get_by_text("no skeleton yet (View: Show provisional)").first.wait_for()
        page.get_by_text(re.compile(r"no skeleton yet: \d+% of points curve-like, 50% needed")).first.wait_for()
        _the_panel_fits_under_the_status(page)
        save_page(page, f"browser-longest-status-behind-{page.size_name}.png")
        page.get_by_text(f"{latest.anchored:,} points on thin handles are held in place").first.wait_for()
        page.get_by_text(f"Run ended at iteration 3: {latest.message}.").first.wait_for()
        save_page(page, f"browser-longest-status-notes-{page.size_name}.png")
        open_folder(page, "About this run")  # a click on the title folds the notes away
        page.get_by_text(f"Run ended at iteration 3: {latest.message}.").first.wait_for(state="hidden")
        open_folder(page, "About this run")
    finally:  # the module's settings, cloud and run; this browser follows the newest again
        set_value(page, "Iteration", len(session.history) - 1)
        wait_until(lambda: page.viewer.following, "the newest followed")
        open_tab(page, "View", "Layers")
        page.get_by_label("Show skeleton").uncheck()
        open_tab(page, "Parameters")
        set_value(page, "W_L0 (0 = auto)", RUN["wl0"])
        set_value(page, "s_L", RUN["sl"])
        open_tab(page, "More")
        set_value(page, "Max iterations", RUN["max_iterations"])
        set_value(page, "Termination", RUN["termination"])
        open_tab(page, "Parameters")
        wait_until(lambda: all(f"{name} {value:g}" in session.pending for name, value in
                               (("W_L0", RUN["wl0"]), ("s_L", RUN["sl"]), ("Max iterations", RUN["max_iterations"]),
                                ("Termination", RUN["termination"]))), "the module's parameters, for the next cloud")
        inspector.open(inspector.module_cloud)
        wait_until(lambda: session.cloud.name == inspector.module_cloud.name
                   and session.start_params.replace(**RUN) == session.start_params
                   and not page.viewer.view.visible["skeleton"], "the module's run")
        inspector.wait_idle()


def test_typing_into_any_box_leaves_the_run_controls_in_view(fresh_sized, inspector):
    """Every number box of the Parameters, More and View tabs takes a value, and every export setting a click, with
    Step, Play and this browser's iteration slider in view, the status at its longer (no skeleton yet).
    viser's panel scrolls to a box below the window's edge, and after the caret when the text above the box grows:
    each tab (and tab within one) fits under the status, and the pending changes are said below the tabs."""
    from app.layout import LAYERS, RESOLUTIONS

    page = fresh_sized
    step(inspector, page)
    open_tab(page, "View", "Layers")
    page.get_by_label("Show skeleton").check()
    page.get_by_text("(View: Show provisional)").first.wait_for()
    scroll_to_top(button(page, "Step"))
    start, radius, ui = inspector.session.start_params, inspector.session.sample_radius, inspector.ui
    boxes = {("Parameters",): {"W_L0 (0 = auto)": (2, start.wl0 or 0), "W_H0": (2, start.wh0), "s_L": (2, start.sl)},
             ("More",): {"W_L cap": (1000, start.wl_max), "k (0 = auto)": (12, start.k or 0),
                         "Max iterations": (30, start.max_iterations), "Termination": (0.02, start.termination),
                         "Sample radius": (0.03, radius)},
             ("View", "Opacity"): {layer.capitalize(): (0.5, 1) for layer in LAYERS},
             ("View", "Size"): {layer.capitalize(): (2, 1) for layer in LAYERS}}
    settings = {"Resolution": "800x600", "Burn in labels": False, "Transparent background": True}

    def taken():
        return (inspector.panel.accepted, inspector.session.sample_radius,
                [handle.value for handle in (*ui.view.opacity.values(), *ui.view.size.values())])

    def choose(resolution):
        page.get_by_label("Resolution").click()
        page.get_by_role("option", name=resolution).click()
        wait_until(lambda: ui.files.resolution.value == resolution, f"the resolution {resolution}")

    def tick(label, on):
        page.get_by_label(label).set_checked(on)
        handle = ui.files.labels if label == "Burn in labels" else ui.files.transparent
        wait_until(lambda: handle.value == on, f"{label} {on}")

    controls = (button(page, "Step"), button(page, "Play"), number_input(page, "Iteration"))

    def type_every_box(which: int) -> None:
        """Type each box's value `which` (0: the test's, 1: the module's) and wait for it to be taken before the
        next: typed all at once on a loaded machine, one of them (Max iterations) was once not taken."""
        for tabs, values in boxes.items():
            open_tab(page, *tabs)
            for label, pair in values.items():
                before = taken()
                set_value(page, label, pair[which])
                wait_until(lambda: taken() != before, f"{label} taken")
                assert all(shown_in_panel(page, each) for each in controls), label

    try:
        type_every_box(0)
        page.locator("strong", has_text="Pending").wait_for()
        close_browser_notices(page)
        save_page(page, f"browser-typing-{page.size_name}.png")
        open_tab(page, "Files", "Export settings")
        choose(settings["Resolution"])
        for label in ("Burn in labels", "Transparent background"):
            tick(label, settings[label])
        assert all(shown_in_panel(page, each) for each in controls), "Export settings"
    finally:
        open_tab(page, "Files", "Export settings")
        choose(RESOLUTIONS[0])
        for label in ("Burn in labels", "Transparent background"):
            tick(label, not settings[label])
        type_every_box(1)
        wait_until(lambda: inspector.panel.accepted == start and not inspector.session.pending
                   and inspector.session.sample_radius == radius
                   and set(taken()[2]) == {1}, "the module's settings")
        open_tab(page, "View", "Layers")
        page.get_by_label("Show skeleton").uncheck()
        wait_until(lambda: not page.viewer.view.visible["skeleton"], "the skeleton hidden")
        open_tab(page, "Parameters")


def test_a_value_typed_key_by_key_is_taken_with_no_refusal_on_the_way(fresh, page):
    """viser sends a number box's value at every key: typing 0.02 sends 0 first, which no run takes. It used to be
    refused at once and put back while the person typed on (0.02 became 1.0002); a refusal now waits for the
    person to stop, and the value typed is taken."""
    inspector = fresh
    close_browser_notices(page)
    open_tab(page, "More")
    radius = inspector.session.sample_radius
    for label, text in (("Termination", "2e-2"), ("Sample radius", "0.03")):  # an exponent too: a text box
        number_input(page, label).click()
        page.keyboard.press("Control+A")
        page.keyboard.type(text, delay=50)
    try:
        wait_until(lambda: inspector.panel.accepted.termination == 0.02 and inspector.session.sample_radius == 0.03
                   and not inspector.panel.typing, "the values typed")
        assert number_input(page, "Termination").input_value() == "2e-2"
        assert page.locator(".mantine-Notification-root").count() == 0  # neither refused nor an error
    finally:
        set_value(page, "Termination", RUN["termination"])
        set_value(page, "Sample radius", radius)
        wait_until(lambda: not inspector.session.pending and inspector.session.sample_radius == radius, "restored")
        open_tab(page, "Parameters")


def test_a_value_being_typed_waits_for_the_person_and_a_click_takes_it(fresh, page, monkeypatch):
    """viser sends a number box's value at every key: typing 30 into max iterations sends 3 first, and a step of
    Play used to take the 3 (the run then ended at 3 iterations). A value is taken once the person has stopped
    typing (here when the test says so), and Step clicked right after typing takes the value typed last."""
    from app import panel as panel_module
    from app.inspector import PLAY_INTERVAL

    inspector = fresh
    pauses = []

    class Pause:  # the wait for the person to stop typing, ended by the test
        def __init__(self, seconds, then):
            pauses.append(then)

        def start(self):
            pass

    monkeypatch.setattr(panel_module, "threading", types.SimpleNamespace(Timer=Pause, Lock=threading.Lock))
    session, box = inspector.session, inspector.ui.params.max_iterations
    _take_play_interval(page, inspector, 0.5)  # the pause after typing it never ends here
    try:
        click(page, "Play")
        button(page, "Pause").wait_for()
        open_tab(page, "More")
        number_input(page, "Max iterations").click()
        page.keyboard.press("Control+A")
        page.keyboard.type("3")
        wait_until(lambda: box.value == "3", "the 3 typed")
        going = len(session.history)
        wait_until(lambda: len(session.history) >= going + 2 or session.finished, "two steps of Play after the 3")
        assert not session.finished and session.params.max_iterations == RUN["max_iterations"]
        page.keyboard.type("0")
        wait_until(lambda: box.value == "30", "the 30 typed")
        assert session.params.max_iterations == RUN["max_iterations"]
        click(page, "Step")  # pauses Play and steps, with the value typed last
        wait_until(lambda: not inspector.worker.playing and session.latest.params.max_iterations == 30, "a step with 30")
        inspector.wait_idle()
        assert not session.finished and not inspector.panel.typing
        number_input(page, "Max iterations").click()
        page.keyboard.press("Control+A")
        page.keyboard.type("25")
        wait_until(lambda: box.value == "25", "the 25 typed")
        assert session.params.max_iterations == 30
        pauses[-1]()  # the person stopped typing
        wait_until(lambda: session.params.max_iterations == 25, "the 25 taken")
    finally:
        set_value(page, "Max iterations", RUN["max_iterations"])
        wait_until(lambda: box.value == str(RUN["max_iterations"]), "the module's max iterations typed")
        wait_until(lambda: _flushed(inspector, lambda: session.params.max_iterations == RUN["max_iterations"]),
                   "the module's max iterations")
        _take_play_interval(page, inspector, PLAY_INTERVAL)
        open_tab(page, "Parameters")


def _take_play_interval(page, inspector, seconds: float) -> None:
    """Type the Play interval and have it taken at once, as a click on Step would (`flush`)."""
    set_value(page, "Play interval (s)", seconds)
    wait_until(lambda: inspector.ui.run.interval.value == str(seconds), "the play interval typed")
    wait_until(lambda: _flushed(inspector, lambda: inspector.playback.interval == seconds), "the play interval")


def _flushed(inspector, taken) -> bool:
    """Take what is being typed at once (`flush`, as a click does), then whether `taken()` holds. A box's value
    reaches the server before the panel's callback marks it as being typed, so a single flush can fall between the
    two and leave the value waiting for a pause that the test's stopped timer never ends."""
    inspector.panel.flush()
    return taken()


def _run_state(page) -> str:
    """What the status says the run does: its first line ends "run playing", "run paused", ..."""
    return status_line(page).inner_text().split(" · run ", 1)[-1]


def test_the_play_button_and_the_status_agree_as_play_starts_and_stops(fresh, page, monkeypatch):
    """The button and the status read whether the run plays from one place and change together: Play says Pause
    exactly while the status says playing, even while a step holds the engine (it used to wait for that step)."""
    inspector = fresh
    gate = threading.Event()
    engine_step = inspector.session.step
    monkeypatch.setattr(inspector.session, "step", lambda *args, **kwargs: gate.wait() and engine_step(*args, **kwargs))
    try:
        click(page, "Play")
        button(page, "Pause").wait_for()
        wait_until(lambda: _run_state(page).startswith("playing"), "the status to say the run plays")
        click(page, "Pause")
        button(page, "Play").wait_for()
        wait_until(lambda: not _run_state(page).startswith("playing"), "the status to say the run stopped")
    finally:
        gate.set()
    wait_until(lambda: not inspector.worker.playing, "the worker to stop")
    inspector.wait_idle()
    wait_until(lambda: _run_state(page).startswith("paused"), "the run paused")
    assert button(page, "Play").count() == 1 and button(page, "Pause").count() == 0


def _text_rows(image: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) row of each line of dark text in the left half of a picture's top quarter."""
    corner = image[:image.shape[0] // 4, :image.shape[1] // 2, :3]
    rows = np.flatnonzero((corner < 100).all(axis=-1).any(axis=1))
    breaks = np.flatnonzero(np.diff(rows) > 1)
    return list(zip(rows[np.r_[0, breaks + 1]], rows[np.r_[breaks, len(rows) - 1]]))


def test_screenshot_frames_the_object(fresh_sized, inspector):
    """The whole cloud in the picture with room around it, the labels burned in above it, at least 1/32 of the
    picture's shorter side high: 19 px at 800x600 (they were 17)."""
    import imageio.v3 as iio

    page = fresh_sized
    step(inspector, page, 2)
    for resolution in ("1280x720", "800x600"):
        open_tab(page, "Files", "Export settings")
        page.get_by_label("Resolution").click()
        page.get_by_role("option", name=resolution).click()
        wait_until(lambda: inspector.ui.files.resolution.value == resolution, f"the resolution {resolution}")
        open_tab(page, "Export")
        with page.expect_download() as download:
            click(page, "Screenshot")
        data = open(download.value.path(), "rb").read()
        assert data[:8] == b"\x89PNG\r\n\x1a\n"
        ARTIFACTS.mkdir(exist_ok=True)
        (ARTIFACTS / f"browser-screenshot-{resolution}-{page.size_name}.png").write_bytes(data)
        image = iio.imread(io.BytesIO(data), extension=".png")
        width, height = (int(v) for v in resolution.split("x"))
        assert image.shape[:2] == (height, width)
        lines = _text_rows(image)
        assert len(lines) == 2  # file, method and iteration; the verdict
        assert all(last - first + 1 >= min(width, height) / 32 for first, last in lines), lines
        rows, cols = np.nonzero((image[..., :3] < 235).any(axis=-1))  # not the white background
        below = rows > lines[-1][1] + 2  # the object, below the labels
        margin = 0.03 * min(width, height)
        assert rows[below].max() < height - margin and margin < cols[below].min() and cols[below].max() < width - margin
        assert max(np.ptp(rows[below]), np.ptp(cols[below])) >= 0.5 * min(width, height)
    open_tab(page, "Export settings")
    page.get_by_label("Resolution").click()
    page.get_by_role("option", name="1280x720").click()
    page.get_by_label("Transparent background").check()
    page.get_by_label("Burn in labels").uncheck()
    wait_until(lambda: inspector.ui.files.transparent.value and not inspector.ui.files.labels.value, "the options")
    open_tab(page, "Export")
    with page.expect_download() as download:
        click(page, "Screenshot")
    clear = iio.imread(download.value.path(), extension=".png")
    assert clear.shape[-1] == 4 and clear[0, 0, 3] == 0 and clear[..., 3].max() == 255
    open_tab(page, "Export settings")
    page.get_by_label("Transparent background").uncheck()
    page.get_by_label("Burn in labels").check()
    wait_until(lambda: not inspector.ui.files.transparent.value and inspector.ui.files.labels.value, "restored")


def test_export_animation_downloads_a_gif_and_an_mp4(fresh_sized, inspector, tmp_path):
    import imageio
    import imageio.v3 as iio

    page = fresh_sized
    step(inspector, page, 3)
    open_tab(page, "View", "Colour")
    page.get_by_label("Colour by").click()
    page.get_by_role("option", name="D_theta").click()
    wait_until(lambda: inspector.presenter.colour_by == "D_theta", "colours by D_theta")
    inspector.wait_idle()
    view = page.viewer.view
    coloured = []  # each frame is coloured by its own iteration's D_theta, as the view colours it
    set_colours = view.set_colours
    view.set_colours = lambda key, *rest: coloured.append(key[1]) or set_colours(key, *rest)
    open_tab(page, "Files", "Export")
    downloads = []
    page.on("download", lambda download: downloads.append(download))
    try:
        click(page, "Export animation")
        wait_until(lambda: page.wait_for_timeout(100) or len(downloads) == 2, "two downloads")  # events need the loop
    finally:
        del view.set_colours
        open_tab(page, "View", "Colour")
        page.get_by_label("Colour by").click()
        page.get_by_role("option", name="plain").click()
        wait_until(lambda: inspector.presenter.colour_by == "plain", "plain colours")
    assert list(range(len(inspector.session.history))) == sorted(set(coloured))[:len(inspector.session.history)]
    files = {}
    for download in downloads:
        files[download.suggested_filename.rsplit(".", 1)[1]] = tmp_path / download.suggested_filename
        download.save_as(files[download.suggested_filename.rsplit(".", 1)[1]])
    frames = len(inspector.session.history)
    assert iio.imread(files["gif"], index=None, extension=".gif").shape[0] == frames
    reader = imageio.get_reader(str(files["mp4"]), format="FFMPEG")
    try:
        assert reader.count_frames() == frames
    finally:
        reader.close()
    ARTIFACTS.mkdir(exist_ok=True)
    (ARTIFACTS / f"browser-animation-{page.size_name}.gif").write_bytes(open(files["gif"], "rb").read())
    assert page.viewer.view.drawn_points("contracted") is not None
    assert np.allclose(page.viewer.view.drawn_points("contracted"), inspector.session.latest.points.astype(np.float32))


def test_pinned_run_is_drawn_beside_the_new_one(fresh_sized, inspector, browser):
    from skelcore.io import validate
    from skelcore.shapes import make_shape

    from app.layout import COMPARE_HINT, PIN, PIN_AGAIN

    page = fresh_sized
    step(inspector, page, 2)
    open_tab(page, "Compare")
    before = inspector.presenter.pinned
    plots = page.viewer.ui.plots
    if before is None:  # nothing pinned: the hint alone, no empty plot frames
        assert not plots.compare_convergence.visible and page.locator(".js-plotly-plot:visible",
                                                                      has_text="pinned and current").count() == 0
    page.get_by_role("button", name=re.compile(r"^Pin this run")).click()  # "... instead" once one is pinned
    wait_until(lambda: inspector.presenter.pinned is not None and inspector.presenter.pinned is not before, "the pinned run")
    open_tab(page, "Parameters")
    set_value(page, "s_L", 1.5)
    wait_until(lambda: inspector.session.params.sl == 1.5, "the new s_L")
    click(page, "Restart with these parameters")
    wait_until(lambda: inspector.session.start_params.sl == 1.5 and len(inspector.session.history) == 1, "the new run")
    inspector.wait_idle()
    step(inspector, page, 2)
    wait_until(lambda: drawn(page, "plots") == 2, "the new run plotted")
    assert all(getattr(plots, each).visible for each in ("compare_convergence", "compare_theta", "compare_kappa"))
    names = [trace.name for trace in page.viewer.ui.plots.compare_convergence.figure.data]
    assert any(name.startswith("pinned:") for name in names) and any(name.startswith("current:") for name in names)
    plot = page.locator(".js-plotly-plot", has_text="pinned and current").first
    plot.wait_for()
    wait_until(lambda: "pinned:" in plot.inner_text() and "current:" in plot.inner_text(), "both runs in the legend")
    assert plot.locator(".scatterlayer .trace").count() >= 4  # two runs x two means
    for measure in ("compare_theta", "compare_kappa"):
        assert len(getattr(page.viewer.ui.plots, measure).figure.data) == 2  # final histograms of both runs
    close_browser_notices(page)
    save_page(page, f"browser-compare-{page.size_name}.png")
    later = open_viewer(browser, inspector, inspector.url, VIEWPORTS[1])  # a browser that connects after the pin
    try:
        wait_until(lambda: later.viewer.ui.plots.pin.label == PIN_AGAIN, "the pin on a later browser")
        inspector.wait_idle()
        assert (later.viewer.view._ghost is None) == (inspector.presenter.pinned.skeleton is None)
    finally:
        later.context.close()
    set_value(page, "s_L", RUN["sl"])
    wait_until(lambda: inspector.session.params.sl == RUN["sl"], "s_L restored")
    # the same points loaded again (a bundled asset reloaded): the pinned run is of them, so it stays
    pinned = inspector.presenter.pinned
    inspector.open(inspector.module_cloud)
    inspector.wait_idle()
    assert inspector.presenter.pinned is pinned and page.viewer.ui.plots.pin.label == PIN_AGAIN
    # another cloud: the pinned run is of the one before, so it is let go
    inspector.open(validate(make_shape("capsule", 800).points, name="capsule.xyz"))
    try:
        wait_until(lambda: inspector.session.cloud.name == "capsule.xyz", "the other cloud")
        inspector.wait_idle()
        assert inspector.presenter.pinned is None and page.viewer.view._ghost is None
        assert page.viewer.ui.plots.pin.label == PIN
        assert page.viewer.ui.plots.compare_note.content == COMPARE_HINT
        assert not page.viewer.ui.plots.compare_convergence.figure.data  # the pinned run's curves are gone
        assert not plots.compare_convergence.visible and not plots.compare_kappa.visible
        # said, not only blank: a notice and the Log
        page.get_by_text("the run compared with was of the cloud before").first.wait_for()
        assert "unpinned: the run compared with was of the cloud before" in inspector.session.log
    finally:
        inspector.open(inspector.module_cloud)
        wait_until(lambda: inspector.session.cloud.name == "torus.xyz", "the module's cloud")
        inspector.wait_idle()
    open_tab(page, "Histograms")


@pytest.fixture(scope="module")
def big_torus(tmp_path_factory):
    """A 300,000-point torus as an ASCII PLY (about 9 MB), made once."""
    t = np.random.default_rng(1).uniform(0, 2 * np.pi, (2, 300_000))
    ring = 1.0 + 0.35 * np.cos(t[1])
    points = np.column_stack([ring * np.cos(t[0]), ring * np.sin(t[0]), 0.35 * np.sin(t[1])])
    return write_ply(tmp_path_factory.mktemp("big") / "big-torus.ply", points)


@pytest.mark.parametrize("sized", [VIEWPORTS[1]], indirect=True, ids=["1280x720"])
def test_large_upload_shows_progress(fresh_sized, inspector, big_torus):
    """A 300k upload: viser's progress bar while the bytes arrive, then ours while it is read and its
    one-rings computed (a minute here), never viser's "uploaded successfully". Once: it does not depend on
    the window size, and it is the slowest check."""
    page = fresh_sized
    original = inspector.module_cloud
    seen = {"progress": False, "ours": False, "success": False}
    # Every notification's text as the page shows it, recorded as it changes: on a loaded machine viser's progress
    # bar came and went between two looks 0.05 s apart (CI of 15060be)
    page.evaluate("""() => {
        window.notificationTexts = [];
        new MutationObserver(() => document.querySelectorAll('.mantine-Notification-root')
            .forEach(note => window.notificationTexts.push(note.innerText)))
            .observe(document.body, {subtree: true, childList: true, characterData: true});
    }""")

    def watch() -> bool:
        text = " ".join(page.evaluate("window.notificationTexts.splice(0)"))
        seen["progress"] |= "Uploading big-torus.ply" in text
        seen["ours"] |= "Reading big-torus.ply" in text
        seen["success"] |= "uploaded successfully" in text
        return inspector.session.cloud.name == "big-torus.ply"

    try:
        upload(page, big_torus)
        wait_until(lambda: watch() or None, "the 300k cloud", interval=0.05)
        assert seen["progress"] and seen["ours"], seen
        assert not seen["success"], "viser's 'uploaded successfully' beside ours"
        page.get_by_text("big-torus.ply").first.wait_for()
        assert inspector.session.cloud.cleaning["input_points"] == 300_000  # then cleaned, as skelcore run does
    finally:
        inspector.open(original)
        wait_until(lambda: inspector.session.cloud.name == original.name, "the torus back")
        inspector.wait_idle()


def test_colouring_a_50k_cloud_leaves_no_grey_points(fresh_sized, inspector):
    from skelcore.io import validate
    from skelcore.shapes import make_shape

    from app.colours import LAYER_COLOURS

    page = fresh_sized
    original = inspector.module_cloud
    inspector.open(validate(make_shape("torus", 50_000).points, name="torus-50k.xyz"))
    try:
        wait_until(lambda: inspector.session.cloud.name == "torus-50k.xyz", "the 50k cloud")
        inspector.wait_idle()
        assert page.viewer.view.opacity["original"] < 1  # a dense original starts thinned
        step(inspector, page)
        open_tab(page, "View", "Colour")
        page.get_by_label("Colour by").click()
        page.get_by_role("option", name="D_theta").click()
        wait_until(lambda: page.viewer.view.coloured, "colours by D_theta")
        inspector.wait_idle()
        colours = page.viewer.view.drawn_colours("contracted")
        assert len(colours) == inspector.session.latest.n_points > 49_000
        grey = (colours == np.asarray(LAYER_COLOURS["original"], np.uint8)).all(axis=1)
        assert not grey.any(), f"{grey.sum()} grey points"
        page.get_by_text("show the value of their nearest measured point").first.wait_for()  # the legend says so
        close_browser_notices(page)
        page.wait_for_timeout(500)
        save_page(page, f"browser-coloured-50k-{page.size_name}.png")
    finally:
        page.get_by_label("Colour by").click()
        page.get_by_role("option", name="plain").click()
        wait_until(lambda: inspector.presenter.colour_by == "plain", "plain colours")
        open_tab(page, "Parameters")
        inspector.open(original)
        wait_until(lambda: inspector.session.cloud.name == original.name, "the torus back")
        inspector.wait_idle()


# ---------------------------------------------------------------- behaviour, one page

def test_page_loads_and_canvas_renders(fresh, page):
    wait_shown(page, 0)
    image = wait_until(lambda: (lambda im: im if im.std() > 1 else None)(canvas_image(page)), "a drawn canvas")
    canvas_image(page, "browser-loaded-canvas.png")
    assert (image != 255).any(axis=-1).mean() > 0.005  # the cloud covers part of the white background


def test_step_advances_state_histograms_and_scene(fresh, page):
    inspector = fresh
    before_image = canvas_image(page)
    before_figure = page.viewer.ui.plots.hist_theta.figure.to_json()
    click(page, "Step")
    wait_until(lambda: len(inspector.session.history) == 2, "a second state")
    wait_until(lambda: drawn(page, "plots") == 1, "iteration 1 drawn")
    wait_shown(page, 1)
    assert inspector.session.latest.iteration == 1
    assert page.viewer.ui.plots.hist_theta.figure.to_json() != before_figure
    after_image = wait_until(lambda: (lambda im: im if np.abs(im.astype(int) - before_image).sum() > 0 else None)(
        canvas_image(page)), "the canvas to change")
    assert np.abs(after_image.astype(int) - before_image).max() > 50


def test_keyboard_shortcuts_step_and_scrub(fresh, page):
    inspector = fresh
    page.locator("canvas[data-engine]").first.click()  # focus on the view, not on a text box
    page.keyboard.press("n")
    wait_until(lambda: len(inspector.session.history) == 2, "a step from the N key")
    page.keyboard.press("n")
    wait_until(lambda: len(inspector.session.history) == 3, "a second step")
    wait_shown(page, 2)
    page.keyboard.press("j")
    wait_shown(page, 1)
    assert not page.viewer.following  # looking back stops following the newest
    page.keyboard.press("k")
    wait_shown(page, 2)


def test_pending_change_and_old_view_are_told(fresh, page):
    inspector = fresh
    step(inspector, page, 2)
    set_value(page, "s_L", 2.5)
    page.get_by_text("Pending: s_L 2.5 from iteration 3").first.wait_for()
    set_value(page, "Iteration", 0)
    wait_until(lambda: page.viewer.shown == 0, "iteration 0 shown")
    click(page, "Step")
    page.get_by_text("Stepped from the newest iteration").first.wait_for()
    wait_shown(page, 3)
    state = inspector.session.latest
    # W_L grows by the new s_L from the step it applies to (W_L <- s_L W_L)
    assert state.params.sl == 2.5 and state.wl == pytest.approx(2.5 * inspector.session.history[-2].wl)
    set_value(page, "s_L", RUN["sl"])
    wait_until(lambda: inspector.session.params.sl == RUN["sl"], "s_L restored")


def test_a_refused_value_is_said_in_the_panels_words_and_put_back(fresh, page):
    inspector = fresh
    set_value(page, "W_H0", 0)  # W_H0 must be > 0
    page.get_by_text("W_H0 = '0': must be").first.wait_for()  # as typed, and what is back:
    page.get_by_text("put back to '1'").first.wait_for()
    wait_until(lambda: number_input(page, "W_H0").input_value() == "1", "W_H0 put back to 1")
    set_value(page, "s_L", 1.5)  # a valid change right after is taken, not blocked by the refused one
    wait_until(lambda: inspector.session.params.sl == 1.5, "s_L = 1.5 in the session")
    page.get_by_text("s_L 1.5 from iteration").first.wait_for()
    wait_until(lambda: page.get_by_text("W_H0 = '0': must be").count() == 0, "the refusal taken down: it is past")
    set_value(page, "s_L", RUN["sl"])
    wait_until(lambda: inspector.session.params.sl == RUN["sl"], "s_L restored")


def test_letters_typed_for_a_whole_number_are_refused_in_our_words_and_put_back(fresh, page):
    """k's box was a number box: letters left it blank and the browser sent nothing, so nothing was said."""
    inspector = fresh
    open_tab(page, "More")
    try:
        set_value(page, "k (0 = auto)", "twelve")
        page.get_by_text("k = 'twelve': must be 0 (auto) or a whole number").first.wait_for()
        wait_until(lambda: number_input(page, "k (0 = auto)").input_value() == str(inspector.session.params.k or 0),
                   "k put back")
        set_value(page, "Max iterations", "1e3")
        wait_until(lambda: inspector.session.params.max_iterations == 1000, "1e3 read as 1000")
    finally:
        set_value(page, "Max iterations", RUN["max_iterations"])
        wait_until(lambda: inspector.session.params.max_iterations == RUN["max_iterations"], "max iterations restored")
        open_tab(page, "Parameters")


def test_every_valid_parameter_is_accepted(fresh, page):
    inspector = fresh
    set_value(page, "W_H0", 20)  # valid (> 0): the widget must take it
    wait_until(lambda: inspector.session.params.wh0 == 20, "W_H0 = 20 in the session")
    click(page, "Restart with these parameters")
    wait_until(lambda: inspector.session.start_params.wh0 == 20, "a run with W_H0 = 20")
    step(inspector, page)
    set_value(page, "W_H0", 1)
    wait_until(lambda: inspector.session.params.wh0 == 1, "W_H0 restored")
    click(page, "Restart with these parameters")
    wait_until(lambda: inspector.session.start_params.wh0 == 1, "the module's run")


def test_method_selector_runs_glskeleton(fresh, page):
    """GLSkeleton merges points only where the cloud has contracted to a curve: with W_L0 = 20 the module's thin
    torus is one after its first step, and its second step merges."""
    inspector = fresh
    page.get_by_label("Method").click()
    page.get_by_role("option", name="GLSkeleton").click()
    wait_until(lambda: any("Method GLSkeleton at restart" in line for line in inspector.session.log), "the note")
    set_value(page, "W_L0", 20)
    wait_until(lambda: inspector.session.params.wl0 == 20, "W_L0 = 20 in the session")
    click(page, "Restart with these parameters")
    wait_until(lambda: inspector.session.start_params.method == "glskeleton", "the GLSkeleton run")
    step(inspector, page, 2)
    wait_until(lambda: drawn(page, "plots") == 2, "iteration 2")
    state = inspector.session.latest
    assert state.n_points < len(inspector.session.cloud.points)  # GLSkeleton merged points
    assert len(page.viewer.view.drawn_points("contracted")) == state.n_points
    removed = len(inspector.session.cloud.points) - state.n_points
    page.get_by_text(f"{state.n_points:,} points retained, {removed:,} removed").first.wait_for()
    assert len(page.viewer.view.drawn_points("removed")) == removed  # absorbed points drawn in their own colour
    page.get_by_label("Method").click()
    page.get_by_role("option", name="LBC").click()
    set_value(page, "W_L0", RUN["wl0"])
    wait_until(lambda: inspector.session.params.wl0 == RUN["wl0"], "W_L0 restored")
    click(page, "Restart with these parameters")
    wait_until(lambda: inspector.session.start_params.method == "lbc", "back to LBC")
    wait_until(lambda: inspector.session.start_params.wl0 == RUN["wl0"], "the module's W_L0 again")


def test_timeline_goes_back(fresh, page):
    inspector = fresh
    step(inspector, page, 2)
    wait_shown(page, 2)
    set_value(page, "Iteration", 0)
    wait_until(lambda: page.viewer.shown == 0 and drawn(page, "plots") == 0, "iteration 0 drawn")
    wait_shown(page, 0)
    assert len(inspector.session.history) == 3  # looking back keeps the later states
    assert np.allclose(page.viewer.view.drawn_points("contracted"), inspector.session.history[0].points.astype(np.float32))


def test_no_skeleton_before_the_cloud_has_contracted(fresh, page):
    inspector = fresh
    open_tab(page, "View", "Layers")
    page.get_by_label("Show skeleton").check()
    inspector.wait_idle()
    assert not page.viewer.view.skeleton_drawn  # iteration 0: nothing contracted yet
    page.get_by_text("no skeleton yet (View: Show provisional)").first.wait_for()
    # the legend says why
    page.get_by_text("no skeleton yet: iteration 0 is the input itself, drawn as the contracted points").first.wait_for()
    page.get_by_label("Show provisional").check()
    wait_until(lambda: drawn(page, "skeleton") == 0, "the provisional skeleton")
    page.get_by_text("skeleton drawn provisionally").first.wait_for()
    page.get_by_text("skeleton provisional: iteration 0 is the input itself").first.wait_for()  # the legend says why
    click(page, "Step")  # iteration 1 of this slow run: contracted a little, still a surface
    wait_until(lambda: drawn(page, "skeleton") == 1, "the provisional skeleton of iteration 1")
    page.get_by_text(re.compile(r"skeleton provisional: \d+% of points curve-like, 50% needed")).first.wait_for()
    page.get_by_label("Show provisional").uncheck()
    page.get_by_label("Show skeleton").uncheck()
    wait_until(lambda: not page.viewer.view.visible["skeleton"], "the skeleton hidden")
    inspector.wait_idle()
    assert not page.viewer.view.skeleton_drawn
    open_tab(page, "Parameters")


def test_run_to_end_shows_the_end_to_a_browser_scrubbed_back(fresh, page):
    """Scrubbed back (not following the newest), Run to end left the view at the early iteration when the run
    ended: the end is what was asked for."""
    inspector = fresh
    step(inspector, page, 2)
    set_value(page, "Iteration", 1)
    wait_until(lambda: not page.viewer.following, "scrubbed back")
    click(page, "Run to end")
    wait_until(lambda: inspector.session.finished, "the run to end")
    inspector.wait_idle()
    assert page.viewer.following
    wait_shown(page, inspector.session.latest.iteration)


def test_run_to_end_shows_skeleton(fresh, page):
    """Restart with the default schedule (s_L = 3, automatic W_L0), run to the end, show the skeleton."""
    inspector = fresh
    set_value(page, "W_L0 (0 = auto)", 0)
    set_value(page, "s_L", 3)
    wait_until(lambda: inspector.session.params.sl == 3 and inspector.session.params.wl0 is None, "the panel")
    click(page, "Restart with these parameters")
    wait_until(lambda: inspector.session.start_params.sl == 3 and len(inspector.session.history) == 1, "restart")
    click(page, "Run to end")
    wait_until(lambda: inspector.session.finished, "the run to end")
    inspector.wait_idle()
    button(page, "Replay").wait_for()
    last = len(inspector.session.history) - 1
    wait_shown(page, inspector.session.latest.iteration)
    open_tab(page, "View", "Layers")
    page.get_by_label("Show skeleton").check()
    wait_until(lambda: drawn(page, "skeleton") == last, "the skeleton drawn")
    skeleton = inspector.session.skeleton(last)
    assert skeleton.topology()["cycles"] == 1  # the torus keeps its loop
    assert len(page.viewer.view._nodes.batched_positions) == skeleton.graph.number_of_nodes()
    open_tab(page, "Opacity")
    set_value(page, "Original", 0.3)
    wait_until(lambda: len(page.viewer.view.drawn_points("original")) == int(np.ceil(0.3 * 1500)),
               "the original thinned")  # the opacity is set before the layer is drawn again
    close_browser_notices(page)
    page.wait_for_timeout(500)
    canvas_image(page, "browser-skeleton.png")
    # tuning after the end says it waits for a restart
    open_tab(page, "Parameters")
    set_value(page, "s_L", 2)
    page.get_by_text("s_L 2 at restart (the run has ended)").first.wait_for()
    # back to the module's settings
    open_tab(page, "View", "Opacity")
    set_value(page, "Original", 1)
    open_tab(page, "Layers")
    page.get_by_label("Show skeleton").uncheck()
    open_tab(page, "Parameters")
    set_value(page, "W_L0 (0 = auto)", RUN["wl0"])
    set_value(page, "s_L", RUN["sl"])
    wait_until(lambda: "W_L0 1" in inspector.session.pending and "s_L 1" in inspector.session.pending,
               "the panel restored")  # the run has ended: the changes wait for the restart
    click(page, "Restart with these parameters")
    wait_until(lambda: inspector.session.start_params.sl == RUN["sl"] and inspector.session.start_params.wl0 == 1
               and not page.viewer.view.visible["skeleton"], "the module's run")


def test_export_bundle_downloads_a_zip(fresh, page):
    step(fresh, page)
    open_tab(page, "Files", "Export")
    with page.expect_download() as download:
        click(page, "Export bundle")
    with zipfile.ZipFile(download.value.path()) as archive:
        names = set(archive.namelist())
        assert {"screenshot.png", "skeleton.json", "skeleton.ply", "contracted.ply", "metrics.json",
                "params.json", "histograms.html", "convergence.html"} <= names
        assert archive.read("screenshot.png")[:8] == b"\x89PNG\r\n\x1a\n"
    open_tab(page, "Parameters")


def test_upload_of_a_valid_ply_replaces_the_cloud(fresh, page, tmp_path):
    from skelcore.shapes import make_shape

    inspector = fresh
    original = inspector.module_cloud
    path = write_ply(tmp_path / "capsule.ply", make_shape("capsule", 1200).points)
    try:
        upload(page, path)
        wait_until(lambda: inspector.session.cloud.name == "capsule.ply", "the uploaded cloud")
        wait_until(lambda: drawn(page, "plots") == 0 and len(page.viewer.view.drawn_points("original")) == 1200,
                   "the new cloud drawn")
        page.get_by_text("capsule.ply", exact=False).first.wait_for()
    finally:
        inspector.open(original)
        wait_until(lambda: inspector.session.cloud.name == original.name, "the torus back")
        open_tab(page, "Parameters")


def test_reset_says_it_drops_the_change_typed(fresh, page):
    """Reset goes back to the parameters the run started with, so a change typed and not used yet is dropped: the
    notice says so and names Restart, which starts with it (a walk-through found Reset put a typed s_L back
    without a word)."""
    inspector = fresh
    close_browser_notices(page)
    open_tab(page, "Parameters")
    set_value(page, "s_L", 2)
    wait_until(lambda: "s_L 2" in inspector.session.pending, "the change pending")
    click(page, "Reset")
    page.get_by_text(re.compile(r"the change typed \(s_L 2 from iteration 1\) is dropped: Restart with these "
                                r"parameters starts with it")).first.wait_for()
    wait_until(lambda: not inspector.session.pending and len(inspector.session.history) == 1, "the reset run")
    assert inspector.session.latest.params.sl == RUN["sl"]
    # the box is put back once the restart is done, and reaches the browser a moment after
    wait_until(lambda: number_input(page, "s_L").input_value() == "1", "the box put back")
    close_browser_notices(page)


def test_upload_of_garbage_is_refused_in_our_words(fresh, page, tmp_path):
    from skelcore.formats import FORMATS

    inspector = fresh
    cloud = inspector.session.cloud
    path = tmp_path / "garbage.ply"
    path.write_bytes(np.random.default_rng(0).integers(0, 256, 4000, dtype=np.uint8).tobytes())
    upload(page, path)
    # the file picker offers the formats read (it offered every file)
    assert page.locator("input[type=file]").first.get_attribute("accept") == ",".join(FORMATS)
    page.get_by_text(re.compile(r"garbage\.ply: ")).first.wait_for()
    inspector.wait_idle()
    page.wait_for_timeout(1000)
    notices = " ".join(page.locator(".mantine-Notification-root").all_inner_texts())
    assert "uploaded successfully" not in notices and "index out of range" not in notices
    save_page(page, "browser-upload-error.png")
    assert inspector.session.cloud is cloud
    click(page, "Step")  # still serving the same session
    wait_until(lambda: len(inspector.session.history) == 2, "a step after the failed upload")
    open_tab(page, "Parameters")


def test_upload_with_nan_rows_offers_to_drop_them(fresh, page, tmp_path):
    from skelcore.shapes import make_shape

    inspector = fresh
    original = inspector.module_cloud
    points = make_shape("capsule", 1000).points
    points[[5, 50]] = np.nan
    path = tmp_path / "holes.xyz"
    path.write_text("\n".join(" ".join(f"{v:.6f}" for v in row) for row in points))
    try:
        upload(page, path)
        page.get_by_text("2 of 1000 points are not finite").first.wait_for()
        click(page, "Drop 2 points and load")
        wait_until(lambda: inspector.session.cloud.name == "holes.xyz", "the cloud without its NaN rows")
        assert len(inspector.session.cloud.points) == 998
    finally:
        inspector.open(original)
        wait_until(lambda: inspector.session.cloud.name == original.name, "the torus back")
        open_tab(page, "Parameters")


def test_two_browsers_see_one_step(fresh, page, browser):
    inspector = fresh
    other = open_viewer(browser, inspector, inspector.url)
    try:
        wait_shown(other, 0)
        click(other, "Step")
        wait_until(lambda: len(inspector.session.history) == 2, "the step from the second browser")
        wait_shown(other, 1)
        wait_shown(page, 1)
    finally:
        other.context.close()


def test_each_browser_looks_at_its_own_iteration(fresh, page, browser):
    """Two browsers (two contexts) on one run: one scrubs back and stays there while the other steps; each
    one's status, histograms and points are of its own iteration; the end of the slider, or key L, follows
    the newest again."""
    inspector = fresh
    history = inspector.session.history
    step(inspector, page, 2)
    other = open_viewer(browser, inspector, inspector.url)
    try:
        wait_shown(other, 2)
        set_value(page, "Iteration", 1)
        wait_shown(page, 1)
        click(other, "Step")
        wait_until(lambda: len(inspector.session.history) == 4, "the step from the other browser")
        wait_shown(other, 3)
        inspector.wait_idle()
        page.wait_for_timeout(500)
        assert shown_iteration(page) == 1 and not page.viewer.following and other.viewer.following
        assert drawn(page, "plots") == 1 and drawn(other, "plots") == 3
        assert np.allclose(page.viewer.view.drawn_points("contracted"), history[1].points.astype(np.float32))
        assert np.allclose(other.viewer.view.drawn_points("contracted"), history[3].points.astype(np.float32))
        page.get_by_text("Iteration 1 of 3 computed").first.wait_for()
        page.get_by_text("not following the newest").first.wait_for()
        for each, iteration in ((page, 1), (other, 3)):
            open_tab(each, "Histograms")
            wait_until(lambda: f"D_theta, iteration {iteration}" in each.locator(".js-plotly-plot").first.inner_text(),
                       f"the histogram of iteration {iteration}")
            assert each.viewer.ui.timeline.value == iteration and each.viewer.ui.timeline.max == 3
        set_value(page, "Iteration", 3)  # the end of the slider follows the newest again
        wait_shown(page, 3)
        assert page.viewer.following
        set_value(other, "Iteration", 0)
        wait_shown(other, 0)
        other.locator("canvas[data-engine]").first.click()
        other.keyboard.press("l")  # follow the newest
        wait_shown(other, 3)
        click(page, "Step")
        wait_shown(page, 4)
        wait_shown(other, 4)
    finally:
        other.context.close()


def test_the_legends_node_swatches_look_like_the_lit_balls(browser):
    """Nodes are lit balls, which render duller and shifted in hue (a junction drawn pure orange looked ochre
    beside the Legend's orange): each kind's ball, rendered in Chromium, has the median colour of its swatch
    (NODE_LOOKS), nearer to it than to any other kind's."""
    import viser

    from app.colours import NODE_LOOKS
    from app.scene import SceneView

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    server.on_client_connect(lambda client: setattr(client.camera, "position", (0.0, -6.0, 0.0))
                             or setattr(client.camera, "look_at", (0.0, 0.0, 0.0)))
    try:
        view = SceneView(server.scene)
        view.load(np.array([[-3.0, 0, -1], [3.0, 0, 1]]))  # sets the scale; hidden below
        view.set_visible("original", False)
        view.set_size("skeleton", 4.0)
        kinds = {"end": 1, "path node": 2, "junction": 3, "isolated": 0}  # degrees, left to right
        nodes = np.array([[x, 0.0, 0.0] for x in (-2.25, -0.75, 0.75, 2.25)])
        view.show_skeleton(nodes, np.empty((0, 2), np.int64), np.array(list(kinds.values())))
        context = browser.new_context(viewport={"width": 1200, "height": 500})
        page = context.new_page()
        page.goto(f"http://127.0.0.1:{server.get_port()}")
        page.locator("canvas[data-engine]").first.wait_for()
        close_browser_notices(page)
        wait_until(lambda: page.wait_for_timeout(200) or _balls(canvas_image(page)) == len(kinds), "four balls")
        image = canvas_image(page, "node-looks.png")
        context.close()
    finally:
        server.stop()
    looks = np.array(list(NODE_LOOKS.values()), float)
    for kind, colour in zip(kinds, _ball_colours(image)):
        distances = np.linalg.norm(looks - colour, axis=1)
        assert distances[list(NODE_LOOKS).index(kind)] < 30 and np.argmin(distances) == list(NODE_LOOKS).index(kind), \
            (kind, colour)


def _ball_columns(image: np.ndarray) -> list[np.ndarray]:
    """Column runs of the canvas's middle band that are not background, left to right (left of viser's own panel,
    drawn over the canvas's right side)."""
    band = image[image.shape[0] // 2 - 12: image.shape[0] // 2 + 12, : int(0.7 * image.shape[1])]
    columns = np.flatnonzero((band.astype(int).sum(axis=2) < 700).any(axis=0))
    return [run for run in np.split(columns, np.flatnonzero(np.diff(columns) > 3) + 1) if len(run) > 10]


def _balls(image: np.ndarray) -> int:
    return len(_ball_columns(image))


def _ball_colours(image: np.ndarray) -> list[np.ndarray]:
    """The median colour of each ball's pixels in the canvas's middle band, left to right."""
    band = image[image.shape[0] // 2 - 12: image.shape[0] // 2 + 12].astype(float)
    colours = []
    for run in _ball_columns(image):
        pixels = band[:, run[0]:run[-1] + 1].reshape(-1, 3)
        colours.append(np.median(pixels[pixels.sum(axis=1) < 700], axis=0))
    return colours


def test_a_pictures_points_look_as_large_beside_the_object_as_in_the_view(browser):
    """Three points in a row, seen square-on: in a picture (its narrow lens, its own height) each point spans the
    same share of the row as in the browser's view, within 15%, also when its layer was drawn anew just before
    (a GLSkeleton frame with fewer points). Before, pictures drew points at the live view's lens and canvas (less
    than half their size), and a layer drawn anew 2 pixels wide."""
    import viser

    from app import export
    from app.delivery import Delivery
    from app.scene import SceneView

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    server.on_client_connect(lambda client: setattr(client.camera, "position", (0.0, -8.0, 0.0))
                             or setattr(client.camera, "look_at", (0.0, 0.0, 0.0)))
    try:
        row = np.array([[-1.0, 0, 0], [0.0, 0, 0], [1.0, 0, 0]])
        context = browser.new_context(viewport={"width": 1200, "height": 800})
        page = context.new_page()
        page.goto(f"http://127.0.0.1:{server.get_port()}")
        page.locator("canvas[data-engine]").first.wait_for()
        close_browser_notices(page)
        client = wait_until(lambda: next(iter(server.get_clients().values()), None), "the browser's client")
        view = SceneView(client.scene)
        view.load(row)
        view.set_visible("original", False)
        view.set_size("contracted", 8.0)
        view.show_points("state", row)
        wait_until(lambda: page.wait_for_timeout(200) or len(_red_runs(canvas_image(page))) == 3, "three points")
        live = _red_runs(canvas_image(page))
        camera = export.framed_camera(row, client.camera, 1280, 720)
        viewer = types.SimpleNamespace(client=client, view=view)
        pictured = _red_runs(Delivery.picture(viewer, 1280, 720, camera)[..., :3])
        view.show_points("next", row[[0, 2]])  # a new handle
        view.show_points("again", row)  # and again, rendered at once
        anew = _red_runs(Delivery.picture(viewer, 1280, 720, camera)[..., :3])
        context.close()
    finally:
        server.stop()
    for runs in (pictured, anew):
        assert len(runs) == 3
        assert _point_share(runs) == pytest.approx(_point_share(live), rel=0.15), (live, runs)


def _red_runs(image: np.ndarray) -> list[np.ndarray]:
    """Column runs of contracted-red pixels along the image's middle row, left to right."""
    middle = image[image.shape[0] // 2].astype(int)
    columns = np.flatnonzero((middle[:, 0] > 150) & (middle[:, 1] < 110) & (middle[:, 2] < 110))
    return [] if len(columns) == 0 else np.split(columns, np.flatnonzero(np.diff(columns) > 1) + 1)


def _point_share(runs: list[np.ndarray]) -> float:
    """A point's width over the distance between the outer points' centres."""
    centres = [run.mean() for run in runs]
    return np.mean([len(run) for run in runs]) / (centres[-1] - centres[0])
