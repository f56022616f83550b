"""skelcore study: a small grid end to end (resumable, its files), the ROC AUC, the split and the calibration."""
import json

import numpy as np
import pytest

from skelcore.cli import main
from skelcore.study import RUNS_FILE, load_runs, run_study
from skelcore.study_analysis import auc, goals, split_of
from skelcore.verdict import StabilityThresholds


@pytest.mark.slow
def test_small_study_end_to_end(tmp_path, capsys):
    out = tmp_path / "study"
    summary = run_study(out, points=1000, settings=("default", "stop after 1"), shapes=["capsule", "torus"],
                        benchmark=False, progress=None)
    runs = load_runs(out / RUNS_FILE)
    clean = [r for r in runs if r["variant"] == "clean"]
    assert {(r["shape"], r["setting"]) for r in clean} == {(s, t) for s in ("capsule", "torus")
                                                            for t in ("default", "stop after 1")}
    # Scan-like variants get the default setting only.
    assert {r["setting"] for r in runs if r["variant"] != "clean"} <= {"default"}
    for r in runs:
        assert len(r["conventions"]["outward"]) == r["iterations"] + 1 == len(r["conventions"]["tracked"])
        assert {"right", "topology_exact", "chamfer", "collapsed", "disconnected"} <= set(r["truth"])
    stopped = [r for r in clean if r["setting"] == "stop after 1"]
    assert all(not r["truth"]["right"] for r in stopped)  # one step leaves a surface, not a curve
    assert summary["shapes"] == {"calibration": ["capsule"], "held-out": ["torus"]}
    for convention in ("outward", "tracked"):
        held = summary["conventions"][convention]["calibrated"]["held-out"]
        assert held["bad_settings_stable"] == 0
    for name in ("study.csv", "study.json", "thresholds.json", "study.html"):
        assert (out / name).stat().st_size > 0
    page = (out / "study.html").read_text()
    assert "ROC AUC" in page and "stable is right" in page
    # Resuming runs nothing again.
    assert main(["study", "--out", str(out), "--points", "1000", "--settings", "default", "stop after 1",
                 "--shapes", "capsule", "torus", "--no-benchmark"]) == 0
    assert "0 to go" in capsys.readouterr().out
    assert len(load_runs(out / RUNS_FILE)) == len(runs)


def test_study_rejects_unknown_settings(tmp_path, capsys):
    assert main(["study", "--out", str(tmp_path), "--settings", "bogus", "--no-benchmark"]) == 2
    assert "bogus" in capsys.readouterr().err


def test_study_refuses_no_worker_processes_before_any_run(tmp_path, capsys, monkeypatch):
    from skelcore import study

    monkeypatch.setattr(study, "_job", lambda task: pytest.fail("a run started"))
    assert main(["study", "--out", str(tmp_path / "out"), "--jobs", "0", "--no-benchmark"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "jobs=0" in error and not (tmp_path / "out").exists()


def test_auc_and_its_interval():
    right = np.array([True] * 20 + [False] * 20)
    perfect = auc(np.r_[np.ones(20), np.zeros(20)], right)
    assert perfect[0] == 1.0 and perfect[2] == 1.0
    chance = auc(np.ones(40), right)
    assert chance[0] == pytest.approx(0.5) and chance[1] < 0.5 < chance[2]
    assert auc(np.ones(5), np.ones(5, bool)) is None


def test_split_alternates_sorted_shapes():
    names = ["torus", "animal", "capsule"]
    assert [split_of(n, names) for n in sorted(names)] == ["calibration", "held-out", "calibration"]


def test_goals_count_forbidden_stable_runs():
    runs = [{"setting": "default", "truth": {"right": True, "collapsed": False, "disconnected": False}},
            {"setting": "wl0 x100", "truth": {"right": False, "collapsed": True, "disconnected": False}},
            {"setting": "default", "truth": {"right": True, "collapsed": False, "disconnected": False}}]
    result = goals(runs, ["stable", "stable", "unstable"])
    assert result["precision"] == 0.5 and result["recall"] == 0.5
    assert result["bad_settings_stable"] == 1 and result["collapsed_or_disconnected_stable"] == 1
    assert json.dumps(result)


def _run(setting, iterations, right, d_mean=0.5, symmetry=0.9):
    """A study record with the figures the verdict reads (a ring whose skeleton agrees with its cloud)."""
    stats = lambda mean: {"mean": mean, "peaks": {"count": 1}, "symmetry": symmetry}
    last = {"d_theta": stats(d_mean), "delta_kappa": stats(0.0), "curve": {"curve_share": 0.8},
            "boundedness": {"inside_share": 1.0, "growth": -0.05, "spread_ratio": 0.8}}
    evidence = {"nodes": 30, "components": 1, "cycles": 1, "cloud_pieces": {"2": 1}, "input_pieces": {"2": 1},
                "cloud_loops": [[0.5, 20.0]]}
    return {"setting": setting, "iterations": iterations, "conventions": {"outward": [last]}, "evidence": evidence,
            "truth": {"right": right, "collapsed": False, "disconnected": False}}


def test_calibration_keeps_the_floors_and_is_no_stricter_than_the_data_demand():
    from skelcore.study_analysis import calibrate

    records = [_run("default", 4, True) for _ in range(5)]
    records += [_run("stop after 1", 1, False), _run("default", 4, False, symmetry=0.4)]
    fitted = calibrate(records, "outward", passes=2, restarts=2)
    assert fitted.min_steps == 2  # the one-step run kept out, at the floor
    assert fitted.min_symmetry == 0.5  # the loosest that keeps the symmetry of 0.4 out
    assert fitted.d_theta_tolerance == StabilityThresholds().d_theta_tolerance  # not calibrated
    # criteria the data do not need: off
    assert fitted.max_d_theta_peaks == fitted.max_delta_kappa_peaks == 100 and fitted.min_curve_share == 0.0
    assert fitted.min_spread_ratio == 0.2  # the size rule's floor, never off


def test_an_unknown_shape_is_refused(tmp_path):
    from skelcore.errors import ParameterError
    from skelcore.study import run_study

    with pytest.raises(ParameterError, match="nosuch"):
        run_study(tmp_path / "study", points=300, shapes=["torus", "nosuch"], benchmark=False, progress=None)
