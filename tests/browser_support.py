"""Drive the inspector in Debian's headless Chromium with Playwright's sync API (never `playwright install`)."""
from __future__ import annotations

import io
import re
import shutil
import time
from pathlib import Path

import numpy as np

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
VIEWPORT = {"width": 1280, "height": 720}
VIEWPORTS = ({"width": 1600, "height": 1000}, {"width": 1280, "height": 720})  # the sizes the checks run at
ARTIFACTS = Path(__file__).resolve().parents[1] / "test-artifacts"
WAIT = 120.0  # seconds: generous, for waiting only (2 shared cores, software WebGL)


def status_line(page):
    """The status's first paragraph: "Iteration N of M computed · run ..." ("Iteration 0 (the input) · ..." before
    the first Step)."""
    return page.locator("p", has_text=re.compile(r"Iteration \d+ ")).first


def browser_missing() -> str | None:
    """Why browser tests cannot run here, or None."""
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "playwright (Python) is not installed"
    if not CHROMIUM.exists() and shutil.which("chromium") is None:
        return f"{CHROMIUM} not found (apt-get install chromium)"
    return None


def launch(playwright):
    executable = CHROMIUM if CHROMIUM.exists() else Path(shutil.which("chromium"))
    return playwright.chromium.launch(executable_path=str(executable), args=CHROMIUM_ARGS)


def open_inspector(browser, url: str, viewport: dict = VIEWPORT):
    """A new page (own context) on the inspector, once its controls and 3-D canvas are up."""
    context = browser.new_context(viewport=viewport, accept_downloads=True)
    page = context.new_page()
    page.set_default_timeout(WAIT * 1000)
    page.goto(url)
    button(page, "Step").wait_for()
    page.locator("canvas[data-engine]").first.wait_for()
    return page


def open_viewer(browser, inspector, url: str, viewport: dict = VIEWPORT):
    """open_inspector on the app.inspector.Inspector serving `url`; the page's own app.viewer.Viewer, the one
    that connected with it, becomes page.viewer, and the inspector page.inspector."""
    before = set(inspector.presenter.viewers)
    page = open_inspector(browser, url, viewport)
    page.viewer = wait_until(lambda: next((viewer for key, viewer in list(inspector.presenter.viewers.items())
                                           if key not in before), None), "the page's viewer")
    page.inspector = inspector
    return page


def button(page, name: str):
    return page.get_by_role("button", name=name, exact=True)


def click(page, name: str) -> None:
    button(page, name).click()


def number_input(page, label: str):
    """The box of a viser number input, slider or text input (the real parameters), found from its label among those
    shown (a tab within a tab keeps its hidden tabs' widgets: Opacity's "Original" and Size's)."""
    typed = "@inputmode='decimal' or (not(@type) or @type='text') and contains(@class, 'TextInput')"
    row = page.locator("label:visible", has_text=label).first.locator(f"xpath=ancestor::*[.//input[{typed}]][1]")
    return row.locator(f"xpath=.//input[{typed}]").first


def set_value(page, label: str, value) -> None:
    box = number_input(page, label)
    box.fill(str(value))
    box.press("Enter")


def open_folder(page, title: str) -> None:
    """Expand a collapsed GUI folder."""
    page.get_by_text(title, exact=True).first.click()


def open_tab(page, *names: str) -> None:
    """Bring a tab of the control panel or the plots panel to the front, then each tab named after it within the one
    before (open_tab(page, "View", "Opacity"))."""
    for name in names:
        page.get_by_role("tab", name=name, exact=True).first.click()


def inside_viewport(page, locator) -> bool:
    """Whether the element's whole box lies inside the page's viewport (nothing to scroll to see it)."""
    box = locator.bounding_box()
    size = page.viewport_size
    return (box is not None and box["x"] >= 0 and box["y"] >= 0 and box["x"] + box["width"] <= size["width"] + 0.5
            and box["y"] + box["height"] <= size["height"] + 0.5)


def overflows(locator) -> bool:
    """Whether the panel holding `locator` has more than it shows (a scrollbar, drawn over its content)."""
    return locator.evaluate("element => { const view = element.closest('.mantine-ScrollArea-viewport');"
                            " return view.scrollHeight > view.clientHeight; }")


def scroll_to_top(locator) -> None:
    """Scroll the panel holding `locator` back to its top, as it opens (an earlier check may have scrolled it)."""
    locator.evaluate("element => { element.closest('.mantine-ScrollArea-viewport').scrollTop = 0; }")


def shown_in_panel(page, locator) -> bool:
    """Whether the element lies inside the window and inside the visible part of the panel holding it (scrolled off
    the panel's top, it can still be inside the window, under the panel's header)."""
    return inside_viewport(page, locator) and locator.evaluate(
        "element => { const panel = element.closest('.mantine-ScrollArea-viewport').getBoundingClientRect();"
        " const box = element.getBoundingClientRect();"
        " return box.top >= panel.top - 0.5 && box.bottom <= panel.bottom + 0.5; }")


def close_browser_notices(page) -> None:
    """Close viser's own notices (e.g. "Software WebGL rendering detected"), which cover the view."""
    for close in page.locator(".mantine-Notification-root button").all():
        try:
            close.click(timeout=2000)
        except Exception:  # already gone
            pass
    page.wait_for_timeout(600)  # the closing animation


def wait_until(predicate, what: str, timeout: float = WAIT, interval: float = 0.05):
    """Poll until predicate() is truthy; return its value. Only a waiting limit, not a speed check."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if isinstance(value, np.ndarray) or value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(interval)


def canvas_image(page, name: str | None = None) -> np.ndarray:
    """Screenshot of the 3-D canvas as an (h,w,3) array; saved under test-artifacts/ when named."""
    import imageio.v3 as iio

    png = page.locator("canvas[data-engine]").first.screenshot()
    if name:
        ARTIFACTS.mkdir(exist_ok=True)
        (ARTIFACTS / name).write_bytes(png)
    return iio.imread(io.BytesIO(png), extension=".png")[..., :3]


def save_page(page, name: str) -> Path:
    ARTIFACTS.mkdir(exist_ok=True)
    path = ARTIFACTS / name
    page.screenshot(path=str(path))
    return path


def write_ply(path: Path, points: np.ndarray) -> Path:
    header = (f"ply\nformat ascii 1.0\nelement vertex {len(points)}\n"
              "property float x\nproperty float y\nproperty float z\nend_header\n")
    path.write_text(header + "\n".join(f"{x:.6f} {y:.6f} {z:.6f}" for x, y, z in points) + "\n")
    return path
