"""The paper's stability metrics: known answers, the peak rule, boundedness, verdicts."""
import json

import numpy as np
import pytest

from skelcore.errors import InputError, ParameterError
from skelcore.histogram_stats import distribution_stats, significant_peaks
from skelcore.metrics import D_THETA_RANGE, IterationMetrics, MetricsReference
from skelcore.normals import orient_outward, pca_features, _eigenvalues, _eigenvector
from skelcore.verdict import StabilityThresholds, run_verdict


def torus(n=1500, big=1.0, small=0.3, seed=0):
    """Points on a torus around the z axis (area-uniform), with their outward normals."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0, 2 * np.pi, 4 * n)
    phi = rng.uniform(0, 2 * np.pi, 4 * n)
    keep = rng.uniform(0, big + small, 4 * n) < big + small * np.cos(phi)
    theta, phi = theta[keep][:n], phi[keep][:n]
    normals = np.column_stack([np.cos(phi) * np.cos(theta), np.cos(phi) * np.sin(theta), np.sin(phi)])
    core = np.column_stack([big * np.cos(theta), big * np.sin(theta), np.zeros(n)])
    return core + small * normals, normals, core


def capsule(n=1500, length=2.0, radius=0.3, seed=0):
    """Points on a closed capsule along z: a tube with two hemispherical caps."""
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(n, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    tube_share = length / (length + 2 * radius)
    on_tube = rng.uniform(size=n) < tube_share
    directions[on_tube, 2] = 0
    directions[on_tube] /= np.linalg.norm(directions[on_tube], axis=1, keepdims=True)
    z = np.where(on_tube, rng.uniform(-length / 2, length / 2, n), np.sign(directions[:, 2]) * length / 2)
    return directions * radius + np.column_stack([np.zeros(n), np.zeros(n), z])


def flat_patch(side=30):
    u, v = np.meshgrid(np.linspace(-1, 1, side), np.linspace(-1, 1, side))
    return np.column_stack([u.ravel(), v.ravel(), np.zeros(side * side)])


def rotation_x(degrees):
    a = np.radians(degrees)
    return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


def test_unchanged_cloud_has_zero_measures():
    points = capsule()
    reference = MetricsReference.from_points(points)
    result = reference.evaluate(points, np.arange(len(points)))
    assert np.all(result.d_theta == 0)
    assert np.all(result.delta_kappa == 0)
    assert result.d_theta_stats["mean"] == 0 and result.d_theta_stats["peaks"]["count"] == 1
    assert result.boundedness["inside_share"] == 1.0


def test_rotated_flat_patch_gives_angle_over_pi():
    patch = flat_patch()
    reference = MetricsReference.from_points(patch, convention="tracked")
    turned = reference.evaluate(patch @ rotation_x(30).T)
    np.testing.assert_allclose(turned.d_theta, 30 / 180, atol=1e-9)
    np.testing.assert_allclose(turned.delta_kappa, 0, atol=1e-12)


def test_normals_are_tracked_across_iterations():
    # Five turns of 30 degrees: each step takes the smaller angle, the total is 150 degrees.
    patch = flat_patch()
    reference = MetricsReference.from_points(patch, convention="tracked")
    previous = None
    for step in range(1, 6):
        previous = reference.evaluate(patch @ rotation_x(30 * step).T, previous=previous)
    np.testing.assert_allclose(previous.d_theta, 150 / 180, atol=1e-9)
    # Without the history the same cloud is one turn of 150 degrees, i.e. 30 degrees the short way.
    np.testing.assert_allclose(reference.evaluate(patch @ rotation_x(150).T).d_theta, 30 / 180, atol=1e-9)


def test_outward_convention_centres_on_the_anchor_and_points_away_from_the_centroid():
    points, normals, _ = torus()
    estimated, _, _ = pca_features(points, 30, anchored=True)
    reference = MetricsReference.from_points(points, convention="outward")
    # Away from the centroid: on the torus's inner side that is against the surface normal.
    radial = points - points.mean(axis=0)
    assert np.all(np.einsum("ij,ij->i", reference.normals, radial) >= 0)
    assert np.mean(np.abs(np.einsum("ij,ij->i", estimated, normals)) > 0.95) > 0.95
    # The anchored covariance differs from the mean-centred one at a curved surface's points.
    _, kappa_mean, _ = pca_features(points, 30)
    _, kappa_anchor, _ = pca_features(points, 30, anchored=True)
    assert np.mean(kappa_anchor) != pytest.approx(np.mean(kappa_mean))
    with pytest.raises(ParameterError, match="convention"):
        MetricsReference.from_points(points, convention="sideways")


def test_curve_share_is_the_stop_rules_measure_at_the_inputs_scale():
    from skelcore.curveness import curve_share
    from skelcore.skeleton import SkeletonParams

    points, _, core = torus(1500)
    reference = MetricsReference.from_points(points)
    surface = reference.evaluate(points, iteration=0)
    shrunk = reference.evaluate(core + 0.02 * (points - core), previous=surface)
    # One definition: skelcore.curveness at the skeleton's radius, a fraction of the INPUT's diagonal.
    diagonal = float(np.linalg.norm(np.ptp(points, axis=0)))
    assert shrunk.curve["curve_share"] == curve_share(core + 0.02 * (points - core),
                                                      SkeletonParams.sample_radius * diagonal)
    assert surface.curve["curve_share"] < 0.2 < 0.9 < shrunk.curve["curve_share"]


def test_closed_form_eigen_matches_lapack():
    rng = np.random.default_rng(3)
    factors = rng.normal(size=(500, 3, 3))
    matrices = factors @ factors.transpose(0, 2, 1)
    matrices[:100] = np.einsum("ni,nj->nij", factors[:100, 0], factors[:100, 0])  # rank 1: line-like
    matrices[100:110] = np.eye(3)  # isotropic
    entries = [matrices[:, a, b] for a, b in [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]]
    smallest, largest, trace = _eigenvalues(*entries)
    expected = np.linalg.eigvalsh(matrices)
    scale = expected[:, -1]
    np.testing.assert_allclose(smallest / scale, expected[:, 0] / scale, atol=1e-7)
    np.testing.assert_allclose(largest / scale, expected[:, -1] / scale, atol=1e-7)
    np.testing.assert_allclose(trace, expected.sum(axis=1))
    vectors = _eigenvector(*entries, smallest)
    residual = np.einsum("nij,nj->ni", matrices, vectors) - smallest[:, None] * vectors
    assert np.abs(np.linalg.norm(vectors, axis=1) - 1).max() < 1e-12
    assert (np.linalg.norm(residual, axis=1) / scale).max() < 1e-6


def test_curvature_of_plane_and_blob():
    _, kappa, _ = pca_features(flat_patch(), 30)
    np.testing.assert_allclose(kappa, 0, atol=1e-12)
    blob = np.random.default_rng(0).normal(size=(3000, 3))
    _, kappa, _ = pca_features(blob, 30)
    assert 0.15 < np.median(kappa) <= 1 / 3  # isotropic neighbourhoods approach 1/3 (eq. 7)


def test_peak_rule_counts_separated_peaks():
    n = 1000  # 2% of the points: 20
    two = np.array([0, 10, 60, 120, 60, 10, 0, 0, 10, 60, 120, 60, 10, 0])
    assert len(significant_peaks(two, n)) == 2
    shallow = np.array([0, 10, 60, 120, 110, 120, 60, 10, 0])  # dip of 10 < 20
    assert len(significant_peaks(shallow, n)) == 1
    deep = np.array([0, 10, 60, 120, 95, 120, 60, 10, 0])  # dip of 25 >= 20
    assert len(significant_peaks(deep, n)) == 2
    assert significant_peaks(np.array([500, 20, 0, 0]), n).tolist() == [0]  # a peak at the edge counts


def test_distribution_statistics():
    from skelcore.verdict import StabilityThresholds

    def distribution_stats_as_run(values, value_range):  # the metrics' histogram and the verdict's peak rule
        return distribution_stats(values, value_range, bins=50, peak_drop=StabilityThresholds().peak_drop)

    rng = np.random.default_rng(1)
    normal = distribution_stats_as_run(rng.normal(0.5, 0.1, 20000), D_THETA_RANGE)
    assert normal["peaks"]["count"] == 1
    assert abs(normal["skewness"]) < 0.1 and abs(normal["kurtosis"]) < 0.2
    assert normal["symmetry"] > 0.95 and abs(normal["unimodality"] - 2 / 3) < 0.03
    assert abs(normal["mean"] - 0.5) < 0.01 and abs(normal["std"] - 0.1) < 0.01
    two = distribution_stats_as_run(np.concatenate([rng.normal(0.2, 0.03, 5000), rng.normal(0.8, 0.03, 5000)]),
                                    D_THETA_RANGE)
    assert two["peaks"]["count"] == 2 and two["unimodality"] < 0.2
    skewed = distribution_stats_as_run(rng.exponential(0.1, 20000), D_THETA_RANGE)
    assert skewed["skewness"] > 1.5 and skewed["symmetry"] < 0.7
    nan = distribution_stats_as_run(np.array([np.nan, 0.5, 0.5, 0.5]), D_THETA_RANGE)
    assert nan["n"] == 3 and nan["n_undefined"] == 1 and nan["skewness"] is None and nan["symmetry"] == 1.0
    json.dumps(nan)


def test_torus_normals_are_oriented_outward():
    points, normals, _ = torus()
    estimated, _, idx = pca_features(points, 30)
    oriented = orient_outward(points, estimated, idx)
    assert np.mean(np.einsum("ij,ij->i", oriented, normals) > 0) > 0.99


def test_normals_are_turned_outward_whatever_the_farthest_point_says():
    """A pencil's farthest point is its tip, where a PCA normal points anywhere across the axis: a sign taken
    there turned every normal inward on 3 of these 12 samples."""
    import trimesh

    body = trimesh.creation.cylinder(radius=0.3, height=4.0, sections=48)
    tip = trimesh.creation.cone(radius=0.3, height=1.5, sections=48)
    tip.apply_translation([0.0, 0.0, 2.0])
    pencil = trimesh.boolean.union([body, tip], engine="manifold")
    for seed in range(12):
        points, faces = trimesh.sample.sample_surface_even(pencil, 5000, seed=seed)
        estimated, _, idx = pca_features(np.asarray(points), 10)
        oriented = orient_outward(np.asarray(points), estimated, idx)
        assert np.mean(np.einsum("ij,ij->i", oriented, pencil.face_normals[faces]) > 0) > 0.99, seed


def test_an_open_tube_among_closed_parts_holds_its_axis():
    """A torso cut off at both ends, among six closed balls (limbs): the outside's votes outnumber the inside's,
    which leaks out through the ends (a quarter of the votes of their joint region), and it is still inside."""
    rng = np.random.default_rng(0)
    angle, height = rng.random(6000) * 2 * np.pi, rng.uniform(-2.0, 2.0, 6000)
    parts = [np.c_[0.5 * np.cos(angle), 0.5 * np.sin(angle), height]]
    for k in range(6):
        ball = rng.normal(size=(1500, 3))
        parts.append(0.3 * ball / np.linalg.norm(ball, axis=1, keepdims=True)
                     + [1.5 * np.cos(k), 1.5 * np.sin(k), -1.5 + 0.6 * k])
    reference = MetricsReference.from_points(np.concatenate(parts))
    axis = np.c_[np.zeros(50), np.zeros(50), np.linspace(-1.5, 1.5, 50)]
    assert reference.inside.contains(axis).all()
    assert not reference.inside.contains(parts[0] * [5.0, 5.0, 1.0]).any()


def test_a_split_region_is_judged_by_its_cells_centres_only_where_points_fall():
    """An open sheet (a bent leaf) splits the outside's votes, so its cells are judged one by one: by their centres,
    as when every cell was judged at once, but only those a query reaches, and each once."""
    from skelcore.inside import SPLIT, InsideTest

    rng = np.random.default_rng(0)
    u, v = rng.uniform(-1, 1, (2, 6000))
    leaf = np.c_[u, v, 0.4 * u**2]
    test = InsideTest.of_cloud(leaf, 0.01, 0.005)
    split = np.argwhere(test.cells == SPLIT)
    assert len(split) > 1000
    cell = split[rng.choice(len(split), 300, replace=False)]
    queries = test.origin + (cell + rng.uniform(0.05, 0.95, cell.shape)) * test.size  # anywhere in those cells
    centres = test.origin + (cell + 0.5) * test.size
    assert np.array_equal(test.contains(queries), test.side_of(centres) <= 0)
    assert (test.cells == SPLIT).sum() == len(split) - 300  # judged once, remembered
    assert np.array_equal(test.contains(queries), test.side_of(centres) <= 0)


def test_another_band_reuses_the_grid_as_it_was_made(monkeypatch):
    """A band that does not size the cells keeps the grid: the cells queries have resolved since are undecided
    again, so the test answers as one made afresh, and the first keeps what it resolved. A band wider than the
    cells makes a new grid."""
    from skelcore.inside import SPLIT, InsideTest

    rng = np.random.default_rng(0)
    u, v = rng.uniform(-1, 1, (2, 6000))
    test = InsideTest.of_cloud(np.c_[u, v, 0.4 * u**2], 0.01, 0.005)  # an open sheet: many split cells
    made = lambda band: InsideTest.from_samples(test.samples, test.normals, band, test.tree, test.spacing)
    fresh, wide = made(0.02), made(3 * test.size)
    split = np.argwhere(test.cells == SPLIT)
    test.contains(test.origin + (split[:300] + 0.5) * test.size)
    with monkeypatch.context() as patched:
        patched.setattr(InsideTest, "from_samples", None)  # no grid made again
        again = test.with_band(0.02)
    assert again.band == 0.02 and again.size == fresh.size == test.size
    np.testing.assert_array_equal(again.cells, fresh.cells)
    np.testing.assert_array_equal(again.undecided, fresh.undecided)
    assert (test.cells == SPLIT).sum() == len(split) - 300
    queries = test.origin + rng.uniform(0, 1, (2000, 3)) * np.array(test.cells.shape) * test.size
    np.testing.assert_array_equal(again.contains(queries), fresh.contains(queries))
    widened = test.with_band(3 * test.size)
    assert widened.size == wide.size == 3 * test.size
    np.testing.assert_array_equal(widened.cells, wide.cells)


@pytest.mark.parametrize("apart", [30.0, 100.0])
def test_two_tori_far_apart_are_each_turned_outward(apart):
    """Each part's normals are turned outward by the sign of sum n.(p - c), which carries c times the sum of its
    normals; with c the centroid of two tori thirty sizes apart that term outweighed each thin torus's volume,
    both were turned inward, their axes judged outside and every run on them "unstable". c is now each far
    piece's own centroid (skelcore.normalise.pieces_apart)."""
    first, normals, core = torus(3000, small=0.2)
    second, _, _ = torus(3000, small=0.2, seed=1)
    offset = np.array([apart * 2.4, 0.0, 0.0])
    points = np.vstack([first, second + offset])
    reference = MetricsReference.from_points(points)
    assert reference.inside.contains(np.vstack([core, core + offset])).all()
    assert not reference.inside.contains(np.array([[0.0, 0.0, 0.0], offset])).any()  # the holes
    outward = reference.inside.normals[:len(first)]
    assert (np.einsum("ij,ij->i", outward, normals) > 0).mean() > 0.95


def test_cloud_contracted_onto_its_core_is_bounded():
    points, normals, core = torus()
    reference = MetricsReference.from_points(points)
    onto_core = reference.evaluate(core)
    assert onto_core.boundedness["inside_share"] == 1.0
    assert onto_core.boundedness["spread_ratio"] < 1
    # The hole is outside the shape, and so is a cloud blown up beyond it.
    hole = reference.evaluate(0.05 * points)
    assert hole.boundedness["inside_share"] == 0.0 and hole.verdict["label"] == "unstable"
    grown = reference.evaluate(points + 0.2 * normals)
    assert grown.boundedness["inside_share"] == 0.0 and not grown.boundedness["shrinking"]


def test_mesh_reference_is_bounded_by_its_surface():
    import trimesh

    mesh = trimesh.creation.capsule(height=2.0, radius=0.3, count=[24, 24])
    vertices = np.asarray(mesh.vertices)
    reference = MetricsReference.from_points(vertices, faces=np.asarray(mesh.faces)[:, ::-1])  # inverted winding
    axis = vertices * [0.0, 0.0, 1.0] * 0.9
    assert reference.evaluate(axis).boundedness["inside_share"] == 1.0
    assert reference.evaluate(vertices * 3.0).boundedness["inside_share"] == 0.0


def _disagreements(faces):
    """Pairs of faces sharing an edge that run along it in the same direction (inconsistent winding)."""
    edges = np.stack([faces, np.roll(faces, -1, axis=1)], axis=-1).reshape(-1, 2)
    seen, count = {}, 0
    for u, v in edges.tolist():
        count += seen.get((u, v), 0)
        seen[(u, v)] = seen.get((u, v), 0) + 1
    return count


def test_scrambled_winding_is_repaired_as_trimesh_repairs_it_and_a_moebius_band_disagrees_once():
    """A third of the faces of a capsule and of two separate bodies flipped: the winding comes out consistent and,
    once each body is turned outward, face for face as trimesh.repair.fix_normals leaves it. A Moebius band has
    no consistent winding: one pair of faces is left disagreeing, the least there can be."""
    import trimesh

    from skelcore.inside import _turn_bodies_outward, _wind_consistently

    rng = np.random.default_rng(0)
    for solid in (trimesh.creation.capsule(count=[24, 24]),
                  trimesh.util.concatenate([trimesh.creation.box(), trimesh.creation.icosphere().apply_translation([3, 0, 0])])):
        faces = solid.faces.copy()
        flipped = rng.random(len(faces)) < 0.3
        faces[flipped] = faces[flipped][:, ::-1]
        ours, theirs = (trimesh.Trimesh(solid.vertices, faces, process=False) for _ in range(2))
        _wind_consistently(ours)
        assert _disagreements(ours.faces) == 0
        _turn_bodies_outward(ours)
        trimesh.repair.fix_normals(theirs)
        _turn_bodies_outward(theirs)
        assert np.array_equal(ours.faces, theirs.faces)
    angle = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    vertices = np.array([[(1 + w * np.cos(t / 2)) * np.cos(t), (1 + w * np.cos(t / 2)) * np.sin(t), w * np.sin(t / 2)]
                         for t in angle for w in (-0.2, 0.2)])
    faces = []
    for i in range(40):
        p, q = (2 * i, 2 * i + 1), ((2 * i + 2, 2 * i + 3) if i < 39 else (1, 0))  # the half twist closes the band
        faces += [[p[0], q[0], p[1]], [p[1], q[0], q[1]]]
    band = trimesh.Trimesh(vertices, np.array(faces), process=False)
    _wind_consistently(band)
    assert _disagreements(band.faces) == 1


def test_an_open_mesh_wound_inward_is_bounded_by_its_surface():
    """trimesh settles the winding's direction only on a watertight mesh: a capsule with one cap cut off and its
    faces wound inward is turned outward by its flux."""
    import trimesh

    mesh = trimesh.creation.capsule(height=2.0, radius=0.3, count=[24, 24])
    vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    kept = faces[vertices[faces].mean(axis=1)[:, 2] > -1.05]  # the bottom cap's tip is gone: a hole
    reference = MetricsReference.from_points(vertices, faces=kept[:, ::-1])
    axis = np.c_[np.zeros(40), np.zeros(40), np.linspace(-0.8, 1.2, 40)]
    assert reference.inside.contains(axis).all()
    assert reference.inside.contains(vertices * [3.0, 3.0, 1.0]).mean() < 0.2


def test_point_ids_compare_with_the_same_input_points():
    points = capsule()
    reference = MetricsReference.from_points(points)
    ids = np.arange(0, len(points), 2)
    shifted = points[ids] + [0.0, 0.0, 0.01]  # translation: same normals and curvature at those ids
    result = reference.evaluate(shifted, ids)
    assert result.point_ids.tolist() == ids.tolist() and len(result.d_theta) == len(ids)
    assert np.nanmean(result.d_theta) < 0.05  # only the halved sampling changes the neighbourhoods
    with pytest.raises(InputError, match="point_ids"):
        reference.evaluate(shifted, np.zeros(len(ids), int))
    with pytest.raises(InputError, match="point_ids"):
        reference.evaluate(shifted, ids + len(points))
    with pytest.raises(InputError, match="not finite"):
        reference.evaluate(np.full((10, 3), np.nan), np.arange(10))
    with pytest.raises(ParameterError, match="k="):
        MetricsReference.from_points(points, k=2)
    with pytest.raises(InputError, match="faces"):
        MetricsReference.from_points(points, faces=np.array([[0, 1, len(points)]]))


def test_shrinking_compares_the_same_points_when_points_merge_away():
    """X_{k+1} <= X_k compares one cloud: when the points near the centre merge away (GLSkeleton), the spread
    of the ones left is larger than that of all the earlier points, yet none of them moved."""
    points = capsule()
    reference = MetricsReference.from_points(points)
    first = reference.evaluate(points, np.arange(len(points)), iteration=1)
    far = np.linalg.norm(points - points.mean(axis=0), axis=1)
    kept = np.flatnonzero(far > np.median(far))
    second = reference.evaluate(points[kept], kept, previous=first, iteration=2)
    assert second.spread > 1.05 * first.spread
    assert second.boundedness["growth"] == pytest.approx(0.0) and second.boundedness["shrinking"]


def test_large_clouds_are_judged_on_a_fixed_sample():
    points = capsule(800)
    reference = MetricsReference.from_points(points, max_points=200)
    result = reference.evaluate(points)
    assert result.d_theta_stats["n"] == 200 and len(result.rows) == 200
    values = result.per_point("d_theta")
    assert values.shape == (800,) and np.isnan(values).sum() == 600
    assert np.all(values[result.rows] == 0)


def _thin_ring(n: int, seed: int = 0) -> np.ndarray:
    """A contracted torus: a unit circle under a Gaussian cross-section of 0.02."""
    rng = np.random.default_rng(seed)
    angle = rng.uniform(0, 2 * np.pi, n)
    return np.c_[np.cos(angle), np.sin(angle), np.zeros(n)] + rng.normal(0, 0.02, (n, 3))


def test_a_cloud_is_measured_at_the_same_scale_at_any_density():
    """The curvature of the same thin ring read on 4,000 and on 40,000 points, judged on 2,000 of them: the
    neighbourhoods come from the sample, so both see the ring as a curve alike; from the whole cloud, 30
    neighbours of the dense one would lie within a sliver of its cross-section, more blob (kappa 1/3) than curve."""
    kappa = []
    for n in (4_000, 40_000):
        reference = MetricsReference.from_points(_thin_ring(n), max_points=2_000)
        kappa.append(float(np.nanmean(reference.kappa[reference.evaluated])))
    assert abs(kappa[0] - kappa[1]) < 0.01, kappa
    _, whole, _ = pca_features(_thin_ring(40_000), 30)
    assert np.nanmean(whole) - kappa[1] > 0.05  # what the whole dense cloud's neighbourhoods would have read


def test_to_dict_is_json_and_run_verdict_reads_both_forms():
    points, _, core = torus(800)
    reference = MetricsReference.from_points(points)
    history = [reference.evaluate(points, iteration=0)]
    for share in (0.6, 0.3, 0.1):
        history.append(reference.evaluate(core + share * (points - core), previous=history[-1]))
    document = json.loads(json.dumps([{"iteration": m.iteration, **m.to_dict()} for m in history]))
    entry = document[1]
    assert set(entry) == {"iteration", "d_theta", "delta_kappa", "boundedness", "curve", "verdict"}
    assert document[0]["verdict"]["label"] is None and entry["verdict"]["iteration"] == 1
    assert {"histogram", "mean", "median", "std", "skewness", "kurtosis", "peaks", "symmetry",
            "unimodality"} <= set(entry["d_theta"])
    assert {"inside_share", "shrinking"} <= set(entry["boundedness"])
    assert entry["verdict"]["label"] in ("stable", "not yet converged", "unstable")
    from_objects, from_dicts = run_verdict(history), run_verdict(document)
    assert from_objects == from_dicts
    assert from_objects["convergence"]["iteration"] == [0, 1, 2, 3]
    assert isinstance(history[1], IterationMetrics) and history[1].boundedness["shrinking"]
    with pytest.raises(InputError, match="iterations"):
        run_verdict([{"d_theta": {}}])
    with pytest.raises(ParameterError, match="min_inside_share"):
        StabilityThresholds(min_inside_share=2.0).validated()


def test_default_and_bad_contractions_get_different_verdicts():
    from skelcore.contraction import run_contraction
    from skelcore.params import ContractionParams

    points, _, _ = torus(1200)
    reference = MetricsReference.from_points(points)

    def verdict(params):
        history = []
        for state in run_contraction(points, params):
            history.append(reference.evaluate(state.points, state.point_ids, previous=history[-1] if history else None,
                                              iteration=state.iteration))
        return run_verdict(history)

    good, bad = verdict(ContractionParams()), verdict(ContractionParams(wl0=1e4))
    assert bad["label"] == "unstable", bad
    assert good["label"] != bad["label"], good


def test_thin_parts_stay_inside_their_own_surface():
    """The animal's legs and tail are thinner than a 30-point neighbourhood: the inside test must still
    find every contracted point inside (its surface normals come from a small neighbourhood, and the
    orientation never crosses a thin part)."""
    from skelcore.contraction import run_contraction
    from skelcore.shapes import make_shape

    points = make_shape("animal", 3000, seed=0).points
    reference = MetricsReference.from_points(points)
    previous = None
    for state in run_contraction(points)[1:]:
        previous = reference.evaluate(state.points, state.point_ids, previous=previous, iteration=state.iteration)
        assert previous.boundedness["inside_share"] > 0.98


def test_inside_grid_operations_match_scipy_ndimage():
    """The inside test dilates and labels its voxel grid with numpy and csgraph (scipy.ndimage is slow to
    import): the same cells and the same region numbers as ndimage's binary_dilation and label."""
    from scipy import ndimage

    from skelcore.regions import dilated, label_regions

    rng = np.random.default_rng(0)
    for shape in [(1, 1, 1), (1, 5, 3), (5, 6, 7), (46, 27, 18)]:
        for density in (0.02, 0.1, 0.3, 0.6):
            occupied = rng.random(shape) < density
            shell = dilated(occupied)
            assert np.array_equal(shell, ndimage.binary_dilation(occupied, np.ones((3, 3, 3), bool)))
            for cells in (~shell, occupied):
                labels, count = label_regions(cells)
                expected, expected_count = ndimage.label(cells)
                assert count == expected_count and np.array_equal(labels, expected)


def test_reference_uses_a_given_tree_only_over_its_own_samples():
    """A run hands the metrics the tree of the skeleton's surface probe: the same reference as one built anew;
    a tree over other points is not used."""
    from scipy.spatial import cKDTree

    from skelcore.shapes import make_shape

    points = make_shape("torus", 2000, seed=0, noise=0.002).points
    alone = MetricsReference.from_points(points)
    for tree in (cKDTree(points), cKDTree(points[:-1]), cKDTree(points + 1e-9)):
        shared = MetricsReference.from_points(points, tree=tree)
        assert np.array_equal(shared.inside.cells, alone.inside.cells)
        assert np.array_equal(shared.inside.normals, alone.inside.normals)
        assert (shared.inside.tree is tree) == (tree.n == len(points) and np.array_equal(tree.data, points))


def test_a_run_does_not_load_scipy_ndimage(tmp_path):
    """scipy.ndimage costs 0.04-0.1 s to import: a whole run (metrics and the inside test included) does without."""
    import os
    import subprocess
    import sys

    from skelcore.export import write_points_ply
    from skelcore.shapes import make_shape

    cloud = tmp_path / "torus.ply"
    write_points_ply(cloud, make_shape("torus", 1500, seed=0, noise=0.002).points)
    script = ("import sys; from skelcore.pipeline import run_pipeline; "
              f"run_pipeline({str(cloud)!r}, {str(tmp_path / 'out')!r}); "
              "print('scipy.ndimage' in sys.modules)")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": root}, check=True)
    assert done.stdout.split()[-1] == "False"
    assert (tmp_path / "out" / "metrics.json").exists()
