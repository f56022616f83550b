"""skelcore.inspect from a script: a page headless Chromium loads, a finished Result opened at its end, a labelled
cloud's Labels panel (weights applied on restart, colours by label), and a handle that stops the server."""
from __future__ import annotations

import urllib.request

import numpy as np
import pytest

import skelcore
from skelcore.shapes import make_shape

from browser_support import (browser_missing, button, launch, number_input, open_tab, open_viewer, save_page,
                             set_value, shown_in_panel, wait_until)

browser_needed = pytest.mark.skipif(browser_missing() is not None, reason=str(browser_missing()))


@pytest.fixture(scope="module")
def labelled():
    points = make_shape("y_branch", 1200).points
    return points, (points[:, 2] < np.median(points[:, 2])).astype(np.int64)


def test_inspect_a_result_opens_at_its_end_and_stops(labelled):
    points, labels = labelled
    result = skelcore.skeletonize(points, labels=labels, label_weights={1: 4.0})
    with skelcore.inspect(result) as handle:
        session = handle.session
        assert [s.iteration for s in session.history] == [s.iteration for s in result.states]
        assert np.array_equal(session.run.weights, result.weights)
        assert handle.inspector.wait_idle(120) and handle.inspector.shown == len(result.states) - 1
        assert urllib.request.urlopen(handle.url, timeout=30).status == 200
        assert handle.url in handle._repr_html_()
        session.restart()  # a restart recomputes with the same label weights
        assert np.array_equal(session.run.weights, result.weights)
    assert handle.stopped
    with pytest.raises(OSError):
        urllib.request.urlopen(handle.url, timeout=5)


@pytest.mark.browser
@browser_needed
def test_inspect_serves_a_page_a_browser_loads_with_the_labels_panel(labelled):
    from playwright.sync_api import sync_playwright

    points, labels = labelled
    handle = skelcore.inspect(points, labels=labels, label_weights={1: 2.0}, max_iterations=3)
    try:
        with sync_playwright() as playwright:
            browser = launch(playwright)
            page = open_viewer(browser, handle.inspector, handle.url)
            page.get_by_text("Labels", exact=True).first.wait_for()
            open_tab(page, "Labels")
            weight = number_input(page, "Label 1 (")
            assert weight.input_value() == "2"
            set_value(page, "Label 1 (", "1e-2")  # a number box sent 1-2 of it
            wait_until(lambda: handle.session.label_weights == {1: 0.01}, "an exponent read as a number")
            set_value(page, "Label 1 (", "0")
            page.get_by_text("the weight of label 1 = '0': must be a positive number").first.wait_for()
            page.get_by_text("put back to '0.01'").first.wait_for()
            wait_until(lambda: weight.input_value() == "0.01", "the refused weight put back")
            assert handle.session.label_weights == {1: 0.01}
            set_value(page, "Label 1 (", "6")
            wait_until(lambda: handle.session.label_weights == {1: 6.0}, "the label weight taken")
            button(page, "Restart with these weights").click()  # in the Labels tab, beside the weights
            wait_until(lambda: handle.session.run.weights is not None and handle.session.run.weights.max() == 6.0,
                       "the restart with the new weight")
            open_tab(page, "View", "Colour")
            page.get_by_label("Colour by").click()
            page.get_by_role("option", name="label").click()
            wait_until(lambda: page.viewer.view.coloured, "colours by label")
            page.get_by_text("(w=6)").first.wait_for()  # the legend
            colours = np.asarray(page.viewer.view.drawn_colours("contracted"))
            assert len(np.unique(colours.reshape(-1, 3), axis=0)) == 2
            save_page(page, "inspect_labels.png")
            small = open_viewer(browser, handle.inspector, handle.url, {"width": 1280, "height": 720})
            open_tab(small, "Labels")  # its boxes under the run controls, as every tab's: typing scrolls nothing away
            for widget in (button(small, "Step"), button(small, "Play"), number_input(small, "Label 1 ("),
                           button(small, "Restart with these weights")):
                assert shown_in_panel(small, widget)
            browser.close()
    finally:
        handle.stop()


@pytest.mark.browser
@browser_needed
def test_a_cloud_with_more_labels_than_boxes_sets_each_weight_by_choosing_its_label(labelled):
    """Ten labels: one weight box, for the label chosen from a list (a box each would not fit a 1280x720 window);
    a weight typed and the label changed at once is the typed label's, and each keeps its own."""
    from playwright.sync_api import sync_playwright

    from app.labels import MAX_WEIGHT_INPUTS

    points, _ = labelled
    labels = np.digitize(points[:, 2], np.quantile(points[:, 2], np.linspace(0, 1, 11)[1:-1])).astype(np.int64)
    assert len(np.unique(labels)) > MAX_WEIGHT_INPUTS
    handle = skelcore.inspect(points, labels=labels, max_iterations=3)
    try:
        with sync_playwright() as playwright:
            browser = launch(playwright)
            page = open_viewer(browser, handle.inspector, handle.url, {"width": 1280, "height": 720})
            open_tab(page, "Labels")

            def choose(label: int) -> None:
                page.get_by_label("Label", exact=True).click()
                page.get_by_role("option", name=f"Label {label} (").click()

            choose(7)
            weight = number_input(page, "Weight")
            weight.click()
            page.keyboard.press("Control+A")
            page.keyboard.type("3", delay=50)
            choose(2)  # at once: the 3 is label 7's
            wait_until(lambda: handle.session.label_weights == {7: 3.0}, "label 7's weight taken")
            wait_until(lambda: weight.input_value() == "1", "label 2's weight shown")
            set_value(page, "Weight", "5e-1")
            wait_until(lambda: handle.session.label_weights == {7: 3.0, 2: 0.5}, "label 2's weight taken")
            choose(7)
            wait_until(lambda: weight.input_value() == "3", "label 7's weight shown again")
            restart = button(page, "Restart with these weights")
            for widget in (button(page, "Step"), button(page, "Play"), weight, restart):
                assert shown_in_panel(page, widget)
            browser.close()
    finally:
        handle.stop()


def test_inspect_a_result_opens_with_its_sample_radius_and_the_parameters_its_states_ran_with():
    """A result skeletonised at its own sample radius shows the same skeleton; one the pipeline ran again held
    inside (its options still say hold_inside off) opens with Hold inside on, so Reset runs what the states show."""
    import dataclasses

    from skelcore.api import Result
    from skelcore.io import validate
    from skelcore.options import RunOptions
    from skelcore.pipeline import compute

    points = make_shape("torus", 1500, seed=0).points
    result = skelcore.skeletonize(points, sample_radius=0.05)
    with skelcore.inspect(result) as handle:
        session = handle.session
        assert session.sample_radius == 0.05
        last = len(session.history) - 1
        assert session.skeleton(last).radius == result.skeleton.radius
        assert session.skeleton(last).graph.number_of_nodes() == result.skeleton.graph.number_of_nodes()
    options = RunOptions()
    held = compute(validate(points, name="torus"), dataclasses.replace(
        options, params=options.params.replace(hold_inside=True)))
    result = Result(held.cloud, held.states, held.skeleton, held.metrics, options)
    with skelcore.inspect(result) as handle:
        assert handle.session.params.hold_inside and handle.inspector.ui.params.hold_inside.value


def test_inspect_a_result_contracted_at_reduced_resolution_runs_it_again_reduced():
    """Its states carry every input point but not the reduced rings skeletons are made from, so the inspector
    contracts it again, reduced as the run was (its budget), from iteration 0."""
    from skelcore.api import Result
    from skelcore.io import validate
    from skelcore.options import RunOptions
    from skelcore.pipeline import compute

    options = RunOptions(point_budget=1500)
    computed = compute(validate(make_shape("torus", 3000, seed=0).points, name="torus"), options)
    assert computed.reduction is not None
    result = Result(computed.cloud, computed.states, computed.skeleton, computed.metrics, options,
                    reduction=computed.reduction)
    with skelcore.inspect(result) as handle:
        session = handle.session
        assert len(session.history) == 1 and session.run.reduction is not None
        assert len(session.run.reduction.points) == len(computed.reduction.points)
        while session.step() is not None:
            pass
        assert session.skeleton(len(session.history) - 1).topology()["cycles"] == 1
