import html
import json
import math
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from skelcore import batch, batch_dask, batch_object
from skelcore.cli import main
from skelcore.errors import InputError, ParameterError, SkelError
from skelcore.results import RESULT_FILES
from skelcore.shapes import write_shapes

REPO = Path(__file__).resolve().parents[1]
NAMES = ("capsule", "torus", "y_branch")
FLAGS = ["--max-iterations", "3", "--quiet"]
HANG_GUARD = 300  # seconds: only so that a broken subprocess cannot hang the suite; never a speed limit


@pytest.fixture(scope="module")
def shapes_dir(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("shapes")
    write_shapes(folder, NAMES, 800, seed=0)
    return folder


@pytest.fixture(scope="module")
def serial_out(shapes_dir, tmp_path_factory) -> Path:
    """The reference: an uninterrupted serial batch of the shapes."""
    out = tmp_path_factory.mktemp("serial")
    assert main(["batch", str(shapes_dir), "--out", str(out), *FLAGS]) == 0
    return out


def summary(out: Path) -> list[dict]:
    return json.loads((out / "summary.json").read_text())["objects"]


def same_rows(a: list[dict], b: list[dict]) -> bool:
    """Equal but for the run's own columns. Floats within 1e-6: a worker runs BLAS on one thread, the serial
    run on several, which reorders sums (1e-10 differences in the means)."""
    assert [row["name"] for row in a] == [row["name"] for row in b]
    for x, y in zip(a, b):
        for key in batch.SUMMARY_COLUMNS:
            if key in batch.RUN_COLUMNS:
                continue
            if isinstance(x[key], float) and isinstance(y[key], float):
                assert math.isclose(x[key], y[key], rel_tol=1e-6, abs_tol=1e-9), (x["name"], key, x[key], y[key])
            else:
                assert x[key] == y[key], (x["name"], key, x[key], y[key])
    return True


def without_timings(metrics: dict) -> dict:
    iterations = [{k: v for k, v in entry.items() if k != "timings"} for entry in metrics["iterations"]]
    metrics = dict(metrics, iterations=iterations)
    metrics.pop("elapsed_seconds", None)
    return metrics


def test_layout_and_summary(serial_out, shapes_dir):
    rows = summary(serial_out)
    assert [row["name"] for row in rows] == sorted(NAMES)
    for row in rows:
        assert row["status"] == "ok" and row["error"] == "" and not row["reused"]
        assert row["points"] == 800 and 0 <= row["iterations"] <= 3 and row["nodes"] >= 1
        assert row["verdict"] in ("stable", "not yet converged", "unstable")
        folder = serial_out / row["name"]
        failed = [c for c in json.loads((folder / "metrics.json").read_text())["verdict"]["criteria"]
                  if c["passed"] is False]  # named in the row, as `skelcore run` names them under its summary
        assert (row["verdict_failed"] == "") == (row["verdict"] == "stable")
        assert row["verdict_failed"] == "; ".join(f"{c['name']} {c['value']} ({c['threshold']})" for c in failed)
        assert sorted(p.name for p in folder.iterdir()) == sorted([*RESULT_FILES, batch.DONE_FILE])
    csv_lines = (serial_out / "summary.csv").read_text().splitlines()
    assert csv_lines[0].split(",") == list(batch.SUMMARY_COLUMNS) and len(csv_lines) == 1 + len(NAMES)
    page = (serial_out / "report.html").read_text(encoding="utf-8")
    table = page[page.index("<table"):page.index("</table>")]
    assert all(f">{name}<" in table for name in NAMES) and "Comparison across objects" in page
    assert all(f"id='{name}'" in page for name in NAMES)  # and each object's own figures


def test_a_verdict_other_than_stable_names_its_failed_criteria_in_the_summary(shapes_dir, tmp_path):
    out = tmp_path / "one_step"
    assert main(["batch", str(shapes_dir / "torus.ply"), "--out", str(out), "--max-iterations", "1", "--quiet"]) == 0
    (row,) = summary(out)
    assert row["verdict"] != "stable" and "contraction steps taken 1 (at least 2)" in row["verdict_failed"]


def test_bad_objects_are_recorded_and_do_not_stop_the_batch(shapes_dir, tmp_path, monkeypatch, capsys):
    data = tmp_path / "data"
    shutil.copytree(shapes_dir, data)
    (data / "broken.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 5\nend_header\nnot numbers\n")
    real = batch_object.run_pipeline

    def flaky(input_path, *args, **kwargs):  # an engine bug in one object
        if Path(input_path).stem == "torus":
            raise RuntimeError("unexpected failure\n  with a second line")
        return real(input_path, *args, **kwargs)

    monkeypatch.setattr(batch_object, "run_pipeline", flaky)
    out = tmp_path / "out"
    assert main(["batch", str(data), "--out", str(out), *FLAGS]) == 1
    rows = {row["name"]: row for row in summary(out)}
    assert sorted(rows) == sorted([*NAMES, "broken"])
    assert rows["broken"]["status"] == "failed" and "broken.ply" in rows["broken"]["error"]
    assert rows["torus"]["error"] == "RuntimeError: unexpected failure"
    for name in ("broken", "torus"):
        assert "\n" not in rows[name]["error"] and rows[name]["points"] is None
        assert not (out / name / batch.DONE_FILE).exists()
    assert all(rows[name]["status"] == "ok" for name in ("capsule", "y_branch"))
    assert "Traceback" not in capsys.readouterr().err
    page = (out / "report.html").read_text(encoding="utf-8")  # every object, the failed ones with their error
    table = page[page.index("<table"):page.index("</table>")]
    assert all(f">{name}<" in table for name in rows) and table.count("class=failed") == 2
    assert all(html.escape(rows[name]["error"]) in table for name in ("broken", "torus"))
    assert "Comparison across objects" in page and "id='torus'" not in page
    # a rerun tries the failed ones again and reuses the others
    monkeypatch.setattr(batch_object, "run_pipeline", real)
    assert main(["batch", str(data), "--out", str(out), *FLAGS]) == 1
    rows = {row["name"]: row for row in summary(out)}
    assert rows["torus"]["status"] == "ok" and not rows["torus"]["reused"]
    assert rows["capsule"]["reused"] and rows["broken"]["status"] == "failed"


def test_interrupted_batch_resumes_with_each_object_once(shapes_dir, serial_out, tmp_path):
    out = tmp_path / "out"
    command = [sys.executable, "-m", "skelcore.cli", "batch", str(shapes_dir), "--out", str(out), *FLAGS]
    process = subprocess.Popen(command, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + HANG_GUARD
        while not list(out.glob(f"*/{batch.DONE_FILE}")):
            assert process.poll() is None, "the batch ended before any object was done"
            assert time.monotonic() < deadline, "no object finished"
            time.sleep(0.02)
    finally:
        process.send_signal(signal.SIGKILL)
        process.wait()
    finished = {marker.parent.name: marker.read_bytes() for marker in out.glob(f"*/{batch.DONE_FILE}")}
    assert finished

    assert subprocess.run(command, cwd=REPO, capture_output=True).returncode == 0
    rows = summary(out)
    assert sorted(row["name"] for row in rows) == sorted(NAMES)  # each object exactly once
    for row in rows:  # finished before the kill: reused, its marker untouched; the others: run once, now
        assert row["reused"] == (row["name"] in finished)
    for name, marker in finished.items():
        assert (out / name / batch.DONE_FILE).read_bytes() == marker
    assert same_rows(rows, summary(serial_out))
    for name in NAMES:
        for file in ("skeleton.json", "contracted.ply", "skeleton.ply"):
            assert (out / name / file).read_bytes() == (serial_out / name / file).read_bytes(), (name, file)
        metrics = [json.loads((folder / name / "metrics.json").read_text()) for folder in (out, serial_out)]
        assert without_timings(metrics[0]) == without_timings(metrics[1])
        assert not list((out / name).glob(".*.tmp"))


def test_resume_rules(shapes_dir, tmp_path):
    data, out = tmp_path / "data", tmp_path / "out"
    data.mkdir()
    for name in ("capsule", "torus"):
        shutil.copy(shapes_dir / f"{name}.ply", data)
    args = ["batch", str(data), "--out", str(out), *FLAGS]
    assert main(args) == 0
    # a half-written object (results without a marker) and a stale marker of other parameters are redone
    (out / "capsule" / batch.DONE_FILE).unlink()
    (out / "capsule" / "skeleton.json").write_text("{")
    assert main(args) == 0
    assert {row["name"]: row["reused"] for row in summary(out)} == {"capsule": False, "torus": True}
    json.loads((out / "capsule" / "skeleton.json").read_text())
    stale = json.loads((out / "torus" / batch.DONE_FILE).read_text())
    (out / "torus" / batch.DONE_FILE).write_text(json.dumps(dict(stale, key="0" * 64)))
    assert main(args) == 0
    assert {row["name"]: row["reused"] for row in summary(out)} == {"capsule": True, "torus": False}
    assert main([*args, "--force"]) == 0
    assert not any(row["reused"] for row in summary(out))
    assert main([*args, "--sample-radius", "0.03"]) == 0  # other parameters: a different key
    assert not any(row["reused"] for row in summary(out))
    assert main(args) == 0 and not any(row["reused"] for row in summary(out))
    write_shapes(data, ["torus"], 800, seed=5)  # an edited input
    assert main(args) == 0
    assert {row["name"]: row["reused"] for row in summary(out)} == {"capsule": True, "torus": False}
    # markers that are JSON but not what a batch writes (they stopped the batch with an internal error): redone
    marker = json.loads((out / "torus" / batch.DONE_FILE).read_text())
    (out / "capsule" / batch.DONE_FILE).write_text("[1]")
    (out / "torus" / batch.DONE_FILE).write_text(json.dumps(dict(marker, row="x")))
    assert main(args) == 0
    assert {row["name"]: row["reused"] for row in summary(out)} == {"capsule": False, "torus": False}


def test_inputs_and_unique_names(tmp_path):
    for folder in ("a", "b"):
        write_shapes(tmp_path / folder, ["capsule"], 50)
    (tmp_path / "a" / "capsule.xyz").write_text("0 0 0\n")
    (tmp_path / "a" / "notes.md").write_text("not a cloud")
    folder, pattern, explicit = tmp_path / "a", tmp_path / "*" / "capsule.ply", tmp_path / "a" / "notes.md"
    paths = batch.collect_inputs([str(folder), str(pattern), str(explicit)])
    assert [p.relative_to(tmp_path).as_posix() for p in paths] == [
        "a/capsule.ply", "a/capsule.xyz", "b/capsule.ply", "a/notes.md"]
    assert batch.object_names(paths) == ["a_capsule_ply", "a_capsule_xyz", "b_capsule_ply", "notes"]
    assert batch.object_names([Path("x/t.ply"), Path("y/t.ply"), Path("y/u.ply")]) == ["x_t", "y_t", "u"]
    assert batch.object_names([Path("t.ply"), Path("t.xyz")]) == ["t_ply", "t_xyz"]
    with pytest.raises(InputError, match="no such file"):
        batch.collect_inputs([str(tmp_path / "missing.ply")])
    with pytest.raises(InputError, match="no point cloud"):
        batch.collect_inputs([str(tmp_path / "*.pcd")])
    # results of an earlier batch inside OUT are not inputs
    (tmp_path / "a" / "run").mkdir()
    (tmp_path / "a" / "run" / "contracted.ply").write_text("")
    assert len(batch.collect_inputs([str(tmp_path / "a" / "**" / "*.ply")], out_dir=tmp_path / "a")) == 1


def test_dask_missing_gives_one_line(shapes_dir, tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)
    assert main(["batch", str(shapes_dir), "--out", str(tmp_path), "--workers", "2", *FLAGS]) == 2
    error = capsys.readouterr().err.strip()
    assert error == "skelcore batch: error: --workers and --scheduler need Dask: pip install 'skelcore[dask]'"


def test_local_cluster_matches_serial(shapes_dir, serial_out, tmp_path):
    pytest.importorskip("distributed")
    out = tmp_path / "out"
    assert main(["batch", str(shapes_dir), "--out", str(out), *FLAGS, "--workers", "2"]) == 0
    assert same_rows(summary(out), summary(serial_out))
    assert all((out / name / batch.DONE_FILE).is_file() for name in NAMES)


def test_external_scheduler_and_worker(shapes_dir, serial_out, tmp_path):
    pytest.importorskip("distributed")
    scheduler_file = tmp_path / "scheduler.json"
    local = ["--host", "127.0.0.1", "--dashboard-address", "127.0.0.1:0"]
    processes = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--port", "0", *local,
                                   "--scheduler-file", str(scheduler_file)], cwd=REPO,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        address = wait_for_address(scheduler_file, processes[0])
        assert address.startswith("tcp://127.0.0.1:")
        processes.append(subprocess.Popen([sys.executable, "-m", "dask", "worker", address, "--nworkers", "1",
                                           "--nthreads", "1", *local], cwd=REPO,
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client

        with Client(address, timeout="60s") as client:
            client.wait_for_workers(1, timeout=HANG_GUARD)
        out = tmp_path / "out"
        assert main(["batch", str(shapes_dir), "--out", str(out), *FLAGS, "--scheduler", address]) == 0
        assert same_rows(summary(out), summary(serial_out))
    finally:
        for process in reversed(processes):
            process.terminate()
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


def wait_for_address(scheduler_file: Path, process: subprocess.Popen) -> str:
    deadline = time.monotonic() + HANG_GUARD
    while True:
        try:
            return json.loads(scheduler_file.read_text())["address"]
        except (OSError, ValueError, KeyError):
            assert process.poll() is None, "dask scheduler exited"
            assert time.monotonic() < deadline, "dask scheduler wrote no address"
            time.sleep(0.1)


def test_unreachable_scheduler_is_one_line(shapes_dir, tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    monkeypatch.setattr(batch_dask, "CONNECT_TIMEOUT", "1s")
    with pytest.raises(SkelError, match=r"^--scheduler tcp://127.0.0.1:9: cannot connect"):
        batch.run_batch([str(shapes_dir)], tmp_path, scheduler="tcp://127.0.0.1:9", progress=False)


def test_an_absurd_worker_count_is_refused_before_any_process_starts():
    from skelcore.batch_dask import local_cluster

    with pytest.raises(ParameterError, match="workers"):
        local_cluster(100_000)
