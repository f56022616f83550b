"""`skelcore run` end to end, as a user runs it: files written, progress, help, bad input."""
import json
import subprocess
import sys

import numpy as np
import pytest

from skelcore.cli import main
from skelcore.shapes import make_shape


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "skelcore.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=None)


def test_run_writes_every_result_file(tmp_path, assets_dir):
    result = run_cli("run", assets_dir / "torus.ply", "--out", tmp_path / "out")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert any(line.startswith("iteration 1:") for line in lines)
    assert "stopped after iteration" in result.stdout
    out = tmp_path / "out"
    skeleton = json.loads((out / "skeleton.json").read_text())
    nodes, edges = np.array(skeleton["nodes"]), np.array(skeleton["edges"])
    assert nodes.shape[1] == 3 and edges.shape[1] == 2 and edges.max() < len(nodes)
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["iterations"][0]["iteration"] == 0
    assert metrics["termination"] in ("ring_ratio", "max_iterations")
    assert {"d_theta", "delta_kappa", "boundedness", "verdict", "wl", "ring_ratio"} <= metrics["iterations"][-1].keys()
    assert metrics["verdict"]["label"] in ("stable", "not yet converged", "unstable")
    params = json.loads((out / "params.json").read_text())
    assert params["contraction"]["k"] == 30 and params["contraction"]["wl0"] > 0
    assert params["input"].endswith("torus.ply")
    header = (out / "contracted.ply").read_bytes()[:300]
    assert b"element vertex 3000" in header
    assert b"element edge" in (out / "skeleton.ply").read_bytes()[:400]
    assert not list(out.glob(".*tmp"))


def test_run_params_reproduce_the_run(tmp_path, assets_dir):
    first = tmp_path / "a"
    assert main(["run", str(assets_dir / "capsule.ply"), "--out", str(first), "--quiet", "--max-iterations", "3"]) == 0
    contraction = json.loads((first / "params.json").read_text())["contraction"]
    second = tmp_path / "b"
    flags = ["--k", contraction["k"], "--wl0", contraction["wl0"], "--wh0", contraction["wh0"], "--sl", contraction["sl"],
             "--wl-max", contraction["wl_max"], "--max-iterations", contraction["max_iterations"],
             "--termination", contraction["termination"]]
    assert main(["run", str(assets_dir / "capsule.ply"), "--out", str(second), "--quiet", *map(str, flags)]) == 0
    assert (first / "skeleton.json").read_text() == (second / "skeleton.json").read_text()


def test_help_documents_every_parameter_with_its_default():
    result = run_cli("run", "--help")
    assert result.returncode == 0
    for flag in ("--k", "--wl0", "--wh0", "--sl", "--wl-max", "--max-iterations", "--termination",
                 "--sample-radius", "--seed", "--method", "--out"):
        assert flag in result.stdout
    assert "default: 3.0" in result.stdout and "default: 2048.0" in result.stdout and "default: 0.02" in result.stdout


@pytest.mark.parametrize("make, fragment", [
    (lambda d: d / "missing.ply", "file not found"),
    (lambda d: (d / "bad.ply").write_bytes(b"\x00garbage\xff") and d / "bad.ply", "bad.ply"),
    (lambda d: (d / "nan.xyz").write_text("0 0 nan\n" * 30) and d / "nan.xyz", "NaN"),
    (lambda d: (d / "x.foo").write_text("1 2 3") and d / "x.foo", "unknown format"),
])
def test_bad_input_is_one_line_and_non_zero(tmp_path, make, fragment):
    result = run_cli("run", make(tmp_path), "--out", tmp_path / "out")
    assert result.returncode != 0
    assert "Traceback" not in result.stderr
    message = result.stderr.strip().splitlines()
    assert len(message) == 1 and fragment in message[0], result.stderr


def test_a_flag_argparse_refuses_is_one_line(tmp_path, assets_dir):
    """argparse's own refusals (a wrong type, a missing argument, an unknown command) print its usage first."""
    for args in (["run", assets_dir / "torus.ply", "--out", tmp_path / "out", "--sample", "1.5"], ["run"], ["frob"]):
        result = run_cli(*args)
        assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1, result.stderr
        assert "--help" in result.stderr and "usage" not in result.stderr


def test_bad_parameter_is_one_line_and_non_zero(tmp_path, assets_dir):
    result = run_cli("run", assets_dir / "torus.ply", "--out", tmp_path / "out", "--sl", "-2")
    assert result.returncode != 0 and "Traceback" not in result.stderr
    assert "sl=" in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_a_command_line_process_runs_with_the_collector_on_after_its_imports(tmp_path):
    """skelcore.startup: a process of its own (no argv) loads its modules with the garbage collector off, then
    freezes them and turns it back on for the run; called with argv (as here in-process) nothing changes."""
    import gc

    frozen = gc.get_freeze_count()
    assert main(["shapes", "--out", str(tmp_path / "in"), "--names", "torus", "--n", "200"]) == 0
    assert gc.isenabled() and gc.get_freeze_count() == frozen
    code = ("import gc, sys; from skelcore import cli; "
            f"sys.argv = ['skelcore', 'run', {str(tmp_path / 'in' / 'torus.ply')!r}, '--out', "
            f"{str(tmp_path / 'out')!r}, '--quiet']; "
            "code = cli.main(); print(code, gc.isenabled(), gc.get_freeze_count() > 10000, "
            "'skelcore.pipeline' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["0", "True", "True", "True"]
    assert (tmp_path / "out" / "metrics.json").exists()


def test_label_weights_on_a_resampled_cloud_say_the_labels_were_dropped(tmp_path, capsys):
    from skelcore.export import write_points_ply

    points = make_shape("torus", 2000).points
    path = write_points_ply(tmp_path / "labelled.ply", points, labels=(points[:, 0] > 0).astype(np.int64))
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet", "--label-weight", "1=5",
                 "--voxel-size", "0.05"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "dropped the labels" in err


def test_a_negative_label_is_weighted_as_written(tmp_path, capsys):
    """`--label-weight -5=2`: argparse alone reads `-5=2` as an unknown option ("expected one argument")."""
    from skelcore.export import write_points_ply

    points = make_shape("torus", 2000).points
    path = write_points_ply(tmp_path / "labelled.ply", points, labels=np.where(points[:, 0] > 0, -5, 3))
    with pytest.raises(SystemExit):  # a label without a weight is still refused, in the argument's words
        main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet", "--label-weight", "-5", "--wl0", "0.5"])
    assert "argument --label-weight: '-5': no '='" in capsys.readouterr().err
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet", "--label-weight", "-5=2",
                 "--label-weight", "3=1", "--max-iterations", "1"]) == 0
    params = json.loads((tmp_path / "out" / "params.json").read_text())
    assert params["weights"]["label_weights"] == {"-5": 2.0, "3": 1.0}


def test_results_that_appear_during_a_run_are_refused_in_the_command_lines_words(tmp_path, assets_dir, capsys,
                                                                                   monkeypatch):
    """`--out` is checked before the work and again as the results are written: another run's results written
    there meanwhile are kept, and the refusal says --force (not the Python API's force=True)."""
    import skelcore.api

    out, real_run = tmp_path / "out", skelcore.api.run

    def run_beside_another(*args, **kwargs):
        result = real_run(*args, **kwargs)
        out.mkdir()
        (out / "metrics.json").write_text("another run's")
        return result

    monkeypatch.setattr(skelcore.api, "run", run_beside_another)
    assert main(["run", str(assets_dir / "torus.ply"), "--out", str(out), "--quiet"]) == 2
    error = capsys.readouterr().err
    assert "--force" in error and "force=True" not in error and error.count("\n") == 1
    assert (out / "metrics.json").read_text() == "another run's"


def test_outputs_under_a_file_or_over_earlier_shapes_are_refused_before_the_work(tmp_path, capsys):
    taken = tmp_path / "taken"
    taken.write_text("mine")
    for args in (["bench-quality", "--shapes", "block_1_hole", "--variants", "clean", "--json", str(taken / "x.json")],
                 ["study", "--out", str(taken), "--shapes", "torus", "--no-benchmark"]):
        assert main([*args, "--quiet"] if args[0] == "bench-quality" else args) == 2
        assert capsys.readouterr().err.count("\n") == 1
    shapes = ["shapes", "--out", str(tmp_path / "shapes"), "--names", "torus", "--n", "200"]
    assert main(shapes) == 0
    first = (tmp_path / "shapes" / "torus.ply").read_bytes()
    assert main([*shapes, "--seed", "1"]) == 2 and "--force" in capsys.readouterr().err
    assert (tmp_path / "shapes" / "torus.ply").read_bytes() == first
    assert main([*shapes, "--seed", "1", "--force"]) == 0
    assert (tmp_path / "shapes" / "torus.ply").read_bytes() != first


@pytest.mark.parametrize("solid", ["block_2_holes", "chair", "handled_ball"])
def test_a_cad_mesh_keeps_its_loops(tmp_path, capsys, solid):
    """An STL of a CAD solid has vertices only at its corners and the rims of its holes, or a ball 14 times more
    sparsely than its handles; contracted as they are, the drilled block lost both loops (a 4-node skeleton), the
    chair its two and the handled ball all three (3 pieces). Its surface is drawn from instead."""
    import trimesh

    from skelcore.solids import mesh_topology, solid_mesh

    vertices, faces = solid_mesh(solid)
    trimesh.Trimesh(vertices, faces).export(tmp_path / f"{solid}.stl")
    assert main(["run", str(tmp_path / f"{solid}.stl"), "--out", str(tmp_path / "out")]) == 0
    assert "points are drawn evenly over it instead" in capsys.readouterr().out
    topology = json.loads((tmp_path / "out" / "skeleton.json").read_text())["topology"]
    assert (topology["cycles"], topology["components"]) == (mesh_topology(vertices, faces)["genus"], 1)
    assert json.loads((tmp_path / "out" / "params.json").read_text())["sample"] is None  # chosen again on a re-run


def test_a_verdict_other_than_stable_names_the_criteria_it_failed(tmp_path, assets_dir, capsys):
    """The summary line says "verdict not yet converged"; the line under it says why, as metrics.json does."""
    assert main(["run", str(assets_dir / "torus.ply"), "--out", str(tmp_path / "one"), "--max-iterations", "2"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "verdict not yet converged" in lines[-2]
    assert lines[-1].startswith("  not yet converged: mean D_theta 0.") and lines[-1].endswith(" (target 0.5 within 0.25)")
    assert main(["run", str(assets_dir / "torus.ply"), "--out", str(tmp_path / "all")]) == 0
    assert capsys.readouterr().out.splitlines()[-1].split("; ")[-2] == "verdict stable"


def test_a_cloud_sparser_than_the_skeletons_balls_is_said_to_be(tmp_path, assets_dir, capsys):
    """A few hundred points on a torus lie farther apart than the sample radius: the run says what that costs."""
    points = make_shape("torus", 400, seed=0).points
    np.savetxt(tmp_path / "sparse.xyz", points)
    assert main(["run", str(tmp_path / "sparse.xyz"), "--out", str(tmp_path / "sparse")]) == 0
    said = [line for line in capsys.readouterr().out.splitlines() if "a sparse cloud" in line]
    assert len(said) == 1 and "more than the skeleton's sample radius (2.0%)" in said[0]
    assert main(["run", str(assets_dir / "torus.ply"), "--out", str(tmp_path / "dense")]) == 0
    assert "a sparse cloud" not in capsys.readouterr().out


def test_noise_past_the_diagonal_and_a_bench_quality_out_that_is_a_file_are_refused_before_the_work(tmp_path,
                                                                                                    capsys):
    """shapes --noise 1e300 wrote a cloud of Inf points and exited 0, bench --noise 1e308 failed inside a child
    (an internal error), bench-quality --out FILE ran every case to an ERROR and exited 0."""
    taken = tmp_path / "taken"
    taken.write_text("mine")
    for args in (["shapes", "--out", str(tmp_path / "s"), "--names", "torus", "--noise", "1e300"],
                 ["bench", "--points", "20", "--noise", "1e308", "--method", "lbc", "--baseline-max", "0"],
                 ["bench-quality", "--shapes", "capsule", "--variants", "clean", "--points", "500", "--out",
                  str(taken)]):
        assert main(args) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and ("noise" in err or "is a file" in err)
    assert not (tmp_path / "s").exists() and taken.read_text() == "mine"
