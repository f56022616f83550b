"""One-ring edges across empty space (skelcore.ring_jumps): dropped where they join parts, kept on surfaces."""
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from skelcore.neighbours import knn, one_rings
from skelcore.ring_jumps import find_jumps, sampling_reach

SPACING = 0.01


def strand(start, direction, count, rng) -> np.ndarray:
    """A curve sampled one point wide: `count` points SPACING apart, jittered by a tenth of it."""
    steps = np.arange(count)[:, None] * SPACING * np.asarray(direction, dtype=float)
    return np.asarray(start, dtype=float) + steps + rng.normal(0.0, 0.1 * SPACING, (count, 3))


def pieces(triangles: np.ndarray, n: int) -> int:
    sides = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]]])
    graph = sp.coo_matrix((np.ones(len(sides)), (sides[:, 0], sides[:, 1])), shape=(n, n))
    return connected_components(graph, directed=False)[0]


def joins(rings, label: np.ndarray, a: int, b: int) -> int:
    """How many ring entries and triangle sides join a point labelled `a` to one labelled `b`."""
    i, j, l = rings.triangles.T
    pairs = [(rings.centres(), rings.indices), (i, j), (i, l), (j, l)]
    return int(sum(np.sum(((label[x] == a) & (label[y] == b)) | ((label[x] == b) & (label[y] == a))) for x, y in pairs))


def test_two_parallel_strands_are_not_joined():
    """Two twigs one point wide, 14 spacings apart, joined at one end: the 30 nearest neighbours reach 15
    spacings along a strand, and across to the other, so Cao's fans join the twigs all along; without the
    jumps no ring entry or triangle joins them, and the surface stays one piece through the joint."""
    rng = np.random.default_rng(0)
    points = np.vstack([strand([0, 0, 0], [1, 0, 0], 200, rng), strand([0, 14 * SPACING, 0], [1, 0, 0], 200, rng),
                        strand([-SPACING, SPACING, 0], [0, 1, 0], 13, rng)])
    label = np.repeat([0, 1, 2], [200, 200, 13])
    far = label.copy()
    far[(label < 2) & (points[:, 0] < 20 * SPACING)] = 2  # the twigs beyond the joint's reach
    assert joins(one_rings(points, 30), far, 0, 1) > 0  # the premise: the plain fans jump
    rings = one_rings(points, 30, drop_jumps=True)
    assert joins(rings, far, 0, 1) == 0
    assert pieces(rings.triangles, len(points)) == 1
    assert np.all(np.diff(rings.indptr) > 0)


def test_a_gap_that_is_the_only_link_stays():
    """A strand with a gap of 14 spacings: the edges over it are jumps by the middle test, but they are the
    only link between the two halves (a thinned strand, not two parts side by side), so the shortest stays."""
    rng = np.random.default_rng(1)
    points = np.vstack([strand([0, 0, 0], [1, 0, 0], 100, rng), strand([114 * SPACING, 0, 0], [1, 0, 0], 100, rng)])
    plain, rings = one_rings(points, 30), one_rings(points, 30, drop_jumps=True)
    halves = np.arange(len(points)) < 100
    assert joins(plain, halves.astype(int), 0, 1) > joins(rings, halves.astype(int), 0, 1) > 0
    assert pieces(rings.triangles, len(points)) == 1
    assert np.all(np.diff(rings.indptr) > 0)


def test_surfaces_keep_their_edges():
    """A uniformly random plate, clean and noisy, loses no edge. A thin wall (two faces four spacings apart)
    has chords through its inside whose middles are empty, but they run along their fans' normal (the
    projection laid the faces onto each other, and the contraction is meant to merge them): it loses no ring
    entry and almost no triangle."""
    rng = np.random.default_rng(2)
    plate = np.column_stack([rng.uniform(0, 1, (3000, 2)), np.zeros(3000)])
    noisy = plate + rng.normal(0.0, 0.005, plate.shape)
    for points in (plate, noisy):
        plain, kept = one_rings(points, 30), one_rings(points, 30, drop_jumps=True)
        assert np.array_equal(plain.indices, kept.indices) and np.array_equal(plain.triangles, kept.triangles)
    face = np.column_stack([rng.uniform(0, 1, (1500, 2)), np.zeros(1500)])
    wall = np.vstack([face, face + [0.0, 0.0, 4 * np.sqrt(1.0 / 1500)]]) + rng.normal(0.0, 1e-4, (3000, 3))
    plain, kept = one_rings(wall, 30), one_rings(wall, 30, drop_jumps=True)
    tree = cKDTree(wall)
    distances, indices = knn(wall, 30, tree)
    reach = sampling_reach(distances, indices)
    assert len(find_jumps(wall, plain.centres(), plain.indices, np.zeros((len(plain.indices), 3)), reach, tree)) > 0
    assert np.array_equal(plain.indices, kept.indices)
    assert len(kept.triangles) >= 0.999 * len(plain.triangles)


def test_the_rings_stay_consistent():
    """Dropping keeps every ring's fan order (a subsequence of Cao's fan), every triangle (i, j, l) with j and l
    in i's ring and every ring non-empty; a stray point alone in empty space keeps a link to the rest."""
    rng = np.random.default_rng(3)
    points = np.vstack([strand([0, 0, 0], [1, 0, 0], 150, rng), strand([0, 14 * SPACING, 0], [1, 0.1, 0], 150, rng),
                        strand([-SPACING, SPACING, 0], [0, 1, 0], 13, rng), [[0.7, 0.5, 0.0]]])
    plain, rings = one_rings(points, 30), one_rings(points, 30, drop_jumps=True)
    assert len(rings.indices) < len(plain.indices)
    for centre in range(len(points)):
        full = list(plain.indices[plain.indptr[centre]:plain.indptr[centre + 1]])
        kept = list(rings.indices[rings.indptr[centre]:rings.indptr[centre + 1]])
        positions = [full.index(neighbour) for neighbour in kept]
        assert positions == sorted(positions)
    ring_pairs = set(zip(rings.centres().tolist(), rings.indices.tolist()))
    i, j, l = rings.triangles.T
    assert all((a, b) in ring_pairs and (a, c) in ring_pairs for a, b, c in zip(i.tolist(), j.tolist(), l.tolist()))
    assert pieces(rings.triangles, len(points)) == 1
    assert np.all(np.diff(rings.indptr) > 0)


def test_the_tree_scan_has_no_false_loop(reference_dir):
    """cloudcontr's tree scan at 10k points: its twigs are one point wide, so Cao's rings join neighbouring
    branches and the skeleton closed 2 false loops with either method; without the jumps it has none."""
    from skelcore.quality_bench import run_case
    from skelcore.solids import reference_shape

    shape = reference_shape("tree", reference_dir)
    for method in ("lbc", "glskeleton"):
        outcome = run_case(shape.points, method, name="tree")
        assert "error" not in outcome, outcome.get("error")
        assert outcome["topology"]["cycles"] == 0 and outcome["topology"]["components"] == 1, (method, outcome)


def test_the_switch_reaches_the_run_from_the_command_line_and_the_api():
    """--no-drop-jumps (and drop_jumps=False in the API) gives cloudcontr's rings; the rings are fixed for a
    run, so the switch changes only on restart."""
    import pytest

    from skelcore import api
    from skelcore.cli import build_parser
    from skelcore.errors import ParameterError
    from skelcore.params import ContractionParams
    from skelcore.run_flags import contraction_params

    parse = build_parser().parse_args
    assert contraction_params(parse(["run", "in.ply", "--out", "o"])).drop_jumps is ContractionParams().drop_jumps
    assert contraction_params(parse(["run", "in.ply", "--out", "o", "--no-drop-jumps"])).drop_jumps is False
    rng = np.random.default_rng(4)
    points = np.vstack([strand([0, 0, 0], [1, 0, 0], 200, rng), strand([0, 14 * SPACING, 0], [1, 0, 0], 200, rng),
                        strand([-SPACING, SPACING, 0], [0, 1, 0], 13, rng)])
    states = {drop: next(api.contract(points, k=30, drop_jumps=drop)) for drop in (False, True)}
    assert len(states[True].rings.indices) < len(states[False].rings.indices)
    steps = api.contract(points)
    next(steps)
    with pytest.raises(ParameterError, match="restart"):
        steps.send(ContractionParams(drop_jumps=False))


def test_no_ring_is_emptied():
    """A point all of whose ring edges are jumps keeps its nearest ring neighbour (its ring size stays defined)."""
    from skelcore.ring_jumps import _without

    rng = np.random.default_rng(5)
    points = np.column_stack([rng.uniform(0, 1, (400, 2)), np.zeros(400)])
    rings = one_rings(points, 16)
    ring = rings.indices[rings.indptr[7]:rings.indptr[8]]
    jumps = np.sort(np.column_stack([np.full(len(ring), 7), ring]), axis=1)
    keep_entry, keep_triangle = _without(jumps, points, rings.centres(), rings.indices, rings.triangles)
    kept = rings.indices[rings.indptr[7]:rings.indptr[8]][keep_entry[rings.indptr[7]:rings.indptr[8]]]
    assert list(kept) == [ring[np.argmin(np.linalg.norm(points[ring] - points[7], axis=1))]]
    assert not np.any(keep_triangle & np.any(rings.triangles == 7, axis=1))
