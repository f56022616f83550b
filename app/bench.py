"""`python -m app.bench`: time from a Step click to the scene updated in the browser (not a test).

A headless Chromium (Debian's, through Playwright) clicks Step on an inspector serving a synthetic
cloud. Measured from the moment the server receives the click to the moment the browser has drawn a
frame with the new points: the new points and the status text arrive in one atomic update, so a probe
in the page waits for the status to change and then for two animation frames (the second starts
after the frame with the new points was drawn), and reports the wall clock, which this machine shares
with the server. Also reported: when the server pushed the points, and when the histograms and the
skeleton of that iteration were pushed, and the engine's share of those times: how long the step's solve,
the paper's metrics and the skeleton's extraction took. The skeleton is asked for at every iteration
("Show provisional" ticked), so each click measures it. Each click waits until the server is idle, as a
person looking at each state would; a finished run is reset (untimed).

Two servers are measured: one that computes the next iteration while it waits for Step (the default), and
one that does not (`skel-inspect --no-look-ahead`), which is also what a Step right after a parameter change
costs.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import threading
import time

from skelcore.cli import default_of
from skelcore.io import validate
from skelcore.params import ContractionParams
from skelcore.shapes import make_shape

from .main import serve

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
WAIT = 300.0  # seconds: a waiting limit, not part of any figure
# Resolves with Date.now() once the status panel names the given iteration, or says the run ended (a rejected
# step shows the last iteration again), and a frame was drawn after that: that status arrives with the points,
# after any "busy" line.
PROBE = r"""(iteration) => {
  const status = [...document.querySelectorAll('p')].find(p => /Iteration \d+ /.test(p.textContent));
  const panel = status.parentElement;
  window.__skelDrawn = new Promise(resolve => {
    const observer = new MutationObserver(() => {
      const text = panel.textContent;
      if (!text.includes(`Iteration ${iteration} of`) && !text.includes('run ended')) return;
      observer.disconnect();
      requestAnimationFrame(() => requestAnimationFrame(() => resolve(Date.now() / 1000)));
    });
    observer.observe(panel, {subtree: true, childList: true, characterData: true});
  });
}"""


def run_bench(n_points: int = 10_000, repeats: int = 7, shape: str = "torus", skeleton: bool = True,
              viewport: tuple[int, int] = (1280, 800), look_ahead: bool = True) -> dict:
    """Median seconds from a Step click to the updated scene in the browser, for an n-point cloud."""
    from playwright.sync_api import sync_playwright

    cloud = validate(make_shape(shape, n_points).points, name=f"{shape}-{n_points}")
    server, inspector = serve(cloud, "127.0.0.1", 0, params=ContractionParams(), look_ahead=look_ahead)
    samples = {name: [] for name in ("click_to_pushed", "click_to_drawn", "driver_click_to_drawn", "click_to_plots",
                                     "click_to_skeleton", "engine_step", "engine_metrics", "engine_skeleton",
                                     "engine_ahead")}
    # seconds the engine took, by call (look_ahead: the step, metrics and skeleton computed before the click)
    engine = {"step": [], "metrics_upto": [], "skeleton": [], "look_ahead": []}
    session = inspector.session
    looking_ahead = set()  # threads within look_ahead: what they compute counts as ahead, not after the click
    for name in engine:
        def timed(*args, _call=getattr(session, name), _name=name, **kwargs):
            thread, started = threading.get_ident(), time.perf_counter()
            ahead = thread in looking_ahead
            if _name == "look_ahead":
                looking_ahead.add(thread)
            try:
                return _call(*args, **kwargs)
            finally:
                if _name == "look_ahead":
                    looking_ahead.discard(thread)
                if _name == "look_ahead" or not ahead:
                    engine[_name].append(time.perf_counter() - started)
        setattr(session, name, timed)
    try:
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": viewport[0], "height": viewport[1]})
            page.set_default_timeout(WAIT * 1000)
            page.goto(f"http://127.0.0.1:{server.get_port()}")
            step = page.get_by_role("button", name="Step", exact=True)
            step.wait_for()
            page.get_by_role("tab", name="View", exact=True).first.click()
            if skeleton:
                page.get_by_label("Show provisional").check()
            else:
                page.get_by_label("Show skeleton").uncheck()
            page.get_by_text(re.compile(r"Iteration \d+ ")).first.wait_for()
            inspector.wait_idle(WAIT)
            wall = time.time() - time.perf_counter()  # perf_counter -> wall clock, for the page's times
            for attempt in range(repeats + 1):  # the first click warms up
                if inspector.session.finished:
                    page.get_by_role("button", name="Reset", exact=True).click()
                    _wait(lambda: len(inspector.session.history) == 1)
                    inspector.wait_idle(WAIT)
                    page.wait_for_timeout(200)  # let the page settle on iteration 0
                page.evaluate(PROBE, inspector.session.latest.iteration + 1)
                ahead = sum(engine["look_ahead"])  # what was computed before this click
                for times in engine.values():
                    times.clear()
                driver_click = time.perf_counter()
                step.click()
                drawn = page.evaluate("() => window.__skelDrawn") - wall
                pushed = inspector.wait_drawn("points", driver_click, timeout=WAIT)
                inspector.wait_idle(WAIT)  # histograms and skeleton of that state, before the next click
                if attempt == 0 or pushed is None:
                    continue
                index = pushed[0]
                plots = inspector.wait_drawn("plots", driver_click, index, timeout=0)
                drawn_skeleton = inspector.wait_drawn("skeleton", driver_click, index, timeout=0)
                clicked = inspector.step_clicked
                samples["click_to_pushed"].append(pushed[1] - clicked)
                samples["click_to_drawn"].append(drawn - clicked)
                samples["driver_click_to_drawn"].append(drawn - driver_click)
                if plots is not None:
                    samples["click_to_plots"].append(plots[1] - clicked)
                if drawn_skeleton is not None:
                    samples["click_to_skeleton"].append(drawn_skeleton[1] - clicked)
                samples["engine_step"].append(sum(engine["step"]))
                samples["engine_ahead"].append(ahead)
                samples["engine_metrics"].append(sum(engine["metrics_upto"]))
                if engine["skeleton"]:
                    samples["engine_skeleton"].append(max(engine["skeleton"]))
            browser.close()
    finally:
        inspector.close()
        server.stop()
    result = {"n_points": n_points, "shape": shape, "repeats": repeats, "skeleton_shown": skeleton,
              "viewport": f"{viewport[0]}x{viewport[1]}", "look_ahead": look_ahead, "load_average": os.getloadavg()}
    for name, values in samples.items():
        if values:
            result[f"{name}_median_s"] = statistics.median(values)
            result[f"{name}_s"] = [round(value, 4) for value in values]
    return result


def _wait(condition) -> None:
    deadline = time.monotonic() + WAIT
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError("the inspector did not respond")
        time.sleep(0.02)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.bench", description=__doc__.splitlines()[0])
    width, height = default_of(run_bench, "viewport")
    parser.add_argument("--points", type=int, default=default_of(run_bench, "n_points"))
    parser.add_argument("--repeats", type=int, default=default_of(run_bench, "repeats"))
    parser.add_argument("--shape", default=default_of(run_bench, "shape"))
    parser.add_argument("--hide-skeleton", action="store_true", help="measure with the skeleton layer off")
    parser.add_argument("--viewport", default=f"{width}x{height}", help="browser window size, WIDTHxHEIGHT")
    parser.add_argument("--only", choices=("look-ahead", "no-look-ahead"),
                        help="measure one server only (default: both, one after the other)")
    parser.add_argument("--json", action="store_true", help="print the full results as JSON")
    args = parser.parse_args(argv)
    width, height = (int(value) for value in args.viewport.lower().split("x"))
    modes = [mode for mode in (True, False) if args.only in (None, "look-ahead" if mode else "no-look-ahead")]
    results = [run_bench(args.points, args.repeats, args.shape, skeleton=not args.hide_skeleton,
                         viewport=(width, height), look_ahead=mode) for mode in modes]
    if args.json:
        print(json.dumps(results, indent=1))
        return 0
    for result in results:
        print(f"{result['n_points']} points ({result['shape']}), browser {result['viewport']}, "
              + ("next iteration computed ahead" if result["look_ahead"] else "no look-ahead (--no-look-ahead)")
              + f", median of {result['repeats']} Step clicks (load average "
              f"{' '.join(f'{value:.2f}' for value in result['load_average'])} at the end):")
        print(f"  click received -> points pushed:              {result['click_to_pushed_median_s']:.3f} s")
        print(f"  click received -> scene drawn in the browser: {result['click_to_drawn_median_s']:.3f} s"
              f"  (from the driver's click: {result['driver_click_to_drawn_median_s']:.3f} s)")
        print(f"  click received -> histograms pushed:         {result['click_to_plots_median_s']:.3f} s")
        if "click_to_skeleton_median_s" in result:
            print(f"  click received -> skeleton pushed:           {result['click_to_skeleton_median_s']:.3f} s")
        print(f"  engine after the click: step solve {result['engine_step_median_s']:.3f} s, metrics "
              f"{result['engine_metrics_median_s']:.3f} s", end="")
        if "engine_skeleton_median_s" in result:
            print(f", skeleton extraction {result['engine_skeleton_median_s']:.3f} s", end="")
        print()
        if result["look_ahead"]:
            print(f"  engine before the click (step, metrics, skeleton ahead): {result['engine_ahead_median_s']:.3f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
