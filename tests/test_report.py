"""The HTML report of run folders and the figure builders the inspector shares."""
import html
import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from skelcore import report
from skelcore.cli import main
from skelcore.errors import SkelError
from skelcore.metrics import MetricsReference
from skelcore.verdict import run_verdict
from skelcore.shapes import make_shape


def write_ply(path, points):
    header = ("ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n"
              "end_header\n").format(len(points))
    path.write_text(header + "\n".join(" ".join(f"{c:.6f}" for c in p) for p in points) + "\n")


def capsule(n=600, seed=0):
    rng = np.random.default_rng(seed)
    angle, z = rng.uniform(0, 2 * np.pi, n), rng.uniform(-1, 1, n)
    return np.column_stack([0.3 * np.cos(angle), 0.3 * np.sin(angle), z])


def shrink_history(points, axis, shares):
    """Metrics of the cloud pulled toward `axis` (same shape as points) by each share in turn."""
    reference = MetricsReference.from_points(points)
    metrics = [reference.evaluate(points, iteration=0)]
    for share in shares:
        metrics.append(reference.evaluate(axis + share * (points - axis), previous=metrics[-1]))
    return points, axis + shares[-1] * (points - axis), metrics


def write_run(folder, history, input_path):
    """A run folder as `skelcore run` writes it, from synthetic metrics."""
    points, contracted, metrics = history
    write_ply(input_path, points)
    folder.mkdir()
    document = {"method": "lbc", "n_points": len(points), "termination": "ring_ratio",
                "iterations": [{"iteration": m.iteration, "wl": 1.0, "n_points": len(points), **m.to_dict()}
                               for m in metrics],
                "verdict": run_verdict(metrics)}
    (folder / "metrics.json").write_text(json.dumps(document))
    (folder / "params.json").write_text(json.dumps({"input": str(input_path)}))
    (folder / "skeleton.json").write_text(json.dumps({"nodes": [[0, 0, -1], [0, 0, 0], [0, 0, 1]],
                                                      "edges": [[0, 1], [1, 2]], "degree": [1, 2, 1]}))
    write_ply(folder / "contracted.ply", contracted)
    return folder


@pytest.fixture(scope="module")
def history():
    points = capsule()
    return shrink_history(points, points * [0.0, 0.0, 1.0], (0.7, 0.4, 0.1))


@pytest.fixture
def run_dir(tmp_path, history):
    return write_run(tmp_path / "capsule_run", history, tmp_path / "input.ply")


@pytest.fixture
def branch_dir(tmp_path):
    """A second object, a different shape pulled toward its centroid: another verdict and histograms."""
    points = make_shape("y_branch", 800).points
    return write_run(tmp_path / "y_branch", shrink_history(points, points.mean(axis=0) + 0 * points, (0.6, 0.3)),
                     tmp_path / "y_branch.ply")


def test_report_is_one_offline_page(run_dir, tmp_path):
    out = report.write_report([run_dir], tmp_path / "out" / "report.html")
    page = out.read_text(encoding="utf-8")
    assert page.startswith("<!DOCTYPE html>") and "capsule_run" in page
    assert "<script src=" not in page  # plotly.js is inline: the page opens offline
    assert page.count("Plotly.newPlot") == 7  # convergence, 2 x Fig. 2, 2 histograms + clouds, skeleton
    assert "Fig. 2" in page and "Figs. 3-4" in page and "Fig. 5" in page
    verdict = json.loads((run_dir / "metrics.json").read_text())["verdict"]["label"]
    assert f">{verdict}<" in page
    assert "original cloud not shown" not in page


def test_report_with_batch_rows_compares_every_object(run_dir, branch_dir, tmp_path):
    broken = tmp_path / "broken_run"
    broken.mkdir()
    (broken / "metrics.json").write_text("{not json")
    error = "odd.ply: line 5: expected 3 numbers, got 'x <y>'"
    rows = [{"name": "capsule_run", "input": "capsule.ply", "status": "ok", "error": "", "points": 600,
             "d_theta_mean": 0.41, "verdict": "unstable", "bounded": True, "reused": False},
            {"name": "odd", "input": "odd.ply", "status": "failed", "error": error, "points": None, "verdict": None,
             "reused": False},
            {"name": "y_branch", "input": "y_branch.ply", "status": "ok", "error": "", "points": 800,
             "d_theta_mean": 0.52, "verdict": "stable", "bounded": False, "reused": True},
            {"name": "broken_run", "input": "b.ply", "status": "ok", "error": "", "verdict": "stable", "reused": False}]
    out = report.write_report([run_dir, branch_dir, broken], tmp_path / "report.html", rows=rows)
    page = out.read_text(encoding="utf-8")
    table = page[page.index("<table"):page.index("</table>")]
    positions = [table.index(f">{row['name']}<") for row in rows]  # every object, failed ones too, in row order
    assert positions == sorted(positions)
    assert html.escape(error) in table and "class=failed" in table
    assert "not in the report" in table and "broken_run" in table and "invalid JSON" in table
    assert f"color:{report.LABEL_COLOURS['stable']}" in table and f"color:{report.LABEL_COLOURS['unstable']}" in table
    assert "data-v='0.41'" in table and "table.sortable" in page
    for title in ("Comparison across objects", "Final means against their targets",
                  "Convergence of the means, all objects", "Final D_theta histograms, all objects",
                  "Final delta_kappa histograms, all objects"):
        assert title in page
    assert page.count("Plotly.newPlot") == 4 + 2 * 7  # the comparison, then each readable run's figures
    assert page.count("* plotly.js v") == 1 and "<script src=" not in page  # plotly.js inline, once


def test_comparison_figures(run_dir, branch_dir):
    runs = [report.load_run(folder) for folder in (run_dir, branch_dir)]
    means = report.final_means_figure(runs)
    markers = [name for trace in means.data for name in trace.text]
    assert sorted(markers) == ["capsule_run", "y_branch"]
    assert {trace.name for trace in means.data} == {run["verdict"]["label"] for run in runs}
    for figure in (report.convergence_comparison_figure(runs), report.final_histograms_figure(runs, "delta_kappa")):
        named = [trace.name for trace in figure.data if trace.showlegend is False]
        assert sorted(set(named)) == ["capsule_run", "y_branch"]
    assert len(report.convergence_comparison_figure(runs).layout.shapes) == 4  # targets and bands, both means
    lines = [t for t in report.convergence_comparison_figure(runs).data if t.name == "y_branch"]
    assert [list(line.x) for line in lines] == [[0, 1, 2]] * 2


def test_page_size_is_bounded(run_dir, tmp_path, monkeypatch):
    small = report.write_report([run_dir], tmp_path / "small.html").stat().st_size
    big_dir = tmp_path / "big_run"
    shutil.copytree(run_dir, big_dir)
    dense = capsule(60_000, seed=1)
    write_ply(tmp_path / "input.ply", dense)  # the original the run folders name
    write_ply(big_dir / "contracted.ply", 0.1 * dense)
    big = report.write_report([big_dir], tmp_path / "big.html").stat().st_size
    # 3 clouds of 60 000 points would add ~5 MB; subsampled to MAX_CLOUD_POINTS they add < 200 kB
    assert big - small < 3 * report.MAX_CLOUD_POINTS * 3 * 4 * 4 / 3 + 20_000
    figure = report.cloud_figure(dense, dense)
    assert [len(trace.x) for trace in figure.data] == [report.MAX_CLOUD_POINTS] * 2

    # many objects: the table and the comparison only, no per-object figures or clouds
    monkeypatch.setattr(report, "MAX_DETAILED_RUNS", 1)
    monkeypatch.setattr(report, "_load_clouds", lambda *args: pytest.fail("clouds read for a large batch"))
    page = report.write_report([run_dir, big_dir], tmp_path / "many.html").read_text(encoding="utf-8")
    assert "more than 1" in page and "Comparison across objects" in page
    assert page.count("Plotly.newPlot") == 4 and "Figs. 3-4" not in page and "Fig. 5" not in page
    assert len(page) < small


def test_bad_run_dirs_give_one_line_errors(run_dir, tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "metrics.json").write_text("{not json")
    partial = tmp_path / "partial"
    partial.mkdir()
    (partial / "metrics.json").write_text(json.dumps({"iterations": [{"d_theta": {}}]}))
    # damage that a check let through to plotly or a comparison (internal errors): NaN edges, an iteration in
    # words, nesting past Python's recursion limit
    good = json.loads((run_dir / "metrics.json").read_text())
    damaged = []
    for name, change in (("nan_edges", lambda m: m["iterations"][0]["d_theta"]["histogram"]["edges"].__setitem__(
                              0, float("nan"))),
                         ("worded", lambda m: m["iterations"][0].__setitem__("iteration", "one"))):
        folder, metrics = tmp_path / name, json.loads(json.dumps(good))
        change(metrics)
        folder.mkdir()
        (folder / "metrics.json").write_text(json.dumps(metrics))
        damaged.append(folder)
    deep = tmp_path / "deep"
    deep.mkdir()
    (deep / "metrics.json").write_text("[" * 100_000 + "]" * 100_000)
    a_file = tmp_path / "a_file"
    a_file.write_text("mine")
    cases = [(tmp_path / "missing", "no such directory"), (a_file, "(a file)"), (empty, "no metrics.json"),
             (broken, "invalid JSON"), (partial, "d_theta has no histogram"),
             (damaged[0], "not increasing finite numbers"), (damaged[1], "no whole number"), (deep, "nested")]
    for folder, problem in cases:
        with pytest.raises(SkelError) as caught:
            report.write_report([run_dir, folder], tmp_path / "r.html")
        message = str(caught.value)
        assert folder.name in message and problem in message and "\n" not in message
    assert not (tmp_path / "r.html").exists()


def test_cli_report(run_dir, tmp_path, capsys):
    assert main(["report", str(run_dir), "--out", str(tmp_path / "cli.html")]) == 0
    assert (tmp_path / "cli.html").is_file()
    assert main(["report", str(tmp_path / "nowhere"), "--out", str(tmp_path / "x.html")]) != 0
    error = capsys.readouterr().err.strip()
    assert "nowhere" in error and "\n" not in error and "Traceback" not in error
    before = (run_dir / "skeleton.json").read_bytes()
    assert main(["report", str(run_dir), "--out", str(run_dir / "skeleton.json")]) == 2  # not over a run's file
    assert (run_dir / "skeleton.json").read_bytes() == before and ".html" in capsys.readouterr().err


def test_figure_builders_take_objects_and_dicts(history):
    _, _, metrics = history
    final = metrics[-1]
    as_dict = {"iteration": final.iteration, **json.loads(json.dumps(final.to_dict()))}
    for source in (final, as_dict):
        figure = report.histogram_figure(source, "D_theta")
        bars, peaks = figure.data[0], figure.data[1]
        assert len(bars.y) == len(final.d_theta_stats["histogram"]["counts"])
        assert len(peaks.x) == final.d_theta_stats["peaks"]["count"]
    convergence = report.convergence_figure(metrics)
    assert list(convergence.data[0].x) == [0, 1, 2, 3]
    # each mean's target (dashed) and tolerance band (shaded), on both subplots
    assert sorted((shape.type, shape.yref) for shape in convergence.layout.shapes) == [
        ("line", "y"), ("line", "y2"), ("rect", "y"), ("rect", "y2")]
    assert len(report.histograms_over_iterations_figure(metrics, "delta_kappa").data) == 4
    assert "**Verdict on iteration 3:" in report.verdict_text(run_verdict(metrics))
    values = report.per_point_values(final, "delta_kappa")
    assert values.shape == (len(final.delta_kappa),)
    assert "Plotly.newPlot" in report.histograms_html(final, iteration=3)
    with pytest.raises(SkelError, match="measure"):
        report.histogram_figure(final, "curvature")


def test_skelcore_does_not_import_plotly():
    code = "import sys, skelcore.metrics, skelcore.report, skelcore.cli; print('plotly' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "False"


def test_report_states_the_measured_predictive_power():
    power = {"command": "skelcore study --out s", "runs": 120, "right_runs": 70, "stable": 40, "precision": 0.95,
             "recall": 0.54, "bad_settings_stable": 0, "collapsed_or_disconnected_stable": 0,
             "best_statistics": [["inside_share", 0.63]]}
    text = report.predictive_power_html(power)
    assert "right in 95% of the 40 runs it labelled" in text and "labelled 54% of the right runs" in text
    assert "inside_share 0.63" in text and "Criteria added" not in text
    power["added_criteria"] = [["contraction steps taken", "one step shows no trend.", "Off: 2 bad settings stable."]]
    text = report.predictive_power_html(power)
    assert "<li><b>contraction steps taken</b>: one step shows no trend. Off: 2 bad settings stable.</li>" in text


def test_fitted_histogram_spans_the_values_and_the_target(history):
    _, _, metrics = history
    first = metrics[1]
    figure = report.histogram_figure(first, "d_theta", fit=True)
    low, high = figure.layout.xaxis.range
    values = first.d_theta[np.isfinite(first.d_theta)]
    assert low <= values.min() and high >= max(values.max(), 0.5)
    assert high - low < 1.0 or values.max() > 0.9
    assert sum(figure.data[0].y) == len(values)  # every value in a bin
    edges = report.fitted_edges(np.zeros(10), (-1 / 3, 1 / 3), 0.0, 50)
    assert edges[-1] - edges[0] >= 0.1 * 2 / 3  # a spike is shown in a readable window, not +-10 micro
    names = [trace.name for trace in figure.data]
    assert any(name.startswith("target") for name in names) and any(name.startswith("mean") for name in names)
    assert not figure.layout.annotations  # labels are legend entries: they cannot overlap


def test_the_verdicts_histogram_is_drawn_on_its_own_bins_zoomed_onto_those_that_hold_points(history):
    """A saved run's histogram keeps the bins and peaks the verdict counted, but a delta_kappa within a few
    hundredths of 0 is not shown as three bars in the middle of its whole range (the exported pages)."""
    _, _, metrics = history
    entry = metrics[-1].to_dict()
    for key in ("d_theta", "delta_kappa"):
        figure = report.histogram_figure(entry, key)
        low, high = figure.layout.xaxis.range
        edges = np.asarray(entry[key]["histogram"]["edges"])
        counts = np.asarray(entry[key]["histogram"]["counts"])
        held = np.flatnonzero(counts)
        target = report.MEASURES[key][3]
        assert low <= min(edges[held[0]], target) and high >= max(edges[held[-1] + 1], target)
        assert list(figure.data[0].y) == counts.tolist()  # the verdict's own bins
    full = report.MEASURES["delta_kappa"][2]
    low, high = report.histogram_figure(entry, "delta_kappa").layout.xaxis.range
    assert high - low < (full[1] - full[0]) / 2


def test_a_verdict_without_a_label_is_written_in_words():
    from skelcore.report import _verdict_html

    assert "none (no contraction step to judge)" in _verdict_html({"label": None, "reasons": []})


def test_a_histogram_of_a_sample_says_how_many_points_the_input_has(history):
    _, _, metrics = history
    final = metrics[-1]
    stats = final.d_theta_stats
    judged = stats["n"] + stats["n_undefined"]
    subtitle = report.histogram_figure(final, "d_theta", of_points=judged + 10_000).layout.title.subtitle.text
    assert subtitle.endswith(f"n {stats['n']:,} of {judged + 10_000:,}")
    for whole in (None, judged):  # every point judged: only those without a value to say
        text = report.histogram_figure(final, "d_theta", of_points=whole).layout.title.subtitle.text
        assert text.endswith(f"n {stats['n']:,}" + (f" of {judged:,}" if stats["n_undefined"] else ""))
    entry = final.to_dict()
    entry["d_theta"] = {**entry["d_theta"], "n": 4694, "n_undefined": 306}
    assert report.histogram_figure(entry, "d_theta").layout.title.subtitle.text.endswith("n 4,694 of 5,000")


def test_the_convergence_marks_the_iteration_shown(history):
    _, _, metrics = history
    lines = lambda figure: sorted((shape.xref, shape.x0) for shape in figure.layout.shapes
                                  if shape.type == "line" and shape.yref.endswith("domain"))
    assert lines(report.convergence_figure(metrics, shown=1)) == [("x", 1), ("x2", 1)]  # on both means
    assert lines(report.convergence_figure(metrics)) == []
