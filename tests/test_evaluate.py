import json
import warnings

import numpy as np
import pytest

from skelcore import shapes
from skelcore.errors import InputError, SkelError
from skelcore.evaluate import evaluate, format_report, graph_topology, load_graph, make_graph


def truth_of(name):
    nodes, edges, _ = shapes.centreline(name)
    return make_graph(nodes, edges, name)


def test_identical_skeleton_scores_zero():
    truth = truth_of("two_hole")
    result = evaluate(truth, truth)
    assert result["chamfer"] == pytest.approx(0.0, abs=1e-12)
    assert result["hausdorff"] == pytest.approx(0.0, abs=1e-12)
    assert result["topology"]["matches"]
    assert result["topology"]["truth"]["cycles"] == 2


@pytest.mark.parametrize("magnitude", [1e308, 1e300, 1e200, 1e-300])  # 1e308: past 2^1023
def test_extreme_coordinates_are_scored_without_overflow(magnitude):
    truth = truth_of("torus")
    delta = 0.05
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = evaluate(make_graph((truth.nodes + [0, 0, delta]) * magnitude, truth.edges),
                          make_graph(truth.nodes * magnitude, truth.edges))
    diagonal = np.linalg.norm(truth.nodes.max(0) - truth.nodes.min(0))
    assert result["chamfer"] == pytest.approx(delta / diagonal, rel=1e-9)
    if magnitude < 1e308:  # past it the diagonal itself is beyond float64
        assert result["diagonal"] == pytest.approx(diagonal * magnitude)


def test_a_skeleton_in_other_coordinates_than_its_truth_is_refused():
    truth = truth_of("torus")
    with pytest.raises(InputError, match="not in the same coordinates"):
        evaluate(make_graph(truth.nodes * 1e300, truth.edges), make_graph(truth.nodes * 1e-300, truth.edges))


def test_shifted_skeleton_distances():
    truth = truth_of("torus")  # a shift normal to the circle's plane moves every point by exactly delta
    delta = 0.05
    result = evaluate(make_graph(truth.nodes + [0, 0, delta], truth.edges), truth)
    diagonal = np.linalg.norm(truth.nodes.max(0) - truth.nodes.min(0))
    assert result["diagonal"] == pytest.approx(diagonal)
    assert result["chamfer"] == pytest.approx(delta / diagonal, rel=1e-9)
    assert result["hausdorff"] == pytest.approx(delta / diagonal, rel=1e-9)
    capsule = truth_of("capsule")  # along the axis: overhang delta at one end of each, length 2
    result = evaluate(make_graph(capsule.nodes + [delta, 0, 0], capsule.edges), capsule)
    assert result["hausdorff"] == pytest.approx(delta / 2.0, rel=1e-9)
    assert result["chamfer"] == pytest.approx(delta**2 / (2 * 2.0) / 2.0, rel=0.02)  # mean of a ramp over the overhang


def test_topology_difference_is_reported():
    truth = truth_of("y_branch")
    keep = np.flatnonzero(truth.nodes[:, 0] < 1e-9)  # drop the arm towards +x, keep the junction
    remap = -np.ones(len(truth.nodes), dtype=np.int64)
    remap[keep] = np.arange(len(keep))
    edges = remap[truth.edges]
    skeleton = make_graph(truth.nodes[keep], edges[(edges >= 0).all(1)])
    result = evaluate(skeleton, truth)
    assert not result["topology"]["matches"]
    assert result["topology"]["skeleton"]["ends"] == 2 and result["topology"]["truth"]["ends"] == 3
    assert result["skeleton_to_truth"]["max"] == pytest.approx(0.0, abs=1e-12)
    assert result["truth_to_skeleton"]["max"] > 0.2
    report = format_report(result)
    assert "differs" in report and "topology matches: no" in report


def test_graph_topology_counts():
    # a square loop with a tail, plus an isolated node, a repeated edge and a self-loop
    edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [3, 4], [1, 0], [2, 2]])
    assert graph_topology(6, edges) == {"components": 2, "cycles": 1, "junctions": 1, "ends": 1, "nodes": 6, "edges": 5}


def test_readers_round_trip(tmp_path):
    nodes = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [2, 0, 0]])
    edges = np.array([[0, 1], [1, 2], [1, 3]])
    (tmp_path / "s.json").write_text(json.dumps({"nodes": nodes.tolist(), "edges": edges.tolist(), "extra": 1}))
    ply = ["ply", "format ascii 1.0", "element vertex 4", "property float x", "property float y", "property float z",
           "element edge 3", "property int vertex1", "property int vertex2", "end_header"]
    ply += [" ".join(map(str, p)) for p in nodes] + [" ".join(map(str, e)) for e in edges]
    (tmp_path / "s.ply").write_text("\n".join(ply) + "\n")
    (tmp_path / "s.skeleton").write_text("10 0 0 0 -1\n11 1 0 0 10\n12 1 1 0 11\n13 2 0 0 11\n")
    (tmp_path / "s.tgf").write_text("1 0 0 0\n2 1 0 0 9 9\n3 1 1 0\n4 2 0 0\n#\n1 2\n2 3 1 0\n2 4\n#\n")
    for suffix in ("json", "ply", "skeleton", "tgf"):
        graph = load_graph(tmp_path / f"s.{suffix}")
        np.testing.assert_allclose(graph.nodes, nodes)
        assert sorted(map(tuple, graph.edges.tolist())) == [(0, 1), (1, 2), (1, 3)], suffix


def test_reference_rigs(reference_dir):
    expected = {  # nodes, edges, junctions, ends; all trees
        "cloudcontr_test_animation.skeleton": (18, 17, 2, 5),
        "libigl_hand.tgf": (21, 20, 1, 6),
        "libigl_elephant.tgf": (25, 24, 2, 5),
    }
    for name, (n_nodes, n_edges, junctions, ends) in expected.items():
        graph = load_graph(reference_dir / name)
        topology = graph_topology(len(graph.nodes), graph.edges)
        assert (topology["nodes"], topology["edges"], topology["junctions"], topology["ends"]) == \
            (n_nodes, n_edges, junctions, ends), name
        assert topology["components"] == 1 and topology["cycles"] == 0
    hand = load_graph(reference_dir / "libigl_hand.tgf")  # extra columns after x y z are ignored
    np.testing.assert_allclose(hand.nodes[0], [0.11429762, -0.76590296, -0.11140733])
    rig = load_graph(reference_dir / "cloudcontr_test_animation.skeleton")
    assert evaluate(rig, rig)["hausdorff"] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("filename, text, words", [
    ("a.json", "{not json", "not valid JSON"),
    ("a.json", '{"nodes": [[0, 0, 0]]}', "'nodes' and 'edges'"),
    ("a.json", '{"nodes": [[0, 0, 0], [1, 0, 0]], "edges": [[0, 2]]}', "refers to node 2"),
    ("a.json", '{"nodes": [[0, 0], [1, 0]], "edges": []}', "[x, y, z]"),
    ("a.json", '{"nodes": [[0, 0, 0], [1, 0, 0]], "edges": [[0, 0.5]]}', "integers"),
    ("a.skeleton", "0 0 0 0 -1\n1 1 0 0\n", "line 2"),
    ("a.skeleton", "0 0 0 0 -1\n1 1 0 0 7\n", "parent 7"),
    ("a.tgf", "1 0 0 0\n2 1 0 0\n", "'#'"),
    ("a.tgf", "1 0 0 0\n2 1 0 0\n#\n1 3\n#\n", "line 4"),
    ("a.tgf", "1 0 0\n#\n", "line 1"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "mesh"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\nzz\n", "a.ply"),
    ("a.obj", "v 0 0 0\n", "unknown graph format"),
])
def test_bad_files_give_one_line_errors(tmp_path, filename, text, words):
    path = tmp_path / filename
    path.write_text(text)
    with pytest.raises(SkelError) as error:
        load_graph(path)
    assert words in str(error.value) and "\n" not in str(error.value)


def test_missing_file_and_flat_truth(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        load_graph(tmp_path / "absent.json")
    point = make_graph([[1.0, 2, 3]], [], "point")
    with pytest.raises(InputError, match="no extent"):
        evaluate(point, point)


def test_cli_evaluate(tmp_path, capsys):
    from skelcore.cli import main

    truth = truth_of("torus")
    (tmp_path / "truth.json").write_text(json.dumps({"nodes": truth.nodes.tolist(), "edges": truth.edges.tolist()}))
    (tmp_path / "skeleton.json").write_text(json.dumps({"nodes": (truth.nodes + [0, 0, 0.1]).tolist(),
                                                        "edges": truth.edges.tolist(), "radius": 0.05}))
    assert main(["evaluate", str(tmp_path / "skeleton.json"), str(tmp_path / "truth.json"), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["hausdorff"] == pytest.approx(0.1 / result["diagonal"])
    assert result["topology"]["matches"]
    assert main(["evaluate", str(tmp_path / "skeleton.json"), str(tmp_path / "truth.json")]) == 0
    assert "topology matches: yes" in capsys.readouterr().out
    assert main(["evaluate", str(tmp_path / "skeleton.json"), str(tmp_path / "absent.tgf")]) != 0
    error = capsys.readouterr().err
    assert "absent.tgf: file not found" in error and error.count("\n") == 1
