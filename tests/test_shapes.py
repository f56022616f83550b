import json
from pathlib import Path

import numpy as np
import pytest

from skelcore import io, shapes
from skelcore.errors import ParameterError
from skelcore.evaluate import graph_topology, load_graph

ASSETS = Path(__file__).resolve().parents[1] / "assets"
ASSET_SHAPES = ("capsule", "torus", "y_branch", "animal", "two_hole")
CONSTANT_RADIUS = ("capsule", "torus", "helix", "y_branch", "two_hole")


def distance_to_polyline(points, nodes, edges):
    """Brute force: distance from each point to the nearest edge and the parameter along that edge."""
    a, b = nodes[edges[:, 0]], nodes[edges[:, 1]]
    t = np.clip(np.einsum("pec,ec->pe", points[:, None] - a, b - a) / ((b - a) ** 2).sum(1), 0, 1)
    d = np.linalg.norm(points[:, None] - (a + t[..., None] * (b - a)), axis=2)
    return d, t


@pytest.mark.parametrize("name", shapes.SHAPES)
def test_shape_is_reproducible_and_on_the_tube_surface(name):
    shape = shapes.make_shape(name, 600, seed=3)
    again = shapes.make_shape(name, 600, seed=3)
    assert shape.points.shape == (600, 3)
    np.testing.assert_array_equal(shape.points, again.points)
    assert not np.allclose(shapes.make_shape(name, 600, seed=4).points, shape.points)
    d, t = distance_to_polyline(shape.points, shape.nodes, shape.edges)
    if name in CONSTANT_RADIUS:  # caps and junctions included: the surface is where the distance is r
        np.testing.assert_allclose(d.min(axis=1), shape.radii[0], atol=1e-9)
    # swept balls with radius linear along each edge: on the surface, no other tube contains the point
    r = shape.radii[shape.edges[:, 0]] + t * (shape.radii[shape.edges[:, 1]] - shape.radii[shape.edges[:, 0]])
    np.testing.assert_allclose((d - r).min(axis=1), 0.0, atol=1e-9)


@pytest.mark.parametrize("name", shapes.SHAPES)
def test_ground_truth_topology(name):
    nodes, edges, radii = shapes.centreline(name)
    topology = graph_topology(len(nodes), edges)
    assert {key: topology[key] for key in shapes.EXPECTED_TOPOLOGY[name]} == shapes.EXPECTED_TOPOLOGY[name]
    assert len(radii) == len(nodes) and (radii > 0).all()


def test_expected_topology_of_loops_and_animal():
    assert shapes.EXPECTED_TOPOLOGY["torus"]["cycles"] == 1 and shapes.EXPECTED_TOPOLOGY["torus"]["ends"] == 0
    assert shapes.EXPECTED_TOPOLOGY["two_hole"]["cycles"] == 2 and shapes.EXPECTED_TOPOLOGY["two_hole"]["ends"] == 0
    assert shapes.EXPECTED_TOPOLOGY["animal"]["ends"] == 6
    nodes, edges, _ = shapes.centreline("animal")
    degree = np.bincount(edges.ravel())
    assert sorted(degree[degree >= 3]) == [4, 4]  # hip and shoulder
    nodes, edges, radii = shapes.centreline("thin_thick")
    assert radii.max() / radii.min() == pytest.approx(4.0)


def test_sampling_is_uniform_per_area():
    capsule = shapes.make_shape("capsule", 3000)
    cap_area, side_area = 4 * np.pi * 0.3**2, 2 * np.pi * 0.3 * 2.0
    assert (np.abs(capsule.points[:, 0]) > 1).mean() == pytest.approx(cap_area / (cap_area + side_area), abs=0.03)
    torus = shapes.make_shape("torus", 3000)
    inner = (np.hypot(torus.points[:, 0], torus.points[:, 1]) < 1).mean()
    assert inner == pytest.approx(0.5 - 0.3 / np.pi, abs=0.03)  # area element (R + r cos v)


def test_noise_and_nonuniform_sampling():
    clean = shapes.make_shape("torus", 1000, seed=1)
    noisy = shapes.make_shape("torus", 1000, seed=1, noise=0.005)
    np.testing.assert_array_equal(noisy.points, shapes.make_shape("torus", 1000, seed=1, noise=0.005).points)
    diagonal = np.linalg.norm(clean.points.max(0) - clean.points.min(0))
    offset = np.linalg.norm(noisy.points - clean.points, axis=1)
    assert offset.mean() == pytest.approx(0.005 * diagonal * np.sqrt(8 / np.pi), rel=0.1)  # chi, 3 dof
    sparse = shapes.make_shape("capsule", 2000, nonuniform=0.8).points[:, 0]
    assert (sparse < 0).sum() > 1.6 * (sparse > 0).sum()  # density 1 -> 0.2 along x: halves 0.8 vs 0.4


@pytest.mark.parametrize("kwargs, word", [
    ({"name": "cube"}, "unknown"), ({"n": 5}, "n=5"), ({"noise": -1.0}, "noise"), ({"nonuniform": 1.0}, "nonuniform"),
])
def test_bad_parameters(kwargs, word):
    arguments = {"name": "torus", **kwargs}
    with pytest.raises(ParameterError) as error:
        shapes.make_shape(arguments.pop("name"), **arguments)
    assert word in str(error.value) and "\n" not in str(error.value)


def test_write_shapes_round_trip(tmp_path):
    written = shapes.write_shapes(tmp_path / "out", ["y_branch"], 500, seed=2)
    assert [p.name for p in written] == ["y_branch.ply", "y_branch_centreline.json"]
    shape = shapes.make_shape("y_branch", 500, seed=2)
    np.testing.assert_allclose(io.load(written[0]).points, shape.points, atol=1e-6)
    truth = load_graph(written[1])
    np.testing.assert_allclose(truth.nodes, shape.nodes, atol=1e-9)
    np.testing.assert_array_equal(truth.edges, shape.edges)
    assert json.loads(written[1].read_text())["topology"] == shapes.EXPECTED_TOPOLOGY["y_branch"]


@pytest.mark.parametrize("name", ASSET_SHAPES)
def test_assets_match_the_generator(name):
    cloud = io.load(ASSETS / f"{name}.ply")
    assert 2000 <= len(cloud.points) <= 4000
    np.testing.assert_allclose(cloud.points, shapes.make_shape(name, len(cloud.points), seed=0).points, atol=1e-6)
    truth = json.loads((ASSETS / f"{name}_centreline.json").read_text())
    assert truth["topology"] == shapes.EXPECTED_TOPOLOGY[name]
    readme = (ASSETS / "README.md").read_text()
    assert f"`{name}.ply` + `{name}_centreline.json`" in readme


def test_cli_shapes(tmp_path, capsys):
    from skelcore.cli import main

    assert main(["shapes", "--out", str(tmp_path), "--names", "torus", "--n", "200", "--seed", "5"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["torus.ply", "torus_centreline.json"]
    np.testing.assert_allclose(io.load(tmp_path / "torus.ply").points, shapes.make_shape("torus", 200, seed=5).points,
                               atol=1e-6)
    capsys.readouterr()
    assert main(["shapes", "--out", str(tmp_path), "--names", "cube"]) != 0
    error = capsys.readouterr().err
    assert "unknown" in error and "capsule" in error and error.count("\n") == 1 and "Traceback" not in error
