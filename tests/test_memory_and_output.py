"""Bounded memory on the command line and in the inspector's loading, and output that is never lost:
inputs sized before parsing, points against a budget with a voxel size offered, peak memory of the worst
inputs measured in a child process, run folders refused or cleaned, a full disk as one line."""
from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from skelcore import io, memory, paths, results
from skelcore.cli import main
from skelcore.errors import TooLargeError
from skelcore.export import write_points_ply
from skelcore.shapes import make_shape

REPO = Path(__file__).resolve().parents[1]


def sphere(n, seed=0):
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_points_over_the_budget_are_refused_with_a_voxel_size_that_fits(tmp_path):
    path = tmp_path / "big.ply"
    write_points_ply(path, sphere(5000))
    budget = 1000 * memory.PIPELINE_BYTES_PER_POINT
    with pytest.raises(TooLargeError) as error:
        io.load(path, budget=budget)
    message = str(error.value)
    assert "\n" not in message and "big.ply" in message and "memory budget" in message
    assert error.value.cap == 1000 and f"voxel size of {error.value.voxel_size:g}" in message
    cloud = io.load(path, budget=budget, voxel_size=error.value.voxel_size)
    assert 300 < len(cloud.points) <= 1000  # fits, without throwing most of the cloud away


def test_the_inspector_budget_is_below_the_command_line_budget(monkeypatch):
    monkeypatch.setenv(memory.AVAILABLE_VARIABLE, "16384")
    assert memory.available_bytes() == 16 * 2**30
    assert memory.INSPECTOR_SHARE < memory.CLI_SHARE
    assert memory.point_cap(memory.budget_bytes(memory.INSPECTOR_SHARE)) < 2_000_000


def test_a_bad_stated_budget_is_one_line(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv(memory.AVAILABLE_VARIABLE, "lots")
    path = tmp_path / "c.xyz"
    np.savetxt(path, sphere(100))
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    assert "SKELCORE_AVAILABLE_MB" in capsys.readouterr().err


def test_a_file_that_may_hold_too_many_points_is_not_parsed(tmp_path):
    path = tmp_path / "rows.xyz"
    path.write_bytes(b"0 0 0\n1 0 0\n0 1 0\n" * 20_000)  # 60,000 rows
    with pytest.raises(io.InputError, match="too many to read within the memory budget"):
        io.load(path, budget=60_000 * 100)


PEAK = textwrap.dedent("""
    import resource, sys
    from skelcore import io
    from skelcore.errors import SkelError, TooLargeError
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    outcome = "loaded"
    try:
        io.load(sys.argv[1], budget=int(float(sys.argv[2])))
    except TooLargeError as error:
        outcome = f"too large, voxel {error.voxel_size}"
    except SkelError as error:
        outcome = "refused"
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(outcome, (after - before) * 1024)
""")


def peak_of_loading(path: Path, budget: float) -> tuple[str, int]:
    """(outcome, bytes the peak memory grew by) of io.load in a fresh process."""
    done = subprocess.run([sys.executable, "-c", PEAK, str(path), str(budget)], capture_output=True, text=True,
                          cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)}, timeout=600)
    assert done.returncode == 0, done.stderr
    outcome, grew = done.stdout.strip().rsplit(" ", 1)
    return outcome, int(grew)


@pytest.mark.slow
def test_peak_memory_of_the_worst_inputs(tmp_path):
    """Sparse 1 GB files (no disk used) that once took 2-5 GB; a header promising a cloud its bytes hold,
    too large for the budget; a 1e9-face OFF. Each is refused within 100 MB of peak growth."""
    gigabyte = 2**30
    worst = {}
    for name in ("zeros.ply", "zeros.xyz", "zeros.off", "zeros.pcd"):
        worst[name] = tmp_path / name
        with open(worst[name], "wb") as handle:
            handle.truncate(gigabyte)
    header = b"ply\nformat binary_little_endian 1.0\nelement vertex 80000000\nproperty float x\n" \
             b"property float y\nproperty float z\nend_header\n"
    worst["promises.ply"] = tmp_path / "promises.ply"
    with open(worst["promises.ply"], "wb") as handle:
        handle.write(header)
        handle.truncate(len(header) + 80_000_000 * 12)
    worst["faces.off"] = tmp_path / "faces.off"
    worst["faces.off"].write_text("OFF\n3 1000000000 0\n0 0 0\n1 0 0\n0 1 0\n")
    for name, path in worst.items():
        outcome, grew = peak_of_loading(path, 2 * gigabyte)
        assert outcome == "refused", (name, outcome)
        assert grew < 100 * 2**20, f"{name}: peak grew by {grew / 2**20:.0f} MB"


@pytest.mark.slow
def test_two_million_points_are_refused_in_the_inspector_budget_with_an_offer(tmp_path):
    """The 2M-point case: on a machine with 16 GiB available the inspector's budget (4 GiB) holds ~0.9M
    points, so 2M are refused with a voxel size, and refusing takes less than 1.5 GB."""
    path = tmp_path / "two_million.ply"
    write_points_ply(path, make_shape("torus", 2_000_000).points, dtype=np.float32)
    budget = 16 * 2**30 * memory.INSPECTOR_SHARE
    outcome, grew = peak_of_loading(path, budget)
    assert outcome.startswith("too large, voxel"), outcome
    assert grew < 1.5 * 2**30, f"peak grew by {grew / 2**30:.2f} GB"
    voxel = float(outcome.rsplit(" ", 1)[1])
    cloud = io.load(path, budget=int(budget), voxel_size=voxel)
    assert 0.3 * memory.point_cap(int(budget)) < len(cloud.points) <= memory.point_cap(int(budget))


def small_cloud(tmp_path) -> Path:
    path = tmp_path / "small.xyz"
    np.savetxt(path, make_shape("torus", 600).points)
    return path


def test_an_output_folder_holding_a_run_is_refused_without_force(tmp_path, capsys):
    path, out = small_cloud(tmp_path), tmp_path / "out"
    args = ["run", str(path), "--out", str(out), "--quiet", "--max-iterations", "2"]
    assert main(args) == 0
    first = (out / "metrics.json").read_bytes()
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "already holds" in err and "--force" in err
    assert (out / "metrics.json").read_bytes() == first  # untouched
    (out / "done.json").write_text("{}")  # what a batch leaves beside a run
    (out / "notes.txt").write_text("mine")
    assert main(args + ["--force"]) == 0
    assert not (out / "done.json").exists() and (out / "notes.txt").read_text() == "mine"
    assert all((out / name).exists() for name in results.RESULT_FILES)
    second = (out / "metrics.json").read_bytes()
    (tmp_path / "empty.xyz").write_text("")
    for bad in (["run", str(tmp_path / "empty.xyz"), "--out", str(out), "--force"], args + ["--force", "--sl", "0"]):
        assert main(bad) == 2  # a bad input or parameter with --force: the earlier results stay
        assert (out / "metrics.json").read_bytes() == second


def test_an_output_path_that_is_a_file_or_empty_is_refused_before_the_work(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # an empty --out taken as "here" would write into the working folder
    path, taken = small_cloud(tmp_path), tmp_path / "taken"
    taken.write_text("mine")
    for out in (str(taken), ""):
        assert main(["run", str(path), "--out", out, "--quiet"]) == 2
        assert capsys.readouterr().err.count("\n") == 1
    assert taken.read_text() == "mine" and not (tmp_path / "metrics.json").exists()


def test_an_output_folder_that_cannot_be_made_is_refused_before_the_work(tmp_path, capsys, monkeypatch):
    """Where no folder can be made (here: /proc, where even root cannot), the run is refused before it starts, not
    after the contraction; the probe leaves nothing behind where it can write."""
    import skelcore.api

    monkeypatch.setattr(skelcore.api, "run", lambda *args, **kwargs: pytest.fail("the run started"))
    assert main(["run", str(small_cloud(tmp_path)), "--out", "/proc/skelcore-test/out", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "/proc/skelcore-test/out: cannot be written" in err, err
    before = sorted(tmp_path.iterdir())
    paths.writable_folder(tmp_path / "new" / "folder", "--out")
    assert sorted(tmp_path.iterdir()) == before


def full_disk_after(monkeypatch, module, target_name: str):
    """os.replace fails with ENOSPC when it would put `target_name` in place."""
    real = os.replace

    def replace(source, destination):
        if Path(destination).name == target_name:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(source, destination)

    monkeypatch.setattr(module.os, "replace", replace)


def test_a_full_disk_during_a_run_is_one_line_and_keeps_what_was_written(tmp_path, capsys, monkeypatch):
    path, out = small_cloud(tmp_path), tmp_path / "out"
    full_disk_after(monkeypatch, results, "metrics.json")
    assert main(["run", str(path), "--out", str(out), "--quiet", "--max-iterations", "2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "metrics.json" in err and "disk is full" in err and "Traceback" not in err
    assert (out / "contracted.ply").exists() and (out / "skeleton.json").exists()
    assert not list(out.glob(".*.tmp"))  # no half-written file left behind


def test_a_full_disk_while_force_writes_new_results_keeps_the_earlier_ones_whole(tmp_path, capsys, monkeypatch):
    """--force replaces an earlier run's results only once the new ones are all written: a disk that fills while
    they are written (here at the last file) leaves every earlier file as it was, a batch's done.json beside them
    too, and no temporary (they used to be removed first, so the folder was left empty)."""
    path, out = small_cloud(tmp_path), tmp_path / "out"
    args = ["run", str(path), "--out", str(out), "--quiet", "--max-iterations", "2"]
    assert main(args) == 0
    (out / "done.json").write_text("{}")
    earlier = {name: (out / name).read_bytes() for name in (*results.RESULT_FILES, "done.json")}
    real = results._write_json

    def full(path, document, indent=1):
        if ".params.json." in Path(path).name:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(path, document, indent)

    monkeypatch.setattr(results, "_write_json", full)
    assert main(args + ["--force", "--max-iterations", "3"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "params.json" in err and "disk is full" in err and "as they were" in err
    assert {name: (out / name).read_bytes() for name in earlier} == earlier
    assert not list(out.glob(".*.tmp"))


def test_a_full_disk_when_the_batch_summary_is_written_is_one_line(tmp_path, capsys, monkeypatch):
    path, out = small_cloud(tmp_path), tmp_path / "batch"
    full_disk_after(monkeypatch, results, "summary.json")
    code = main(["batch", str(path), "--out", str(out), "--quiet", "--no-report", "--max-iterations", "2"])
    err = capsys.readouterr().err
    assert code == 2 and "summary.json" in err and "disk is full" in err and "Traceback" not in err
    assert err.strip().count("\n") == 0
    assert json.loads((out / "small" / "done.json").read_text())["row"]["status"] == "ok"  # kept
    assert (out / "summary.csv").exists()


def test_unforeseen_errors_are_one_line(tmp_path, capsys, monkeypatch):
    from skelcore import cli

    def explode(args):
        raise MemoryError()

    monkeypatch.setattr(cli, "_run", explode)
    assert main(["run", str(small_cloud(tmp_path)), "--out", str(tmp_path / "out")]) == cli.EXIT_INTERNAL
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "out of memory" in err


def test_bundle_params_name_no_server_path(tmp_path):
    from app.session import Session

    cloud = io.load(small_cloud(tmp_path))
    session = Session(cloud)
    session.step()
    session.write_results(1, tmp_path / "bundle")
    assert json.loads((tmp_path / "bundle" / "params.json").read_text())["input"] == "small.xyz"


def test_the_command_line_names_the_flags_that_bring_a_cloud_under(tmp_path, capsys):
    path = tmp_path / "big.ply"
    write_points_ply(path, sphere(5000))
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--max-points", "1000"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "big.ply" in err and "--voxel-size" in err and "--max-points" in err
