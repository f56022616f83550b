"""Curve skeleton extraction (skelcore.skeleton) and the skeleton writers (skelcore.export)."""
import json

import networkx as nx
import numpy as np
import pytest
from scipy.spatial import cKDTree

from skelcore import skeleton as skeleton_module
from skelcore.errors import InputError, ParameterError, SkelError
from skelcore.evaluate import load_graph
from skelcore.export import (polylines, skeleton_document, write_points_ply, write_skeleton, write_skeleton_graphml,
                             write_skeleton_obj)
from skelcore.neighbours import one_rings
from skelcore.skeleton import SkeletonParams, ball_cover_sampling, extract_skeleton


def knn_edges(points, k=8):
    """Stand-in ring edges: the k nearest neighbours of each point on the ORIGINAL cloud."""
    idx = cKDTree(points).query(points, k + 1)[1][:, 1:]
    return np.unique(np.sort(np.column_stack([np.repeat(np.arange(len(points)), k), idx.ravel()]), axis=1), axis=0)


def torus(n=2000, major=1.0, minor=0.25, jitter=0.01, centre=(0.0, 0.0, 0.0), seed=0):
    """Original points on a torus surface; contracted points on its centre circle with a little jitter."""
    rng = np.random.default_rng(seed)
    u, v = rng.uniform(0, 2 * np.pi, (2, n))
    original = np.column_stack([(major + minor * np.cos(v)) * np.cos(u), (major + minor * np.cos(v)) * np.sin(u),
                                minor * np.sin(v)]) + centre
    contracted = np.column_stack([major * np.cos(u), major * np.sin(u), np.zeros(n)]) + centre
    return contracted + rng.normal(0, jitter, (n, 3)), original


def tubes(segments, n, radius=0.05, jitter=0.005, seed=0):
    """Tubes around segments in the xy plane: original points on the tube walls, contracted on the axes."""
    rng = np.random.default_rng(seed)
    segments = np.asarray(segments, dtype=float)
    lengths = np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1)
    which = rng.choice(len(segments), n, p=lengths / lengths.sum())
    a, b = segments[which, 0], segments[which, 1]
    axis_points = a + rng.uniform(0, 1, (n, 1)) * (b - a)
    side = np.cross((b - a) / lengths[which, None], [0.0, 0.0, 1.0])
    phi = rng.uniform(0, 2 * np.pi, (n, 1))
    original = axis_points + radius * (np.cos(phi) * side + np.sin(phi) * [0.0, 0.0, 1.0])
    return axis_points + rng.normal(0, jitter, (n, 3)), original


def y_shape(short_arm=1.0, n=2000):
    arm = np.array([np.sin(2 * np.pi / 3), np.cos(2 * np.pi / 3), 0.0])
    return tubes([[(0, 0, 0), (0, 1, 0)], [(0, 0, 0), arm], [(0, 0, 0), arm * [-short_arm, short_arm, 0]]], n,
                 radius=0.04)


def h_shape(bar=0.07):
    """Two long posts joined by a bar shorter than 2 sample radii: two junctions, close together."""
    return tubes([[(-bar / 2, -1, 0), (-bar / 2, 1, 0)], [(bar / 2, -1, 0), (bar / 2, 1, 0)],
                  [(-bar / 2, 0, 0), (bar / 2, 0, 0)]], 3000, radius=0.01, jitter=0.002)


def skeleton_of(contracted, original, **params):
    return extract_skeleton(contracted, original, knn_edges(original), SkeletonParams(**params))


def topology(skeleton):
    return skeleton.topology()


def check_correspondence(skeleton, n):
    corr = skeleton.correspondence
    m = skeleton.graph.number_of_nodes()
    assert corr.shape == (n,) and corr.min() >= 0 and corr.max() < m
    counts = [skeleton.graph.nodes[i]["point_count"] for i in range(m)]
    assert np.array_equal(np.bincount(corr, minlength=m), counts) and min(counts) >= 1


# --- topology ---

def test_torus_keeps_exactly_one_loop():
    contracted, original = torus()
    skeleton = skeleton_of(contracted, original)
    assert topology(skeleton) == {"components": 1, "cycles": 1, "junctions": 0, "ends": 0}
    assert skeleton.graph.number_of_nodes() > 20
    check_correspondence(skeleton, len(original))


def test_a_loop_of_four_nodes_on_a_thin_torus_survives():
    contracted, original = torus(minor=0.1)
    skeleton = skeleton_of(contracted, original, sample_radius=0.3)  # r ~ 0.9: about 4 samples round the circle
    assert skeleton.graph.number_of_nodes() <= 6
    assert topology(skeleton) == {"components": 1, "cycles": 1, "junctions": 0, "ends": 0}


def test_genus_two_gives_two_loops():
    left, left_original = torus(1500, centre=(-1.1, 0, 0), seed=1)
    right, right_original = torus(1500, centre=(1.1, 0, 0), seed=2)
    skeleton = skeleton_of(np.vstack([left, right]), np.vstack([left_original, right_original]))
    assert topology(skeleton)["cycles"] == 2 and topology(skeleton)["components"] == 1


def test_y_gives_one_junction_and_three_ends():
    contracted, original = y_shape()
    skeleton = skeleton_of(contracted, original)
    assert topology(skeleton) == {"components": 1, "cycles": 0, "junctions": 1, "ends": 3}
    check_correspondence(skeleton, len(original))


def test_a_sheet_gives_no_false_loops(monkeypatch):
    """A flat sheet that did not contract to a curve: its sample graph has faces of 4-5 nodes that the
    triangle step keeps; the cycle rule removes every one of them."""
    rng = np.random.default_rng(0)
    xy = rng.uniform([-1, -0.3], [1, 0.3], (3000, 2))
    contracted = np.column_stack([xy, rng.normal(0, 0.005, len(xy))])
    original = contracted * [1, 1, 0] + np.where(rng.random((len(xy), 1)) < 0.5, 0.1, -0.1) * [0, 0, 1]
    edges = knn_edges(original)
    skeleton = extract_skeleton(contracted, original, edges)
    assert topology(skeleton)["cycles"] == 0 and topology(skeleton)["components"] == 1
    monkeypatch.setattr(skeleton_module, "_encloses_hole", lambda *args: True)  # every cycle taken as a loop
    monkeypatch.setattr(skeleton_module, "_passage", lambda *args: 1.0)
    assert topology(extract_skeleton(contracted, original, edges))["cycles"] > 0


def test_a_hollow_ring_inside_the_shape_is_no_loop(monkeypatch):
    """A ball whose contraction stopped at a ring (a bulky part that did not contract to a curve): the ring
    encloses a hole in the contracted points, but no passage through the ball opens there."""
    rng = np.random.default_rng(0)
    original = rng.normal(size=(2000, 3))
    original /= np.linalg.norm(original, axis=1, keepdims=True)
    azimuth = np.arctan2(original[:, 1], original[:, 0])
    contracted = 0.5 * np.column_stack([np.cos(azimuth), np.sin(azimuth), 0 * azimuth]) + rng.normal(0, 0.01, (2000, 3))
    assert topology(skeleton_of(contracted, original))["cycles"] == 0
    monkeypatch.setattr(skeleton_module, "_passage", lambda *args: 1.0)  # as if the ball had a hole there
    assert topology(skeleton_of(contracted, original))["cycles"] == 1


def test_ball_cover_sampling_covers_and_maps_to_the_nearest_sample():
    points = np.random.default_rng(0).uniform(-1, 1, (2000, 3))
    samples, owner = ball_cover_sampling(points, 0.3)
    distance, nearest = cKDTree(points[samples]).query(points)
    assert distance.max() <= 0.3
    assert np.allclose(np.linalg.norm(points - points[samples][owner], axis=1), distance)
    assert cKDTree(points[samples]).query(points[samples], 2)[0][:, 1].min() > 0.3  # samples farther apart than r


def test_reference_simplejoint(reference_dir):
    """cloudcontr's MATLAB skeleton of its contracted simplejoint: same topology (after pruning its split tip),
    and Chamfer distance (mean of the two directed mean nearest-node distances) to its valid nodes within 2%
    of the diagonal."""
    data = np.load(reference_dir / "cloudcontr_simplejoint_v4770_matlab_result.npz")
    points, contracted = data["pts"], data["cpts"]
    reference = data["spls"][~np.isnan(data["spls"]).any(axis=1)]
    skeleton = extract_skeleton(contracted, points, one_rings(points, 30).edges())
    assert topology(skeleton) == {"components": 1, "cycles": 0, "junctions": 1, "ends": 3}
    nodes = skeleton.nodes_array()
    chamfer = (cKDTree(reference).query(nodes)[0].mean() + cKDTree(nodes).query(reference)[0].mean()) / 2
    assert chamfer <= 0.02 * np.linalg.norm(np.ptp(points, axis=0))
    check_correspondence(skeleton, len(points))


# --- refinements: each switch has its effect ---

def test_prune_spurs_removes_a_short_branch():
    contracted, original = y_shape(short_arm=0.08)  # an arm of ~2 sample radii
    assert topology(skeleton_of(contracted, original, prune_spurs=False))["junctions"] == 1
    pruned = skeleton_of(contracted, original)
    assert topology(pruned) == {"components": 1, "cycles": 0, "junctions": 0, "ends": 2}
    check_correspondence(pruned, len(original))


def test_merge_junctions_joins_two_close_junctions():
    contracted, original = h_shape()
    separate = skeleton_of(contracted, original, merge_junctions=False)
    assert topology(separate)["junctions"] == 2
    merged = skeleton_of(contracted, original)
    assert topology(merged) == {"components": 1, "cycles": 0, "junctions": 1, "ends": 4}
    assert max(d for _, d in merged.graph.degree()) == 4
    check_correspondence(merged, len(original))


def test_drop_collinear_leaves_a_straight_tube_as_one_edge_and_keeps_loops():
    contracted, original = tubes([[(0, 0, 0), (1, 0, 0)]], 1000, jitter=0.001)
    assert skeleton_of(contracted, original, recentre=False).graph.number_of_nodes() > 10
    straight = skeleton_of(contracted, original, recentre=False, drop_collinear=True)
    assert straight.graph.number_of_nodes() == 2 and straight.graph.number_of_edges() == 1
    check_correspondence(straight, len(original))
    contracted, original = torus()
    loop = skeleton_of(contracted, original, drop_collinear=True, collinear_angle=20.0)
    assert topology(loop)["cycles"] == 1
    assert loop.graph.number_of_nodes() < skeleton_of(contracted, original).graph.number_of_nodes()


def test_recentre_moves_nodes_onto_the_centroid_of_their_original_points():
    contracted, original = tubes([[(0, 0, 0), (1, 0, 0)]], 1000, radius=0.05, jitter=0.001)
    contracted = contracted + [0, 0.01, 0.03]  # a contraction that drifted off the axis
    drifted = skeleton_of(contracted, original, recentre=False)
    assert np.allclose(drifted.nodes_array()[:, 1:].mean(axis=0), [0.01, 0.03], atol=0.003)
    centred = skeleton_of(contracted, original)
    nodes, middle = centred.nodes_array(), centred.degrees() == 2
    assert np.abs(nodes[middle, 1:]).max() < 0.01  # back on the axis, across the curve only
    assert np.allclose(nodes[middle, 0], drifted.nodes_array()[middle, 0], atol=0.003)
    assert np.array_equal(nodes[~middle], drifted.nodes_array()[~middle])  # the ends stay


# --- errors ---

@pytest.mark.parametrize("params", [dict(sample_radius=0), dict(sample_radius=float("nan")), dict(sample_radius=2),
                                    dict(spur_length=-1), dict(junction_distance=0), dict(collinear_angle=180)])
def test_bad_parameters_raise_parameter_error(params):
    contracted, original = y_shape(n=200)
    with pytest.raises(ParameterError, match=next(iter(params))):
        skeleton_of(contracted, original, **params)


def test_bad_input_raises_input_error():
    contracted, original = y_shape(n=200)
    edges = knn_edges(original)
    for args in [(contracted[:, :2], original, edges), (contracted[:-1], original, edges),
                 (np.where(np.arange(200)[:, None] == 3, np.nan, contracted), original, edges),
                 (contracted, original, edges + 1000), (contracted, original, edges.astype(float)),
                 (np.zeros((0, 3)), np.zeros((0, 3)), edges)]:
        with pytest.raises(InputError) as error:
            extract_skeleton(*args)
        assert "\n" not in str(error.value)


def test_one_point_and_no_edges_give_one_node():
    skeleton = extract_skeleton(np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((0, 2), dtype=int))
    assert skeleton.graph.number_of_nodes() == 1 and skeleton.topology()["components"] == 1


# --- exports ---

def read_ascii_ply(path):
    lines = path.read_text().splitlines()
    end = lines.index("end_header")
    counts = {line.split()[1]: int(line.split()[2]) for line in lines[:end] if line.startswith("element")}
    body = lines[end + 1:]
    vertices = np.array([list(map(float, line.split())) for line in body[:counts["vertex"]]]).reshape(-1, 5)
    edges = np.array([list(map(int, line.split())) for line in body[counts["vertex"]:]]).reshape(-1, 2)
    assert len(edges) == counts["edge"]
    return vertices, edges


@pytest.fixture(scope="module")
def y_skeleton():
    contracted, original = y_shape(n=1000)
    return skeleton_of(contracted, original)


def test_json_and_ply_round_trip(y_skeleton, tmp_path):
    paths = write_skeleton(y_skeleton, tmp_path / "new" / "out")
    assert {p.name for p in paths.values()} == {"skeleton.json", "skeleton.ply"}
    document = json.loads(paths["json"].read_text())
    assert np.array_equal(document["nodes"], y_skeleton.nodes_array())
    assert np.array_equal(document["edges"], y_skeleton.edges_array())
    assert document["degree"] == y_skeleton.degrees().tolist()
    assert sum(document["point_count"]) == len(y_skeleton.correspondence)
    assert document["correspondence"] == y_skeleton.correspondence.tolist()
    assert document["topology"] == y_skeleton.topology()
    assert "correspondence" not in skeleton_document(y_skeleton, correspondence=False)
    vertices, edges = read_ascii_ply(paths["ply"])
    assert np.array_equal(vertices[:, :3], y_skeleton.nodes_array())
    assert np.array_equal(vertices[:, 3], y_skeleton.degrees())
    assert np.array_equal(edges, y_skeleton.edges_array())
    for path in paths.values():  # the evaluator reads what we write
        graph = load_graph(path)
        assert np.allclose(graph.nodes, y_skeleton.nodes_array())
        assert np.array_equal(graph.edges, y_skeleton.edges_array())


def test_obj_polylines_cover_every_edge_once(tmp_path):
    contracted, original = torus(800)
    loop = skeleton_of(contracted, original)
    for skeleton in (loop, skeleton_of(*y_shape(n=1000))):
        path = write_skeleton_obj(tmp_path / "skeleton.obj", skeleton)
        lines = path.read_text().splitlines()
        vertices = np.array([list(map(float, line.split()[1:])) for line in lines if line.startswith("v ")])
        assert np.array_equal(vertices, skeleton.nodes_array())
        chains = [list(map(int, line.split()[1:])) for line in lines if line.startswith("l ")]
        edges = sorted(tuple(sorted((a - 1, b - 1))) for chain in chains for a, b in zip(chain, chain[1:]))
        assert edges == [tuple(e) for e in skeleton.edges_array().tolist()]
    assert len(polylines(loop.graph)) == 1 and polylines(loop.graph)[0][0] == polylines(loop.graph)[0][-1]


def test_graphml_is_read_by_networkx(y_skeleton, tmp_path):
    graph = nx.read_graphml(write_skeleton_graphml(tmp_path / "skeleton.graphml", y_skeleton), node_type=int)
    assert graph.number_of_nodes() == y_skeleton.graph.number_of_nodes()
    assert sorted(tuple(sorted(e)) for e in graph.edges()) == [tuple(e) for e in y_skeleton.edges_array().tolist()]
    xyz = [[graph.nodes[i][c] for c in "xyz"] for i in range(graph.number_of_nodes())]
    assert np.allclose(xyz, y_skeleton.nodes_array())


@pytest.mark.parametrize("dtype, kind", [(np.float64, "double"), (np.float32, "float")])
def test_points_ply_is_binary_little_endian(tmp_path, dtype, kind):
    points = np.random.default_rng(0).normal(size=(50, 3))
    raw = write_points_ply(tmp_path / "contracted.ply", points, dtype=dtype).read_bytes()
    header, body = raw.split(b"end_header\n", 1)
    assert b"format binary_little_endian 1.0" in header and f"property {kind} x".encode() in header
    assert np.allclose(np.frombuffer(body, dtype=np.dtype(dtype).newbyteorder("<")).reshape(-1, 3), points, atol=1e-6)
    trimesh = pytest.importorskip("trimesh")
    assert np.allclose(trimesh.load(tmp_path / "contracted.ply").vertices, points, atol=1e-6)


def test_write_errors_are_one_line(y_skeleton, tmp_path):
    with pytest.raises(SkelError, match="cannot write"):
        write_skeleton_obj(tmp_path, y_skeleton)  # a folder, not a file
    with pytest.raises(InputError, match=r"\(n, 3\)"):
        write_points_ply(tmp_path / "p.ply", np.zeros((4, 2)))
    (tmp_path / "file").write_text("")
    with pytest.raises(SkelError, match="cannot create"):
        write_skeleton(y_skeleton, tmp_path / "file" / "out")


def test_whole_pipeline_on_the_cloudcontr_golden_case(reference_dir):
    """Our contraction AND skeleton on simplejoint_v4770.off (the reference's parameters) against MATLAB's
    skeleton: one junction, three ends, Chamfer distance to its valid nodes within 2% of the diagonal."""
    from skelcore.contraction import run_contraction
    from skelcore.io import load
    from skelcore.normalise import Normalisation
    from skelcore.params import ContractionParams
    from skelcore.pipeline import skeleton_of_state

    data = np.load(reference_dir / "cloudcontr_simplejoint_v4770_matlab_result.npz")
    cloud = load(reference_dir / "cloudcontr_simplejoint_v4770.off")
    final = run_contraction(cloud.points, ContractionParams(k=30, wl0=9.621282, wh0=1.0, sl=3.0, max_iterations=4))[-1]
    skeleton = skeleton_of_state(final, cloud.points, SkeletonParams())
    assert topology(skeleton) == {"components": 1, "cycles": 0, "junctions": 1, "ends": 3}
    nodes = Normalisation.fit(cloud.points).forward(skeleton.nodes_array())  # MATLAB's normalised frame
    reference = data["spls"][~np.isnan(data["spls"]).any(axis=1)]
    chamfer = (cKDTree(reference).query(nodes)[0].mean() + cKDTree(nodes).query(reference)[0].mean()) / 2
    diagonal = np.linalg.norm(np.ptp(data["pts"], axis=0))
    print(f"golden skeleton: Chamfer {chamfer / diagonal:.4%} of the diagonal, {len(nodes)} nodes vs {len(reference)}")
    assert chamfer <= 0.02 * diagonal
