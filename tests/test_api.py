"""The Python API (skelcore.load/skeletonize/contract, Result), per-point weights and labels, and the README's
Python examples, executed."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

import skelcore
from skelcore import cli
from skelcore.errors import InputError, ParameterError
from skelcore.export import write_points_ply
from skelcore.labels import weights_from_labels
from skelcore.options import RunOptions
from skelcore.pipeline import run_pipeline

from conftest import REPO

ASSETS = sorted((REPO / "assets").glob("*.ply"))


def python_section(readme: str) -> list[str]:
    """The ```python blocks of the README's "## Python API" section, in order."""
    section = readme.split("\n## Python API", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", section, flags=re.S)


def test_readme_python_section_runs(tmp_path, monkeypatch):
    blocks = python_section((REPO / "README.md").read_text())
    assert len(blocks) >= 4
    (tmp_path / "assets").symlink_to(REPO / "assets")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__readme__"}
    try:
        for block in blocks:
            exec(compile(block, "README.md (Python API)", "exec"), namespace)
    finally:
        handle = namespace.get("handle")
        if handle is not None:
            handle.stop()
    assert (tmp_path / "out" / "y_branch" / "skeleton.json").is_file()


@pytest.mark.parametrize("asset", ASSETS, ids=lambda path: path.stem)
def test_skeletonize_gives_the_skeleton_of_skelcore_run(asset, tmp_path):
    assert cli.main(["run", str(asset), "--out", str(tmp_path / "cli"), "--quiet"]) == 0
    result = skelcore.skeletonize(asset)
    result.save(tmp_path / "api")
    cli_skeleton = json.loads((tmp_path / "cli" / "skeleton.json").read_text())
    assert json.loads((tmp_path / "api" / "skeleton.json").read_text()) == cli_skeleton
    assert np.allclose(result.nodes, cli_skeleton["nodes"]) and result.edges.tolist() == cli_skeleton["edges"]
    assert result.correspondence.tolist() == cli_skeleton["correspondence"]
    assert len(result.metrics) == len(result.states)
    metrics = json.loads((tmp_path / "cli" / "metrics.json").read_text())
    assert result.verdict == metrics["verdict"]


def test_skeletonize_matches_the_batch_pipeline_and_takes_arrays(tmp_path):
    asset = REPO / "assets" / "y_branch.ply"
    run_pipeline(asset, tmp_path / "batch", RunOptions())
    from_array = skelcore.skeletonize(skelcore.load(asset).points)
    assert from_array.nodes.tolist() == json.loads((tmp_path / "batch" / "skeleton.json").read_text())["nodes"]
    assert from_array.graph.number_of_nodes() == len(from_array.nodes)


def test_contract_steps_by_hand_and_retunes():
    points = skelcore.load(REPO / "assets" / "capsule.ply").points
    generator = skelcore.contract(points, max_iterations=5)
    first = next(generator)
    assert first.iteration == 0 and np.array_equal(first.points, points)
    second = generator.send(skelcore.ContractionParams(max_iterations=5, sl=2.0))
    assert second.iteration == 1 and second.params.sl == 2.0
    with pytest.raises(ParameterError, match="unknown parameter wl"):
        skelcore.contract(points, wl=3)


def test_bad_arguments_give_one_line_errors():
    points = skelcore.load(REPO / "assets" / "capsule.ply").points
    with pytest.raises(ParameterError, match=r"one weight per input point \(3,000\), got shape \(3,\)"):
        skelcore.skeletonize(points, weights=np.ones(3))
    with pytest.raises(ParameterError, match="not positive"):
        skelcore.skeletonize(points, weights=np.zeros(len(points)))
    with pytest.raises(ParameterError, match="not both"):
        skelcore.skeletonize(points, weights=np.ones(len(points)), labels=np.zeros(len(points)), label_weights={0: 2})
    with pytest.raises(InputError, match="no labels"):
        skelcore.skeletonize(points, label_weights={1: 2.0})
    with pytest.raises(ParameterError, match="method"):
        skelcore.skeletonize(points, method="nope")


@pytest.mark.parametrize("arguments", [{"wl0": "1"}, {"k": 2.5}, {"max_iterations": 3.0}, {"hold_curves": "no"},
                                       {"drop_jumps": 1}, {"sample": "x"}, {"voxel_size": "a"}, {"seed": "1"},
                                       {"seed": -1}, {"max_points": 10.5}, {"sample_radius": "0.02"},
                                       {"cleaning": skelcore.CleaningParams(denoise="no")}, {"progress": 3}])
def test_wrongly_typed_arguments_name_the_parameter(arguments):
    points = skelcore.load(REPO / "assets" / "capsule.ply").points
    name = next(iter(arguments))
    name = "denoise" if name == "cleaning" else name
    with pytest.raises(ParameterError, match=f"parameter {name}="):
        skelcore.skeletonize(points, **arguments)


def test_wrongly_typed_loading_options_are_refused_before_reading(tmp_path):
    for arguments in ({"sample": "x"}, {"voxel_size": "a"}, {"max_points": "5"}, {"seed": "s"}):
        with pytest.raises(ParameterError, match=f"parameter {next(iter(arguments))}="):
            skelcore.load(tmp_path / "not_read.xyz", **arguments)  # not there: refused before it is looked for
    with pytest.raises(ParameterError, match="parameter label_weights: weight '2'"):
        skelcore.skeletonize(np.zeros((30, 3)), label_weights={1: "2"})


def test_result_save_keeps_earlier_results_unless_forced(tmp_path):
    from skelcore.errors import OutputError

    result = skelcore.skeletonize(REPO / "assets" / "capsule.ply", max_iterations=2)
    result.save(tmp_path)
    (tmp_path / "notes.txt").write_text("mine")
    before = (tmp_path / "skeleton.json").read_text()
    with pytest.raises(OutputError, match="already holds the results of a run.*force=True"):
        result.save(tmp_path)
    with pytest.raises(ParameterError, match="parameter force="):
        result.save(tmp_path, force="yes")
    assert (tmp_path / "skeleton.json").read_text() == before
    (tmp_path / "skeleton.json").write_text("{}")
    assert result.save(tmp_path, force=True) == tmp_path
    assert (tmp_path / "skeleton.json").read_text() == before and (tmp_path / "notes.txt").read_text() == "mine"


def test_result_saves_its_skeleton_alone_in_the_format_its_file_name_ends_in(tmp_path):
    import networkx as nx

    result = skelcore.skeletonize(REPO / "assets" / "torus.ply")
    document = json.loads(result.save_skeleton(tmp_path / "loop.json").read_text())
    assert document["topology"] == result.topology and np.allclose(document["nodes"], result.nodes)
    graph = nx.read_graphml(result.save_skeleton(tmp_path / "loop.GraphML"), node_type=int)
    assert graph.number_of_edges() == len(result.edges)
    lines = result.save_skeleton(tmp_path / "loop.obj").read_text().splitlines()
    assert sum(line.startswith("v ") for line in lines) == len(result.nodes)
    assert result.save_skeleton(tmp_path / "loop.ply").read_text().startswith("ply")
    with pytest.raises(ParameterError, match="loop.dxf: a skeleton file's name ends in"):
        result.save_skeleton(tmp_path / "loop.dxf")


def test_labels_beyond_int64_are_refused_not_wrapped(tmp_path):
    points = np.random.default_rng(4).normal(size=(40, 3))
    write_points_ply(tmp_path / "p.ply", points)
    huge = np.full(40, 2**63, dtype=np.uint64)
    with pytest.raises(InputError, match="label 9223372036854775808 is too large"):
        skelcore.load(tmp_path / "p.ply", labels=huge)
    (tmp_path / "l.txt").write_text("9223372036854775807\n" * 39 + "1\n")  # int64's largest: read exactly
    assert skelcore.load(tmp_path / "p.ply", labels=tmp_path / "l.txt").labels[0] == 2**63 - 1
    (tmp_path / "l.txt").write_text("9223372036854775808\n" * 40)
    with pytest.raises(InputError, match="too large"):
        skelcore.load(tmp_path / "p.ply", labels=tmp_path / "l.txt")
    with pytest.raises(ParameterError, match="too large"):
        skelcore.skeletonize(points, labels=np.ones(40, dtype=int), label_weights={2**64: 2.0})


def test_import_is_light_and_every_public_name_is_documented():
    code = ("import sys, skelcore; heavy = [m for m in ('numpy', 'scipy', 'viser', 'open3d', 'app') if m in sys.modules];"
            "print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, "PYTHONPATH": str(REPO)})
    assert out.stdout.strip() == ""
    for name in skelcore.__all__:
        value = getattr(skelcore, name)
        if callable(value):
            assert (value.__doc__ or "").strip(), name
    for name in ("graph", "nodes", "edges", "correspondence", "contracted", "verdict", "topology", "save",
                 "report", "summary"):
        assert (getattr(skelcore.Result, name).__doc__ or "").strip(), name


def test_every_public_function_class_and_method_of_skelcore_has_a_docstring():
    import importlib
    import inspect
    import pkgutil

    missing = []
    for info in pkgutil.iter_modules(skelcore.__path__):
        module = importlib.import_module(f"skelcore.{info.name}")
        for name, value in vars(module).items():
            if name.startswith("_") or getattr(value, "__module__", None) != module.__name__:
                continue
            if not (inspect.isfunction(value) or inspect.isclass(value)):
                continue
            if not (inspect.getdoc(value) or "").strip() or inspect.getdoc(value).startswith(f"{name}("):
                missing.append(f"{info.name}.{name}")
            for member, attribute in (vars(value).items() if inspect.isclass(value) else ()):
                function = attribute.fget if isinstance(attribute, property) else attribute
                if not member.startswith("_") and inspect.isfunction(function) and not (function.__doc__ or "").strip():
                    missing.append(f"{info.name}.{name}.{member}")
    assert missing == []


# ---------------------------------------------------------------- weights
def _half_labels(points: np.ndarray) -> np.ndarray:
    return (points[:, 2] < np.median(points[:, 2])).astype(np.int64)


@pytest.mark.parametrize("method", ["lbc", "glskeleton"])
def test_heavier_labelled_points_contract_further_in_the_first_step(method):
    points = skelcore.load(REPO / "assets" / "y_branch.ply").points
    labelled = _half_labels(points) == 1
    moved = {}
    for weight in (1.0, 10.0, 0.3):
        weights = np.where(labelled, weight, 1.0)
        generator = skelcore.contract(points, method=method, weights=weights)
        next(generator)
        state = next(generator)
        moved[weight] = np.linalg.norm(state.points[state.owner] - points, axis=1)[labelled].mean()
    assert moved[10.0] > 1.5 * moved[1.0] > 1.5 * moved[0.3]


@pytest.mark.parametrize("method", ["lbc", "glskeleton"])
def test_unit_weights_change_nothing(method):
    points = skelcore.load(REPO / "assets" / "y_branch.ply").points
    plain = skelcore.skeletonize(points, method=method, max_iterations=4)
    ones = skelcore.skeletonize(points, method=method, max_iterations=4, weights=np.ones(len(points)))
    assert np.array_equal(plain.contracted, ones.contracted)
    assert plain.nodes.tolist() == ones.nodes.tolist()


def test_glskeleton_merged_points_carry_the_mean_weight_of_their_points():
    from skelcore.contraction import IterationState  # noqa: F401 (the state's owner map is what is checked)

    points = skelcore.load(REPO / "assets" / "y_branch.ply").points
    labels = _half_labels(points)
    result = skelcore.skeletonize(points, method="glskeleton", labels=labels, label_weights={1: 5.0})
    weights = weights_from_labels(result.cloud.labels, {1: 5.0})  # the labels of the points kept by cleaning
    assert np.array_equal(result.weights, weights)
    state = result.states[-1]
    assert state.n_points < len(points)  # points were merged
    stands_for = np.bincount(state.owner, minlength=state.n_points)
    mean = np.bincount(state.owner, weights=weights, minlength=state.n_points) / stands_for
    assert set(np.round(mean[stands_for == 1], 9)) <= {1.0, 5.0}
    assert ((mean >= 1.0) & (mean <= 5.0)).all()


# ---------------------------------------------------------------- labels
def test_labels_survive_a_ply_round_trip(tmp_path):
    points = np.random.default_rng(1).normal(size=(200, 3))
    labels = np.random.default_rng(2).integers(0, 5, 200)
    write_points_ply(tmp_path / "labelled.ply", points, labels=labels)
    cloud = skelcore.load(tmp_path / "labelled.ply")
    assert np.array_equal(cloud.points, points) and np.array_equal(cloud.labels, labels)
    # duplicates are removed with their labels, the first occurrence kept
    write_points_ply(tmp_path / "repeated.ply", np.vstack([points, points[:10]]),
                     labels=np.concatenate([labels, labels[:10] + 7]))
    assert np.array_equal(skelcore.load(tmp_path / "repeated.ply").labels, labels)


@pytest.mark.parametrize("prop, kind", [("class", "uchar"), ("scalar_label", "float"), ("Classification", "int")])
def test_labels_are_read_from_common_ply_properties(tmp_path, prop, kind):
    points = np.random.default_rng(3).normal(size=(50, 3))
    labels = np.arange(50) % 3
    header = (f"ply\nformat ascii 1.0\nelement vertex 50\nproperty float x\nproperty float y\nproperty float z\n"
              f"property float nx\nproperty {kind} {prop}\nend_header\n")
    rows = [f"{x:.6f} {y:.6f} {z:.6f} 2 {label}" for (x, y, z), label in zip(points, labels)]
    (tmp_path / "c.ply").write_text(header + "\n".join(rows) + "\n")
    assert np.array_equal(skelcore.load(tmp_path / "c.ply").labels, labels)
    assert np.array_equal(skelcore.load(tmp_path / "c.ply", labels="nx").labels, np.full(50, 2))


def test_label_files_and_bad_labels(tmp_path):
    points = np.random.default_rng(4).normal(size=(40, 3))
    write_points_ply(tmp_path / "p.ply", points)
    np.savetxt(tmp_path / "l.txt", np.arange(40) % 2, fmt="%d")
    np.save(tmp_path / "l.npy", np.arange(40) % 3)
    assert np.array_equal(skelcore.load(tmp_path / "p.ply", labels=tmp_path / "l.txt").labels, np.arange(40) % 2)
    assert np.array_equal(skelcore.load(tmp_path / "p.ply", labels=str(tmp_path / "l.npy")).labels, np.arange(40) % 3)
    np.savetxt(tmp_path / "short.txt", np.arange(39), fmt="%d")
    with pytest.raises(InputError, match="39 labels for 40 points"):
        skelcore.load(tmp_path / "p.ply", labels=tmp_path / "short.txt")
    with pytest.raises(InputError, match="no vertex property 'class'"):
        skelcore.load(tmp_path / "p.ply", labels="class")
    (tmp_path / "folder").mkdir()
    with pytest.raises(InputError, match="is a folder, and no vertex property"):  # it said "no vertex property"
        cwd = os.getcwd()
        try:
            os.chdir(tmp_path)
            skelcore.load(tmp_path / "p.ply", labels="folder")
        finally:
            os.chdir(cwd)
    (tmp_path / "l.dat").write_text("0\n")
    for path, problem in (("gone.txt", "no such file"), (tmp_path / "gone", "no such file"),
                          (tmp_path, "is a folder"), (tmp_path / "l.dat", "not a label file")):
        with pytest.raises(InputError, match=f"labels {re.escape(str(path))}: {problem}"):  # not "no vertex property"
            skelcore.load(tmp_path / "p.ply", labels=path)
    np.savetxt(tmp_path / "half.txt", np.arange(40) / 2)
    with pytest.raises(InputError, match="integers"):
        skelcore.load(tmp_path / "p.ply", labels=tmp_path / "half.txt")
    # complex labels lost their imaginary parts with a warning; an empty file read as no labels with one
    np.save(tmp_path / "complex.npy", np.arange(40) + 1j)
    (tmp_path / "empty.txt").write_text("")
    for path, problem in (("complex.npy", "complex numbers"), ("empty.txt", "empty")):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(InputError, match=problem):
                skelcore.load(tmp_path / "p.ply", labels=tmp_path / path)


def test_cli_labels_and_label_weights_are_recorded(tmp_path, capsys):
    cloud = skelcore.load(REPO / "assets" / "y_branch.ply")
    labels = _half_labels(cloud.points)
    write_points_ply(tmp_path / "y.ply", cloud.points, labels=labels)
    np.savetxt(tmp_path / "labels.txt", labels, fmt="%d")
    args = ["--label-weight", "1=4", "--label-weight", "0=0.5", "--quiet"]
    assert cli.main(["run", str(tmp_path / "y.ply"), "--out", str(tmp_path / "prop"), *args]) == 0
    assert cli.main(["run", str(REPO / "assets" / "y_branch.ply"), "--labels", str(tmp_path / "labels.txt"),
                     "--out", str(tmp_path / "file"), *args]) == 0
    recorded = json.loads((tmp_path / "prop" / "params.json").read_text())["weights"]
    assert recorded["label_weights"] == {"0": 0.5, "1": 4.0}
    contracted = skelcore.load(tmp_path / "prop" / "contracted.ply")  # keeps the labels of the points contracted
    assert contracted.labels is not None and set(contracted.labels) == {0, 1}
    kept = json.loads((tmp_path / "prop" / "metrics.json").read_text())["cleaning"]["kept"]
    assert recorded["weighted_points"] == kept and recorded["max"] == 4.0  # every weight is 4 or 0.5
    assert json.loads((tmp_path / "file" / "params.json").read_text())["weights"]["labels"] == str(tmp_path / "labels.txt")
    assert cli.main(["batch", str(tmp_path / "y.ply"), "--out", str(tmp_path / "batch"), "--no-report", "--quiet",
                     *args[:-1]]) == 0
    weighted = skelcore.skeletonize(cloud.points, labels=labels, label_weights={1: 4, 0: 0.5})
    for folder in ("prop", "file", "batch/y"):
        saved = json.loads((tmp_path / folder / "skeleton.json").read_text())
        assert saved["nodes"] == weighted.nodes.tolist()
    assert cli.main(["run", str(tmp_path / "y.ply"), "--out", str(tmp_path / "bad"), "--label-weight", "1=4",
                     "--labels", "nope"]) == 2
    assert "nope" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.main(["run", str(tmp_path / "y.ply"), "--out", str(tmp_path / "bad"), "--label-weight", "1:4"])


def test_explicit_weights_are_listed_in_params_json(tmp_path):
    points = skelcore.load(REPO / "assets" / "capsule.ply").points
    weights = np.linspace(0.5, 2.0, len(points))
    result = skelcore.skeletonize(points, weights=weights, max_iterations=2, cleaning=False)
    result.save(tmp_path)
    recorded = json.loads((tmp_path / "params.json").read_text())["weights"]
    assert np.allclose(recorded["values"], weights) and recorded["labels"] is None
    # cleaning drops points: the weights of the points kept go with them
    noisy = np.vstack([points, points.max(axis=0) + 5.0])
    cleaned = skelcore.skeletonize(noisy, weights=np.append(weights, 9.0), max_iterations=2,
                                   cleaning=skelcore.CleaningParams(denoise=False))
    row_of = {tuple(point): row for row, point in enumerate(noisy.tolist())}
    kept = np.array([row_of[tuple(point)] for point in cleaned.cloud.points.tolist()])
    assert len(points) not in kept and np.array_equal(cleaned.weights, np.append(weights, 9.0)[kept])
    assert any("cleaning removed" in note for note in cleaned.cloud.notes)


def test_weights_given_per_input_row_follow_the_points_loading_keeps():
    points = skelcore.load(REPO / "assets" / "capsule.ply").points
    weights = np.linspace(0.5, 2.0, len(points))
    repeated = np.vstack([points, points[:40]])  # loading drops the 40 repeats; each point keeps its first row's
    given = np.append(weights, np.full(40, 9.0))
    result = skelcore.skeletonize(repeated, weights=given, max_iterations=1, cleaning=False)
    assert np.array_equal(result.weights, weights)
    gone = repeated.copy()
    gone[3] = np.nan  # its repeat in row len(points) + 3 is now the first: its weight goes with the point
    result = skelcore.skeletonize(gone, weights=given, max_iterations=1, cleaning=False, drop_nonfinite=True)
    assert np.array_equal(result.weights, np.r_[weights[:3], weights[4:], 9.0])
    state = next(skelcore.contract(repeated, weights=given))
    assert len(state.points) == len(points)
    with pytest.raises(ParameterError, match=rf"per input point \({len(repeated):,}\) or per point kept "
                                             rf"\({len(points):,}\)"):
        skelcore.skeletonize(repeated, weights=given[:-1])
    unread = given.copy()
    unread[len(points):] = np.nan  # the repeats' rows are left out, and their weights with them
    assert np.array_equal(skelcore.skeletonize(repeated, weights=unread, max_iterations=1, cleaning=False).weights,
                          weights)


def test_weights_for_points_drawn_anew_are_refused_in_words_even_when_the_counts_agree(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    mesh = trimesh.creation.torus(1.0, 0.3)  # vertices on rings only: its surface is drawn over
    for count in (None, len(mesh.vertices)):  # as many points drawn as it has vertices: still not theirs
        with pytest.raises(ParameterError, match=r"replaced by .* drawn anew.*skelcore\.load"):
            skelcore.skeletonize(mesh, weights=np.ones(len(mesh.vertices)), sample=count)
    points = skelcore.load(REPO / "assets" / "capsule.ply").points
    np.savetxt(tmp_path / "capsule.xyz", points)
    with pytest.raises(ParameterError, match="drawn anew"):  # voxels finer than the spacing: reordered, not merged
        skelcore.skeletonize(tmp_path / "capsule.xyz", weights=np.ones(len(points)), voxel_size=1e-9)
    cloud = skelcore.load(tmp_path / "capsule.xyz", voxel_size=1e-9)  # loaded first: weighted point by point
    weights = np.linspace(1.0, 2.0, len(cloud.points))
    assert np.array_equal(skelcore.skeletonize(cloud, weights=weights, max_iterations=1, cleaning=False).weights,
                          weights)
    with pytest.raises(ParameterError, match="complex numbers"):
        skelcore.skeletonize(points, weights=np.ones(len(points)) * 1j)


def test_result_report_is_one_page(tmp_path):
    result = skelcore.skeletonize(skelcore.load(REPO / "assets" / "capsule.ply").points)
    page = result.report(tmp_path / "r.html").read_text()
    assert "Contraction stability report" in page and "original cloud not shown" not in page


def test_inspect_without_an_installed_inspector_says_so(monkeypatch):
    import importlib.metadata

    monkeypatch.setattr(importlib.metadata, "entry_points", lambda **_: [])
    with pytest.raises(skelcore.SkelError, match="no inspector is installed"):
        skelcore.inspect(np.random.default_rng(0).random((50, 3)))


def test_a_run_whose_first_step_fails_is_an_error_not_a_result():
    from skelcore.shapes import make_shape

    points = make_shape("torus", 800).points
    with pytest.raises(skelcore.SkelError, match="first contraction step failed") as failure:
        skelcore.skeletonize(points, weights=np.full(len(points), 1e20))
    # the cause, not the words of a run that kept a good state: there is none
    assert "(the sparse solver failed" in str(failure.value) and "kept" not in str(failure.value)


def test_weights_past_w_l_s_range_are_refused_in_words():
    """A weight multiplies W_L on its row: past WEIGHT_MAX the normal equations' squares overflowed (numpy's warning
    reached the user before the solver's refusal)."""
    points = np.random.default_rng(0).random((40, 3))
    for weight in (1.7e308, 1e101):
        with pytest.raises(ParameterError, match="1 of 40 weights are not positive numbers up to 1e\\+100"):
            skelcore.skeletonize(points, weights=np.r_[np.ones(39), weight])
        with pytest.raises(ParameterError, match="must be a positive number up to 1e\\+100"):
            skelcore.skeletonize(points, labels=np.ones(40, dtype=int), label_weights={1: weight})


def test_open3d_and_trimesh_clouds_and_meshes_are_taken_as_they_come():
    """A robotics user holds an open3d PointCloud, a graphics user a trimesh mesh: both skeletonise without a
    conversion (they were refused as "coordinates are not numbers"); a mesh is judged as a mesh file is."""
    import open3d as o3d
    import trimesh

    torus = trimesh.creation.torus(1.0, 0.3)
    points = trimesh.sample.sample_surface(torus, 3000, seed=0)[0]
    clouds = (o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points)), trimesh.PointCloud(points))
    meshes = (torus, o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(torus.vertices),
                                               o3d.utility.Vector3iVector(torus.faces)))
    for geometry in (*clouds, *meshes):
        result = skelcore.skeletonize(geometry)
        assert (result.topology["cycles"], result.topology["components"]) == (1, 1), type(geometry).__name__
        assert result.cloud.name == type(geometry).__name__
    sampled = skelcore.skeletonize(torus)  # 1,024 vertices in rings 2.6 sample radii apart: drawn over
    assert len(sampled.cloud.points) == 10_000 and "points are drawn evenly over it" in sampled.cloud.notes[0]
    assert len(skelcore.skeletonize(torus, sample=0).cloud.points) == len(torus.vertices)
    with pytest.raises(InputError, match=r"^array: coordinates are complex numbers; give their real parts"):
        skelcore.skeletonize(points.astype(complex))
    with pytest.raises(InputError, match=r"^array: coordinates are not numbers \(got dict\)$"):
        skelcore.skeletonize({"x": 1})


def test_a_cloud_made_by_hand_and_arguments_of_the_wrong_type_are_refused_in_words(tmp_path, monkeypatch):
    """skelcore.Cloud is public: one made by hand with NaN, identical points, two columns or labels of another
    length raised ValueError, ZeroDivisionError or IndexError from deep inside; paths of other types, a NUL byte,
    params as a dict, and an empty folder for save (which wrote the five files into the working folder) likewise."""
    from skelcore.errors import SkelError

    points = np.random.default_rng(0).normal(size=(300, 3))
    for cloud in (skelcore.Cloud(points=np.full((30, 3), np.nan)), skelcore.Cloud(points=np.ones((100, 3))),
                  skelcore.Cloud(points=points[:, :2]), skelcore.Cloud(points=points, labels=np.zeros(3, int))):
        with pytest.raises(SkelError):
            skelcore.skeletonize(cloud)
        with pytest.raises(SkelError):
            next(iter(skelcore.contract(cloud)))
    assert len(skelcore.skeletonize(skelcore.Cloud(points=points.tolist()), max_iterations=1).cloud.points) > 250
    for call in (lambda: skelcore.load(None), lambda: skelcore.load(points),
                 lambda: skelcore.load("assets/torus.ply", drop_nonfinite="x"),
                 lambda: skelcore.contract(points, params={"k": 8})):
        with pytest.raises(SkelError):
            call()
    generator = skelcore.contract(points)
    next(generator)
    with pytest.raises(SkelError, match="ContractionParams"):
        generator.send({"k": 8})
    result = skelcore.skeletonize(points, max_iterations=2)
    monkeypatch.chdir(tmp_path)
    for bad in (None, 5, b"/tmp/x", "a\0b", "", " "):
        with pytest.raises(SkelError):
            result.save(bad)
        with pytest.raises(SkelError):
            result.report(bad)
    assert not list(tmp_path.iterdir())
    thinned = skelcore.skeletonize(points, voxel_size=0.5, max_iterations=1)  # an array's loading options count
    assert len(thinned.cloud.points) < 300 and any("voxel" in note for note in thinned.cloud.notes)
