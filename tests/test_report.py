"""The HTML report of run folders and the figure builders the inspector shares."""
import json
import subprocess
import sys

import numpy as np
import pytest

from skelcore import report
from skelcore.cli import main
from skelcore.errors import SkelError
from skelcore.metrics import MetricsReference, run_verdict


def write_ply(path, points):
    header = ("ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n"
              "end_header\n").format(len(points))
    path.write_text(header + "\n".join(" ".join(f"{c:.6f}" for c in p) for p in points) + "\n")


def capsule(n=600, seed=0):
    rng = np.random.default_rng(seed)
    angle, z = rng.uniform(0, 2 * np.pi, n), rng.uniform(-1, 1, n)
    return np.column_stack([0.3 * np.cos(angle), 0.3 * np.sin(angle), z])


@pytest.fixture(scope="module")
def history():
    points = capsule()
    reference = MetricsReference.from_points(points)
    axis = points * [0.0, 0.0, 1.0]
    metrics = [reference.evaluate(points, iteration=0)]
    for share in (0.7, 0.4, 0.1):
        metrics.append(reference.evaluate(axis + share * (points - axis), previous=metrics[-1]))
    return points, axis + 0.1 * (points - axis), metrics


@pytest.fixture
def run_dir(tmp_path, history):
    points, contracted, metrics = history
    write_ply(tmp_path / "input.ply", points)
    folder = tmp_path / "capsule_run"
    folder.mkdir()
    document = {"method": "lbc", "n_points": len(points), "termination": "ring_ratio",
                "iterations": [{"iteration": m.iteration, "wl": 1.0, "n_points": len(points), **m.to_dict()}
                               for m in metrics],
                "verdict": run_verdict(metrics)}
    (folder / "metrics.json").write_text(json.dumps(document))
    (folder / "params.json").write_text(json.dumps({"input": str(tmp_path / "input.ply")}))
    (folder / "skeleton.json").write_text(json.dumps({"nodes": [[0, 0, -1], [0, 0, 0], [0, 0, 1]],
                                                      "edges": [[0, 1], [1, 2]], "degree": [1, 2, 1]}))
    write_ply(folder / "contracted.ply", contracted)
    return folder


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


def test_bad_run_dirs_give_one_line_errors(run_dir, tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "metrics.json").write_text("{not json")
    partial = tmp_path / "partial"
    partial.mkdir()
    (partial / "metrics.json").write_text(json.dumps({"iterations": [{"d_theta": {}}]}))
    cases = [(tmp_path / "missing", "no such directory"), (empty, "no metrics.json"),
             (broken, "invalid JSON"), (partial, "d_theta has no histogram")]
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
    assert len(report.histograms_over_iterations_figure(metrics, "delta_kappa").data) == 4
    assert "**Verdict:" in report.verdict_text(run_verdict(metrics))
    values = report.per_point_values(final, "delta_kappa")
    assert values.shape == (len(final.delta_kappa),)
    assert "Plotly.newPlot" in report.histograms_html(final, iteration=3)
    with pytest.raises(SkelError, match="measure"):
        report.histogram_figure(final, "curvature")


def test_skelcore_does_not_import_plotly():
    code = "import sys, skelcore.metrics, skelcore.report, skelcore.cli; print('plotly' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "False"
