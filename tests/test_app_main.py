"""`skel-inspect`: its command line, bad input, the default asset, and a real server process."""
from __future__ import annotations

import re
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

from app.main import default_cloud, main
from app.main import bundled_assets


def test_missing_input_is_one_line_and_non_zero(capsys, tmp_path):
    assert main([str(tmp_path / "nothing.ply")]) != 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "nothing.ply" in err and "not found" in err


def test_garbage_input_is_one_line_and_non_zero(capsys, tmp_path):
    path = tmp_path / "garbage.ply"
    path.write_bytes(b"\x00\xff" * 100)
    assert main([str(path)]) != 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "garbage.ply" in err and "Traceback" not in err


def test_bad_port_is_refused(capsys):
    assert main(["--port", "70000"]) != 0
    assert "--port" in capsys.readouterr().err


def test_loading_options_without_input_and_a_save_dir_that_is_a_file_are_refused_before_serving(capsys, tmp_path):
    """Without INPUT, --sample -5 and --voxel-size nan were dropped silently (the bundled torus served); a --save-dir
    that is a file was taken, to fail only when "Also save on server" was clicked."""
    taken = tmp_path / "taken"
    taken.write_text("mine")
    for args in (["--sample", "-5"], ["--voxel-size", "nan"], ["--save-dir", str(taken)],
                 ["--save-dir", str(taken / "sub")]):
        assert main([*args, "--port", "0"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and ("sample" in err or "voxel_size" in err or "--save-dir" in err)


def test_bad_host_is_refused(capsys):
    assert main(["--host", "999.1.1.1"]) != 0
    assert "--host 999.1.1.1" in capsys.readouterr().err


def test_default_cloud_prefers_the_bundled_torus(assets_dir):
    assets = bundled_assets(assets_dir)
    cloud = default_cloud(assets)
    if "torus.ply" in assets:
        assert Path(cloud.name).name == "torus.ply"
    assert len(cloud.points) >= 20


def test_default_cloud_without_assets_is_synthetic():
    cloud = default_cloud({})
    assert "torus" in cloud.name and len(cloud.points) > 1000


def test_serves_on_localhost_and_prints_the_url(tmp_path):
    process = subprocess.Popen([sys.executable, "-m", "app.main", "--port", "0"], stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True, cwd=Path(__file__).resolve().parents[1])
    try:
        url = None
        deadline = time.monotonic() + 120  # waiting limit only
        while url is None and time.monotonic() < deadline:
            line = process.stdout.readline()
            if not line:
                break
            match = re.search(r"http://127\.0\.0\.1:(\d+)", line) if "skel-inspect:" in line else None
            url = match.group(0) if match else None
        assert url, "no URL printed"
        with urllib.request.urlopen(url, timeout=60) as response:
            assert response.status == 200 and b"<html" in response.read().lower()
    finally:
        process.terminate()
        process.wait(timeout=60)


def test_an_input_over_the_inspector_budget_names_the_voxel_size(capsys, tmp_path, monkeypatch):
    import numpy as np

    from skelcore import memory
    from skelcore.export import write_points_ply
    from skelcore.shapes import make_shape

    path = write_points_ply(tmp_path / "dense.ply", make_shape("torus", 5000).points)
    available = 1000 * memory.PIPELINE_BYTES_PER_POINT / memory.INSPECTOR_SHARE / 2**20
    monkeypatch.setenv(memory.AVAILABLE_VARIABLE, str(available))
    assert main([str(path), "--port", "0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "dense.ply" in err and "--voxel-size" in err
    voxel = float(err.rsplit("--voxel-size ", 1)[1].split(")")[0])
    assert np.isfinite(voxel) and voxel > 0


def test_full_resolution_reaches_the_session(monkeypatch):
    """--full-resolution turns the multi-resolution path off; without it the session keeps the budget."""
    import app.main as app_main

    seen = []

    def fake_serve(cloud, host, port, **options):
        seen.append(options.get("point_budget", "default"))
        raise OSError("stop here")

    monkeypatch.setattr(app_main, "serve", fake_serve)
    assert main(["--port", "0", "--full-resolution"]) == 2
    assert main(["--port", "0"]) == 2
    assert seen == [None, "default"]


def test_a_cad_mesh_is_sampled_and_said_so(monkeypatch, capsys, tmp_path):
    """skel-inspect loads as `skelcore run` does, and prints what loading did; --sample 0 keeps the vertices."""
    import trimesh

    import app.main as app_main
    from skelcore.solids import solid_mesh

    trimesh.Trimesh(*solid_mesh("block_2_holes")).export(tmp_path / "block.stl")
    seen = []

    def fake_serve(cloud, host, port, **options):
        seen.append(len(cloud.points))
        raise OSError("stop here")

    monkeypatch.setattr(app_main, "serve", fake_serve)
    assert main([str(tmp_path / "block.stl"), "--port", "0"]) == 2
    assert "block.stl: mesh: its 264 vertices leave" in capsys.readouterr().out
    assert main([str(tmp_path / "block.stl"), "--port", "0", "--sample", "0"]) == 2
    assert seen == [10_000, 264]
