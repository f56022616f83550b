"""The inspector driven in a real browser: Debian's headless Chromium through Playwright.

One server (in this process, on a free 127.0.0.1 port) and one page serve the whole module; each
test starts from a reset run. Server state is read directly; what the browser shows is read from
its DOM and its canvas. Waits poll with generous limits; nothing asserts on speed.
"""
from __future__ import annotations

import io
import re
import zipfile

import numpy as np
import pytest

from browser_support import (ARTIFACTS, browser_missing, button, canvas_image, click, launch, open_inspector,
                             save_page, set_value, wait_until, write_ply)

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


@pytest.fixture(scope="module")
def page(browser, inspector):
    page = open_inspector(browser, inspector.url)
    # The skeleton of a barely contracted surface is slow to extract: hidden, except where tested.
    page.get_by_label("Show skeleton").uncheck()
    wait_until(lambda: not inspector.view.visible["skeleton"], "the skeleton hidden")
    yield page
    page.context.close()


def drawn(inspector, stage: str) -> int | None:
    """Index of the state whose `stage` ('points', 'plots', 'skeleton') was pushed last, in the current run."""
    run, index, _ = inspector.drawn.get(stage, (None, None, None))
    return index if run is inspector.session.run else None


@pytest.fixture
def fresh(inspector, page):
    """A reset run, drawn in full, before each test."""
    inspector.worker.pause()
    inspector.wait_idle()
    click(page, "Reset")
    wait_until(lambda: len(inspector.session.history) == 1 and drawn(inspector, "plots") == 0
               and inspector.session.latest.params == inspector.session.start_params, "the reset run")
    inspector.wait_idle()
    yield inspector
    inspector.wait_idle()
    assert not [line for line in inspector.session.log if "internal error" in line]


def shown_iteration(page) -> int | None:
    """The iteration number the status panel of this page shows."""
    text = page.locator("p", has_text="computed").first.inner_text()
    match = re.search(r"Iteration (\d+)", text)
    return int(match.group(1)) if match else None


def wait_shown(page, iteration: int) -> None:
    wait_until(lambda: shown_iteration(page) == iteration, f"the page to show iteration {iteration}")


def test_page_loads_and_canvas_renders(fresh, page):
    wait_shown(page, 0)
    image = wait_until(lambda: (lambda im: im if im.std() > 1 else None)(canvas_image(page)), "a drawn canvas")
    canvas_image(page, "browser-loaded-canvas.png")
    save_page(page, "browser-loaded-page.png")
    assert (image != 255).any(axis=-1).mean() > 0.005  # the cloud covers part of the white background


def test_step_advances_state_histograms_and_scene(fresh, page):
    inspector = fresh
    before_image = canvas_image(page)
    before_figure = inspector.hist_theta.figure.to_json()
    click(page, "Step")
    wait_until(lambda: len(inspector.session.history) == 2, "a second state")
    wait_until(lambda: drawn(inspector, "plots") == 1, "iteration 1 drawn")
    wait_shown(page, 1)
    assert inspector.session.latest.iteration == 1
    assert inspector.hist_theta.figure.to_json() != before_figure
    assert inspector.hist_kappa.figure.to_json() != before_figure
    # the contracted points moved in the browser
    after_image = wait_until(lambda: (lambda im: im if np.abs(im.astype(int) - before_image).sum() > 0 else None)(
        canvas_image(page)), "the canvas to change")
    canvas_image(page, "browser-after-step.png")
    assert np.abs(after_image.astype(int) - before_image).max() > 50
    # the histogram plots in the page are live plotly figures
    assert page.locator(".js-plotly-plot").count() >= 3


def test_play_then_pause_stops_advancing(fresh, page):
    inspector = fresh
    set_value(page, "Play interval (s)", 0.5)  # about 20 iterations: 10 s of Play, ample time to pause
    wait_until(lambda: inspector.interval.value == 0.5, "the play interval")
    click(page, "Play")
    button(page, "Pause").wait_for()
    wait_until(lambda: len(inspector.session.history) >= 3, "Play to advance")
    click(page, "Pause")
    button(page, "Play").wait_for()
    wait_until(lambda: not inspector.worker.playing, "the worker to stop")
    inspector.wait_idle()
    stopped_at = len(inspector.session.history)
    assert not inspector.session.finished, "the run ended by itself; the test needs a longer run"
    page.wait_for_timeout(1500)  # a Play still running would have stepped again by now
    assert len(inspector.session.history) == stopped_at
    wait_shown(page, stopped_at - 1)
    page.get_by_text("Run paused").first.wait_for()


def test_weight_change_is_used_by_next_step(fresh, page):
    inspector = fresh
    click(page, "Step")
    wait_until(lambda: len(inspector.session.history) == 2, "iteration 1")
    set_value(page, "s_L", 2.5)
    wait_until(lambda: inspector.session.params.sl == 2.5, "the new s_L to reach the session")
    click(page, "Step")
    wait_until(lambda: len(inspector.session.history) == 3, "iteration 2")
    state = inspector.session.latest
    assert state.params.sl == 2.5
    assert state.wl == pytest.approx(RUN["wl0"] * 2.5 ** (state.iteration - 1))
    assert inspector.session.history[1].params.sl == RUN["sl"]
    assert any("sl=2.5" in line for line in inspector.session.log)
    set_value(page, "s_L", RUN["sl"])  # back, for the next tests
    wait_until(lambda: inspector.session.params.sl == RUN["sl"], "s_L restored")


def test_method_selector_runs_glskeleton(fresh, page):
    inspector = fresh
    page.get_by_label("Method").click()
    page.get_by_role("option", name="glskeleton").click()
    wait_until(lambda: any("method=glskeleton on restart" in line for line in inspector.session.log), "the note")
    click(page, "Restart with these parameters")
    wait_until(lambda: inspector.session.start_params.method == "glskeleton", "the GLSkeleton run")
    click(page, "Step")
    wait_until(lambda: len(inspector.session.history) == 2 and drawn(inspector, "plots") == 1, "iteration 1")
    state = inspector.session.latest
    assert state.n_points < len(inspector.session.cloud.points)  # GLSkeleton merged points
    assert len(inspector.view._contracted.points) == state.n_points
    removed = len(inspector.session.cloud.points) - state.n_points
    page.get_by_text(f"{state.n_points:,} points retained, {removed:,} removed").first.wait_for()
    assert len(inspector.view._removed.points) == removed  # absorbed points drawn in their own colour
    page.screenshot(path=str(ARTIFACTS / "browser-glskeleton-removed.png"))
    page.get_by_label("Method").click()
    page.get_by_role("option", name="lbc").click()
    click(page, "Restart with these parameters")
    wait_until(lambda: inspector.session.start_params.method == "lbc", "back to LBC")


def test_timeline_goes_back(fresh, page):
    inspector = fresh
    for expected in (2, 3):
        click(page, "Step")
        wait_until(lambda: len(inspector.session.history) == expected, f"{expected} states")
    wait_shown(page, 2)
    set_value(page, "Iteration", 0)
    wait_until(lambda: inspector.shown == 0 and drawn(inspector, "plots") == 0, "iteration 0 drawn")
    wait_shown(page, 0)
    assert len(inspector.session.history) == 3  # looking back keeps the later states
    shown = inspector.view._contracted.points
    assert np.allclose(shown, inspector.session.history[0].points.astype(np.float32))


def test_run_to_end_shows_skeleton_and_colours(fresh, page):
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
    last = len(inspector.session.history) - 1
    wait_shown(page, inspector.session.latest.iteration)
    page.get_by_label("Show skeleton").check()
    wait_until(lambda: drawn(inspector, "skeleton") == last, "the skeleton drawn")
    skeleton = inspector.session.skeleton(last)
    assert skeleton.topology()["cycles"] == 1  # the torus keeps its loop
    assert len(inspector.view._nodes.batched_positions) == skeleton.graph.number_of_nodes()
    page.get_by_label("Colour contracted by").click()
    page.get_by_role("option", name="D_theta").click()
    wait_until(lambda: inspector.view._colours_key is not None, "colours by D_theta")
    page.get_by_text("colour scale").first.wait_for()
    page.wait_for_timeout(500)
    canvas_image(page, "browser-skeleton-coloured.png")
    save_page(page, "browser-skeleton-page.png")
    # back to the module's settings
    page.get_by_label("Colour contracted by").click()
    page.get_by_role("option", name="plain").click()
    page.get_by_label("Show skeleton").uncheck()
    set_value(page, "W_L0 (0 = auto)", RUN["wl0"])
    set_value(page, "s_L", RUN["sl"])
    wait_until(lambda: inspector.session.params.sl == RUN["sl"] and inspector.session.params.wl0 == RUN["wl0"],
               "the panel restored")
    click(page, "Restart with these parameters")
    wait_until(lambda: inspector.session.start_params.sl == RUN["sl"] and not inspector.view.visible["skeleton"]
               and inspector.colour_by == "plain", "the module's run")


def test_screenshot_downloads_a_valid_non_blank_png(fresh, page):
    import imageio.v3 as iio

    with page.expect_download() as download:
        click(page, "Screenshot")
    data = open(download.value.path(), "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    ARTIFACTS.mkdir(exist_ok=True)
    (ARTIFACTS / "browser-screenshot-download.png").write_bytes(data)
    image = iio.imread(io.BytesIO(data), extension=".png")
    assert image.shape[:2] == (720, 1280)
    differs = (image[..., :3] != 255).any(axis=-1)  # pixels not the white background
    assert 0.005 < differs.mean() < 0.9


def test_export_bundle_downloads_a_zip(fresh, page):
    click(page, "Step")
    wait_until(lambda: len(fresh.session.history) == 2, "iteration 1")
    with page.expect_download() as download:
        click(page, "Export bundle")
    with zipfile.ZipFile(download.value.path()) as archive:
        names = set(archive.namelist())
        assert {"screenshot.png", "skeleton.json", "skeleton.ply", "contracted.ply", "metrics.json",
                "params.json", "histograms.html"} <= names
        assert archive.read("screenshot.png")[:8] == b"\x89PNG\r\n\x1a\n"


def test_upload_of_a_valid_ply_replaces_the_cloud(fresh, page, tmp_path):
    from skelcore.shapes import make_shape

    inspector = fresh
    original_name, original_points = inspector.session.cloud.name, inspector.session.cloud.points
    path = write_ply(tmp_path / "capsule.ply", make_shape("capsule", 1200).points)
    try:
        with page.expect_file_chooser() as chooser:
            click(page, "Upload cloud")
        chooser.value.set_files(str(path))
        wait_until(lambda: inspector.session.cloud.name == "capsule.ply", "the uploaded cloud")
        wait_until(lambda: drawn(inspector, "plots") == 0 and len(inspector.view._original.points) == 1200,
                   "the new cloud drawn")
        page.get_by_text("capsule.ply", exact=False).first.wait_for()
        assert len(inspector.session.history[0].points) == 1200
        page.wait_for_timeout(500)
        canvas_image(page, "browser-after-upload.png")
    finally:  # back to the module's torus
        from skelcore.io import validate
        inspector.open(validate(original_points, name=original_name))
        wait_until(lambda: inspector.session.cloud.name == original_name, "the torus back")


def test_upload_of_garbage_shows_an_error_and_keeps_serving(fresh, page, tmp_path):
    inspector = fresh
    cloud = inspector.session.cloud
    path = tmp_path / "garbage.ply"
    path.write_bytes(np.random.default_rng(0).integers(0, 256, 4000, dtype=np.uint8).tobytes())
    with page.expect_file_chooser() as chooser:
        click(page, "Upload cloud")
    chooser.value.set_files(str(path))
    page.get_by_text(re.compile(r"garbage\.ply: ")).first.wait_for()
    save_page(page, "browser-upload-error.png")
    inspector.wait_idle()
    assert inspector.session.cloud is cloud
    click(page, "Step")  # still serving the same session
    wait_until(lambda: len(inspector.session.history) == 2, "a step after the failed upload")
    wait_shown(page, 1)


def test_two_browsers_see_one_step(fresh, page, browser):
    inspector = fresh
    other = open_inspector(browser, inspector.url)
    try:
        wait_shown(other, 0)
        click(other, "Step")
        wait_until(lambda: len(inspector.session.history) == 2, "the step from the second browser")
        wait_shown(other, 1)
        wait_shown(page, 1)
        save_page(other, "browser-second-page.png")
    finally:
        other.context.close()
