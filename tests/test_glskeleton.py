"""GLSkeleton: contraction with in-loop point reduction (skelcore.glskeleton)."""
import json

import numpy as np
import pytest
from scipy.spatial import Delaunay

from skelcore.contraction import contract, run_contraction
from skelcore.errors import ParameterError
from skelcore.evaluate import evaluate, make_graph
from skelcore.glskeleton import greedy_matching
from skelcore.neighbours import delaunay_fans
from skelcore.params import ContractionParams
from skelcore.io import Cloud
from skelcore.pipeline import IterationMetricsCache, RunOptions, run_pipeline, skeleton_of_state
from skelcore.shapes import EXPECTED_TOPOLOGY, centreline, make_shape, write_shape
from skelcore.skeleton import SkeletonParams

TOPOLOGY = ("components", "cycles", "ends", "junctions")
GLSKELETON = ContractionParams(method="glskeleton")


@pytest.fixture(scope="module")
def runs():
    """Both methods on each shape, run once for the module."""
    cache = {}

    def get(name, method):
        if (name, method) not in cache:
            shape = make_shape(name, 3000, seed=0)
            cache[name, method] = shape, run_contraction(shape.points, ContractionParams(method=method))
        return cache[name, method]
    return get


def score(shape, state):
    """Skeleton of the state against the shape's centreline; distances as fractions of the CLOUD's diagonal.
    Collinear degree-2 nodes are dropped, as GLSkeleton's graph step does."""
    skeleton = skeleton_of_state(state, shape.points, SkeletonParams(drop_collinear=True))
    truth = make_graph(*centreline(shape.name)[:2], shape.name)
    result = evaluate(make_graph(skeleton.nodes_array(), skeleton.edges_array()), truth)
    to_cloud = result["diagonal"] / np.linalg.norm(np.ptp(shape.points, axis=0))
    return skeleton.topology(), result["skeleton_to_truth"]["mean"] * to_cloud


@pytest.mark.parametrize("name", ["torus", "y_branch", "capsule", "two_hole"])
def test_skeleton_as_good_as_lbc(runs, name):
    shape, states = runs(name, "glskeleton")
    lbc_shape, lbc_states = runs(name, "lbc")
    topology, distance = score(shape, states[-1])
    lbc_topology, lbc_distance = score(lbc_shape, lbc_states[-1])
    expected = {key: EXPECTED_TOPOLOGY[name][key] for key in TOPOLOGY}
    assert {key: topology[key] for key in TOPOLOGY} == expected
    assert {key: lbc_topology[key] for key in TOPOLOGY} == expected
    assert distance < 0.015
    assert distance < lbc_distance + 0.005


def test_point_count_falls_and_the_input_comes_first(runs):
    shape, states = runs("torus", "glskeleton")
    first = states[0]
    assert first.iteration == 0 and np.array_equal(first.points, shape.points)
    assert np.array_equal(first.point_ids, np.arange(3000)) and np.array_equal(first.owner, np.arange(3000))
    counts = [s.n_points for s in states]
    assert counts[1] < counts[0] and all(a >= b for a, b in zip(counts, counts[1:]))
    assert counts[-1] < 0.5 * counts[0]
    assert states[-1].termination == "covariance" and "score changed by" in states[-1].message
    assert all(s.termination is None for s in states[:-1])


@pytest.mark.parametrize("name", ["torus", "y_branch"])
def test_bookkeeping_is_consistent(runs, name):
    _, states = runs(name, "glskeleton")
    previous = None
    for state in states:
        m = state.n_points
        assert state.points.shape == (m, 3) and state.wh.shape == (m,) and state.rings.n_points == m
        assert state.owner.shape == (3000,) and state.owner.min() >= 0 and state.owner.max() < m
        assert np.all(np.diff(state.point_ids) > 0)  # ids of the present points, in input order
        assert np.array_equal(state.owner[state.point_ids], np.arange(m))  # a present point represents itself
        if previous is not None:
            assert set(state.point_ids) <= set(previous.point_ids)
            # every input point keeps following the point that absorbed its representative
            absorbed_into = previous.point_ids[previous.owner]
            assert np.isin(state.point_ids[state.owner], previous.point_ids).all()
            assert (state.point_ids[state.owner] == absorbed_into)[np.isin(absorbed_into, state.point_ids)].all()
        rings = state.rings
        counts = np.diff(rings.indptr)
        assert counts.min() >= 1 and rings.indices.min() >= 0 and rings.indices.max() < m
        assert not np.any(rings.indices == rings.centres())
        pairs = set(zip(rings.centres().tolist(), rings.indices.tolist()))
        assert len(pairs) == len(rings.indices)  # no repeated ring entry
        i, j, l = rings.triangles.T
        assert np.all((i != j) & (j != l) & (l != i))
        assert all((a, b) in pairs for a, b in zip(i.tolist(), j.tolist()))
        previous = state


def test_merged_fans_are_local_delaunay():
    rng = np.random.default_rng(1)
    rows, width = 200, 20
    planar = rng.normal(size=(rows, width, 2))
    planar[::2, :, 0] = np.abs(planar[::2, :, 0]) + 0.01  # even rows: the centre on the boundary (open fans)
    lengths = rng.integers(3, width + 1, rows)
    valid = np.arange(width) < lengths[:, None]
    ring_row, ring_slot, tri_row, tri_j, tri_l = delaunay_fans(planar, valid)
    for row in range(rows):
        simplices = Delaunay(np.concatenate([[[0.0, 0.0]], planar[row, :lengths[row]]])).simplices
        expected = {frozenset(t) for t in simplices[(simplices == 0).any(axis=1)]}
        mine = tri_row == row
        assert {frozenset((0, j + 1, l + 1)) for j, l in zip(tri_j[mine], tri_l[mine])} == expected
        assert set(ring_slot[ring_row == row] + 1) == set().union(*expected) - {0}


def test_greedy_matching_equals_the_sequential_rule():
    rng = np.random.default_rng(3)
    n = 400
    source = rng.permutation(n)[:300]
    target = (source + rng.integers(1, 6, len(source))) % n  # short chains, many conflicts
    priority = rng.permutation(len(source))
    taken = greedy_matching(source, target, priority, n)
    used, expected = set(), np.zeros(len(source), dtype=bool)
    for edge in np.argsort(priority):
        if source[edge] not in used and target[edge] not in used:
            used |= {source[edge], target[edge]}
            expected[edge] = True
    assert np.array_equal(taken, expected)


def test_termination_rules():
    points = make_shape("capsule", 1500, seed=0).points
    never = dict(method="glskeleton", gl_covariance=1e-12, termination=1e-12)
    states = run_contraction(points, ContractionParams(**never, max_iterations=2))
    assert states[-1].termination == "max_iterations" and states[-1].iteration == 2
    states = run_contraction(points, ContractionParams(method="glskeleton", gl_covariance=10.0, termination=1e-12))
    assert states[-1].termination == "covariance" and states[-1].iteration == 3  # tested from the third step
    states = run_contraction(points, ContractionParams(method="glskeleton", gl_covariance=1e-12, termination=0.5))
    assert states[-1].termination == "ring_ratio" and "shrank the rings" in states[-1].message


def test_retune_live_and_restart_fields():
    points = make_shape("capsule", 1500, seed=0).points
    steps = contract(points, GLSKELETON.replace(termination=1e-12, gl_covariance=1e-12))
    next(steps)
    one = next(steps)
    two = steps.send(GLSKELETON.replace(termination=1e-12, gl_covariance=1e-12, wl0=one.wl, sl=1.0, gl_merge=1.0))
    assert two.iteration == 2 and two.wl == pytest.approx(one.wl)
    assert "gl_merge=1.0" in two.message
    with pytest.raises(ParameterError):
        steps.send(ContractionParams(method="lbc"))


@pytest.mark.parametrize("change", [{"gl_merge": 0.0}, {"gl_covariance": float("nan")}, {"gl_merge": -1.0}])
def test_parameters_are_validated(change):
    with pytest.raises(ParameterError) as error:
        ContractionParams(method="glskeleton", **change).validated()
    assert next(iter(change)) in str(error.value)


def test_metrics_follow_the_surviving_points(runs):
    shape, states = runs("y_branch", "glskeleton")
    cache = IterationMetricsCache(Cloud(points=shape.points))
    measured = cache.all(states)
    assert [m.iteration for m in measured] == [s.iteration for s in states]
    assert all(np.array_equal(m.point_ids, s.point_ids) for m, s in zip(measured, states))


def test_pipeline_writes_results(tmp_path):
    pytest.importorskip("skelcore.export", reason="skelcore.export (the skeleton writers) is not there yet")
    paths = write_shape(make_shape("y_branch", 1500, seed=0), tmp_path)
    cloud = next(path for path in paths if path.suffix == ".ply")
    result = run_pipeline(cloud, tmp_path / "out", RunOptions(params=GLSKELETON))
    metrics = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert metrics["method"] == "glskeleton"
    counts = [entry["n_points"] for entry in metrics["iterations"]]
    assert counts[0] == 1500 and counts[-1] < counts[0]
    assert {key: result.skeleton.topology()[key] for key in TOPOLOGY} == \
        {key: EXPECTED_TOPOLOGY["y_branch"][key] for key in TOPOLOGY}
