"""`skelcore bench`: the whole-run timing children and the pc-skeletor baseline's protocol."""
import os
import subprocess
import sys
import textwrap

import pytest

from skelcore.bench import _pc_skeletor_interpreter, _peer_child, run_bench
from skelcore.errors import ParameterError

FAKE_PEER = {
    # Stand-ins with pc-skeletor's and open3d's call signatures, so the peer script runs without them.
    "open3d/__init__.py": "from . import io\n",
    "open3d/io.py": "def read_point_cloud(path):\n    return open(path, 'rb').read()\n",
    "pc_skeletor/__init__.py": textwrap.dedent("""
        import os
        class LBC:
            def __init__(self, point_cloud, max_iteration_steps, down_sample):
                assert point_cloud.startswith(b"ply") and max_iteration_steps == 3 and down_sample == -1
            def extract_skeleton(self):
                pass
            def extract_topology(self):
                pass
            def save(self, output):
                os.makedirs(output)
    """),
}


def test_bench_prints_runs_baseline_and_ratios():
    lines: list[str] = []
    rows = run_bench([600], methods=("lbc",), baseline_max=600, out=lines.append)
    assert [row["method"] for row in rows] == ["lbc", "baseline"]
    assert "; baseline: " in lines[0]
    assert "speed-up vs pc-skeletor" in lines[-2]
    assert lines[-1].split()[0] == "600" and " lbc " in lines[-1] and lines[-1].endswith("x)")


@pytest.mark.parametrize("flags, words", [(["--baseline-max", "-1"], "baseline_max=-1"), (["--noise", "-0.1"], "noise")])
def test_bench_refuses_bad_settings_before_any_work(flags, words, capsys, monkeypatch):
    from skelcore import bench
    from skelcore.cli import main

    monkeypatch.setattr(bench, "compile_package", lambda: pytest.fail("the bench started"))
    assert main(["bench", "--points", "600", *flags]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and words in error


def test_pc_skeletor_interpreter_is_checked():
    with pytest.raises(ParameterError, match="cannot be started"):
        _pc_skeletor_interpreter("/nonexistent/python")
    with pytest.raises(ParameterError, match="cannot import pc_skeletor"):
        _pc_skeletor_interpreter(_python_without_peer())


def test_peer_run_follows_pc_skeletors_readme(tmp_path, monkeypatch):
    for name, text in FAKE_PEER.items():
        (tmp_path / "peer" / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "peer" / name).write_text(text)
    cloud = tmp_path / "cloud.ply"
    cloud.write_bytes(b"ply\n")
    monkeypatch.setenv("PYTHONPATH", str(tmp_path / "peer"))
    row = _peer_child(1000, sys.executable, cloud, 3, tmp_path / "out")
    assert (tmp_path / "out").is_dir()
    assert row["method"] == "baseline" and row["iterations"] == 3 and row["total"] > 0
    assert set(row["stages"]) == {"start and load", "contract", "skeleton", "write"}


def _python_without_peer() -> str:
    """This interpreter, unless pc-skeletor is installed in it (then the test cannot show the refusal)."""
    found = subprocess.run([sys.executable, "-c", "import pc_skeletor"], capture_output=True,
                           env={**os.environ, "PYTHONPATH": ""}).returncode == 0
    if found:
        pytest.skip("pc-skeletor is installed in this interpreter")
    return sys.executable


def test_bench_compiles_the_package_before_timing():
    """The timed runs read skelcore's bytecode, as an installed package's do, whatever PYTHONDONTWRITEBYTECODE says."""
    import importlib.util

    import skelcore.pipeline
    from skelcore.bench import compile_package

    assert compile_package()
    assert os.path.exists(importlib.util.cache_from_source(skelcore.pipeline.__file__))
