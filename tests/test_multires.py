"""Multi-resolution (skelcore.multires): a reduced cloud is contracted and every input point carried along; the
run's helper thread that measures its states."""
import json

import numpy as np
import pytest

from skelcore import multires
from skelcore.evaluate import evaluate, make_graph
from skelcore.export import write_points_ply
from skelcore.io import validate
from skelcore.options import RunOptions
from skelcore.pipeline import run_pipeline
from skelcore.shapes import EXPECTED_TOPOLOGY, centreline, make_shape

TOPOLOGY = ("components", "cycles", "ends", "junctions")


def test_within_the_budget_nothing_is_reduced():
    points = make_shape("torus", 2000, seed=0).points
    assert multires.reduce_cloud(points, 2000) is None and multires.reduce_cloud(points, None) is None


@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_reduction_lands_in_the_budget_band(noise):
    points = make_shape("torus", 40_000, seed=0, noise=noise).points
    reduction = multires.reduce_cloud(points, 5000)
    lower, upper = (share * 5000 for share in multires.BUDGET_BAND)
    assert lower <= len(reduction.points) <= upper
    assert reduction.voxel_of.shape == (40_000,) and set(np.unique(reduction.voxel_of)) == set(range(len(reduction.points)))
    # a centroid lies within its voxel's reach of every point it stands for
    reach = np.linalg.norm(points - reduction.points[reduction.voxel_of], axis=1)
    assert reach.max() <= np.sqrt(3) * reduction.voxel_size + 1e-9


@pytest.mark.parametrize("n", [100_000, 300_000])
def test_centroids_of_a_dense_noisy_cloud_are_denoised_at_their_own_spacing(n):
    """In a dense cloud the 16 nearest points span less than noise of 1% of the diagonal, so cleaning's projection
    leaves a shell, and its voxel centroids fill it, the more so the denser the cloud (the noise's tails occupy
    voxels of their own). Projected on the plane of the points their own 16 nearest stand for (each centroid
    weighted by its count), they lie nearer the surface than the points they average."""
    from skelcore.clean import CleaningParams, denoised

    k = CleaningParams().neighbours
    points = denoised(make_shape("torus", n, seed=0, noise=0.01).points, k)  # cleaning's projection
    reduction = multires.reduce_cloud(points)
    off_surface = lambda p: np.median(np.abs(np.hypot(np.hypot(p[:, 0], p[:, 1]) - 1.0, p[:, 2]) - 0.3))
    shell = off_surface(reduction.points)
    assert shell > off_surface(points)  # the centroids are no nearer the surface than the points they average
    flat = reduction.denoised(k)
    assert off_surface(flat.points) < min(0.5 * shell, 0.8 * off_surface(points))
    assert np.array_equal(flat.voxel_of, reduction.voxel_of) and reduction.denoised(0) is reduction
    assert f"denoised on their {k} nearest" in flat.note() and "denoised" not in reduction.note()


def test_a_dense_noisy_drilled_block_keeps_its_hole():
    """The real-shape benchmark's plate with one hole, 100k points with noise of 1% of the diagonal: with the
    centroids left as a thick shell the contraction closed the hole (no loop)."""
    from skelcore.perturb import perturb
    from skelcore.pipeline import compute
    from skelcore.solids import solid_shape

    block = solid_shape("block_1_hole", 100_000, seed=0)
    cloud = validate(perturb(block.points, "noise_1", seed=0, normals=block.normals), name="block.xyz")
    run = compute(cloud, RunOptions())
    assert run.reduction is not None
    topology = run.skeleton.topology()
    assert (topology["components"], topology["cycles"]) == (1, 1)


@pytest.mark.parametrize("name", ["torus", "y_branch"])
def test_pipeline_above_the_budget(tmp_path, name):
    """The reduced run keeps the topology, and every input point keeps its row: carried positions, metrics
    over the input ids, a skeleton node each; metrics.json says what was done."""
    shape = make_shape(name, 6000, seed=0)
    path = tmp_path / f"{name}.ply"
    write_points_ply(path, shape.points)
    result = run_pipeline(path, tmp_path / "out", RunOptions(point_budget=2000))
    n = len(result.cloud.points)
    info = result.metrics["multiresolution"]
    assert info["input_points"] == n and info["contracted_points"] <= 2000
    assert all(state.points.shape == (n, 3) and np.array_equal(state.point_ids, np.arange(n)) for state in result.states)
    assert result.skeleton.correspondence.shape == (n,)
    counts = [result.skeleton.graph.nodes[i]["point_count"] for i in result.skeleton.graph.nodes]
    assert sum(counts) == n
    truth = make_graph(*centreline(name)[:2], name)
    scored = evaluate(make_graph(result.skeleton.nodes_array(), result.skeleton.edges_array()), truth)
    assert {key: scored["topology"]["skeleton"][key] for key in TOPOLOGY} == \
        {key: EXPECTED_TOPOLOGY[name][key] for key in TOPOLOGY}
    assert scored["chamfer"] <= 0.02
    written = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert written["multiresolution"]["contracted_points"] == info["contracted_points"]
    # iteration 0 is the input, not its voxels' interpolation: nothing has moved, no normal has turned
    assert np.array_equal(result.states[0].points, result.cloud.points)
    assert written["iterations"][0]["d_theta"]["mean"] == 0.0
    assert json.loads((tmp_path / "out" / "params.json").read_text())["point_budget"] == 2000


def test_carried_points_are_convex_combinations_of_their_ring():
    points = make_shape("capsule", 8000, seed=0).points
    reduction = multires.reduce_cloud(points, 2000)
    from skelcore.contraction import run_contraction

    states = run_contraction(reduction.points)
    carrier = reduction.carrier(states[0].rings)
    np.testing.assert_allclose(np.asarray(carrier.sum(axis=1)).ravel(), 1.0)
    assert carrier.data.min() >= 0
    lifted = reduction.lift(states[-1], carrier)
    # each carried point lies within the bounding box of the contracted cloud
    low, high = states[-1].points.min(axis=0), states[-1].points.max(axis=0)
    assert ((lifted.points >= low - 1e-9) & (lifted.points <= high + 1e-9)).all()


def test_voxels_numbered_without_a_sort_as_with_one(monkeypatch):
    """The occupancy-array numbering of small grids is np.unique's (key order)."""
    points = make_shape("torus", 20_000, seed=0, noise=0.01).points
    low = points.min(axis=0)
    dense = multires._voxels(points, low, 0.05)
    monkeypatch.setattr(multires, "DENSE_GRID", 0)
    assert np.array_equal(dense[0], multires._voxels(points, low, 0.05)[0]) and dense[1] == dense[0].max() + 1


def test_cli_run_says_in_metrics_json_that_it_reduced(tmp_path):
    """`skelcore run` (skelcore.api.run then Result.save) writes the reduction into metrics.json too."""
    from skelcore.cli import main

    path = tmp_path / "torus.ply"
    write_points_ply(path, make_shape("torus", 3000, seed=0).points)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet", "--point-budget", "1000"]) == 0
    written = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert written["multiresolution"]["input_points"] == written["n_points"]
    assert written["multiresolution"]["contracted_points"] <= 1000
    from skelcore.clean import CleaningParams

    assert written["multiresolution"]["denoise_neighbours"] == CleaningParams().neighbours
    assert main(["run", str(path), "--out", str(tmp_path / "raw"), "--quiet", "--point-budget", "1000",
                 "--no-denoise"]) == 0
    assert json.loads((tmp_path / "raw" / "metrics.json").read_text())["multiresolution"]["denoise_neighbours"] == 0


@pytest.mark.parametrize("budget", [None, 2000])
def test_metrics_and_evidence_made_beside_the_run_are_those_made_after_it(budget):
    """compute() measures each state on a helper thread while the contraction goes on (a reduced run: while its
    skeleton is drawn) and starts the skeleton evidence before the skeleton: the same metrics and evidence as
    computing them one after the other from the finished run."""
    from skelcore.evidence import skeleton_evidence
    from skelcore.pipeline import IterationMetricsCache, compute

    cloud = validate(make_shape("two_hole", 4000, seed=0).points, name="two_hole.xyz")
    run = compute(cloud, RunOptions(point_budget=budget))
    assert (run.reduction is not None) == (budget is not None)
    again = IterationMetricsCache(run.cloud).all(run.states)
    assert len(run.metrics) == len(run.states) == len(again)
    for made, remade in zip(run.metrics, again):
        assert made.iteration == remade.iteration
        np.testing.assert_array_equal(made.d_theta, remade.d_theta)
        np.testing.assert_array_equal(made.delta_kappa, remade.delta_kappa)
    assert run.evidence == skeleton_evidence(run.skeleton, run.states[-1], run.cloud.points)


def test_a_run_that_ends_a_step_back_keeps_the_metrics_of_the_states_it_keeps(monkeypatch):
    """A rejected step can take the last accepted state with it (skelcore.step.rejected: a fling that began in
    it). That state was measured on the helper thread already: its metrics go with it. Forced here: the rejection
    that ends the run drops the last state."""
    import skelcore.contraction as contraction
    from skelcore.pipeline import IterationMetricsCache, compute
    from skelcore.step import stopped

    def one_back(state, earlier, run, reason, detail, notes):
        return stopped(earlier if earlier is not None and earlier.iteration >= 1 else state, reason, detail, notes)

    cloud = validate(make_shape("capsule", 2000, seed=0).points, name="capsule.xyz")
    kept = len(compute(cloud, RunOptions()).states) - 1
    monkeypatch.setattr(contraction, "rejected", one_back)
    run = compute(cloud, RunOptions())
    assert kept >= 3 and [state.iteration for state in run.states] == list(range(kept))
    assert [measured.iteration for measured in run.metrics] == list(range(kept))
    np.testing.assert_array_equal(run.metrics[-1].d_theta, IterationMetricsCache(run.cloud).all(run.states)[-1].d_theta)


def test_an_error_on_the_helper_thread_is_the_runs_one_line_error(monkeypatch):
    from skelcore.errors import InputError
    from skelcore.metrics import MetricsReference
    from skelcore.pipeline import compute

    def broken(*args, **kwargs):
        raise InputError("points: something the metrics refuse")

    monkeypatch.setattr(MetricsReference, "evaluate", broken)
    cloud = validate(make_shape("capsule", 1500, seed=0).points, name="capsule.xyz")
    with pytest.raises(InputError, match="^capsule.xyz: points: something the metrics refuse$"):
        compute(cloud, RunOptions())


def test_a_reduced_runs_loop_probe_reads_the_inside_test_made_during_the_contraction(monkeypatch):
    """A reduced run's false-loop probe judges its loops on an inside test of the reduced points made on the
    second core while the contraction runs: it makes none itself, and the skeleton is the one it makes alone."""
    import skelcore.loops as loops
    import skelcore.pipeline as pipeline

    cloud = validate(make_shape("two_hole", 4000, seed=0).points, name="two_hole.xyz")
    monkeypatch.setattr(pipeline, "cloud_inside", lambda *args: None)  # none made ahead: the probe makes its own
    alone = pipeline.compute(cloud, RunOptions(point_budget=2000)).skeleton
    monkeypatch.undo()
    monkeypatch.setattr(loops, "cloud_inside", None)  # the probe's own would be made by this
    run = pipeline.compute(cloud, RunOptions(point_budget=2000))
    assert run.reduction is not None and run.skeleton.topology() == alone.topology()
    assert alone.topology()["cycles"] == 2  # loops were judged
    np.testing.assert_array_equal(run.skeleton.nodes_array(), alone.nodes_array())


def test_a_reduced_run_whose_inside_test_made_ahead_fails_judges_its_loops_alone(monkeypatch):
    """An error in the inside test made ahead is left to the probe to meet, if it ever needs the test: here
    it makes its own and the run ends as usual."""
    import skelcore.pipeline as pipeline
    from skelcore.errors import InputError

    def broken(*args):
        raise InputError("no part of the cloud is large enough")

    monkeypatch.setattr(pipeline, "cloud_inside", broken)
    run = pipeline.compute(validate(make_shape("torus", 4000, seed=0).points, name="torus.xyz"),
                           RunOptions(point_budget=2000))
    assert run.reduction is not None and run.skeleton.topology()["cycles"] == 1


def test_a_negative_point_budget_is_refused():
    from skelcore.errors import ParameterError

    with pytest.raises(ParameterError, match="point_budget"):
        multires.reduce_cloud(make_shape("torus", 1000).points, -1)


def _ball_with_a_dense_patch(ball_points: int = 5000, patch_points: int = 5000) -> np.ndarray:
    """The handled ball with a patch of its surface (a scanner's dwell, about 0.06 of radius 1 across) sampled
    over a hundred times as densely as the rest."""
    from skelcore.solids import solid_shape

    ball = solid_shape("handled_ball", ball_points).points
    patch = np.column_stack([np.random.default_rng(3).normal(0.0, 0.03, (patch_points, 2)), -np.ones(patch_points)])
    return np.vstack([ball, patch / np.linalg.norm(patch, axis=1, keepdims=True)])


def test_a_patch_far_denser_than_the_surface_around_it_is_thinned_for_the_contraction():
    """Contracted with every point, the patch barely moves and holds the ball back: the run stops after two
    steps with 6 ends on a shape that has none. Thinned (every point still carried along), the ball contracts
    as it does alone: its 3 loops and no end."""
    from skelcore.io import Cloud
    from skelcore.pipeline import compute

    points = _ball_with_a_dense_patch()
    run = compute(Cloud(points=points, name="ball"), RunOptions())
    reduction = run.reduction
    assert reduction is not None and reduction.thinned and 5000 <= len(reduction.points) < 5200
    assert run.skeleton.correspondence.shape == (len(run.cloud.points),)
    assert all(state.points.shape == run.cloud.points.shape for state in run.states)
    topology = run.skeleton.topology()
    assert (topology["components"], topology["cycles"]) == (1, 3) and topology["ends"] <= 1
    assert run.states[-1].iteration >= 5
    every_point = compute(Cloud(points=points, name="ball"), RunOptions(point_budget=0))
    assert every_point.reduction is None  # --full-resolution
    assert every_point.states[-1].iteration <= 3 and every_point.skeleton.topology()["ends"] >= 4


def test_thinning_keeps_every_point_of_a_thin_handle_and_of_the_even_surface():
    """Only the patch is thinned, to a few times the density of the surface around it: the ball's own points
    away from it, its thin handles' among them (a handle crossing a cell puts more surface into it than a
    sheet), all stay."""
    from scipy.spatial import cKDTree

    from skelcore import density
    from skelcore.normalise import SAMPLE_RADIUS, object_diagonal
    from skelcore.solids import solid_shape

    ball = solid_shape("thin_handled_ball", 5000).points
    patch = np.column_stack([np.random.default_rng(3).normal(0.0, 0.03, (5000, 2)), -np.ones(5000)])
    points = np.vstack([ball, patch / np.linalg.norm(patch, axis=1, keepdims=True)])
    kept = density.evened(points, SAMPLE_RADIUS * object_diagonal(points))
    away = np.flatnonzero(np.linalg.norm(ball - [0, 0, -1], axis=1) > 0.15)
    assert np.isin(away, kept).all() and len(away) > 4500
    # around the patch the kept cloud is up to EVEN times as dense as the ball's own surface there (the input: 350)
    near = lambda cloud: int((np.linalg.norm(cloud - [0, 0, -1], axis=1) < 0.1).sum())  # noqa: E731
    assert near(points) > 100 * near(ball) and near(ball) <= near(points[kept]) <= (density.EVEN + 1) * near(ball)
    patch_kept = points[kept[kept >= 5000]]
    # a regular subset: no two kept patch points far closer than the ball's own spacing
    spacing = np.median(cKDTree(ball).query(ball, k=2)[0][:, 1])
    assert cKDTree(patch_kept).query(patch_kept, k=2)[0][:, 1].min() > 0.1 * spacing


def test_an_evenly_sampled_cloud_and_a_finely_sampled_separate_object_are_not_thinned():
    """A small object beside a large one, each evenly sampled, is measured against its own density (its own
    points resolve its loop), so nothing is thinned; nor is an evenly sampled shape, or one with a few repeated
    points."""
    import trimesh

    from skelcore import density
    from skelcore.normalise import SAMPLE_RADIUS, object_diagonal

    big = trimesh.creation.torus(1.0, 0.3, major_sections=32, minor_sections=32)
    small = trimesh.creation.torus(1.0, 0.3, major_sections=32, minor_sections=32)
    small.apply_scale(0.1)
    small.apply_translation([2.0, 0.0, 0.0])
    pair = np.vstack([trimesh.sample.sample_surface(big, 5000, seed=1)[0],
                      trimesh.sample.sample_surface(small, 5000, seed=2)[0]])
    torus = make_shape("torus", 5000, seed=0).points
    repeated = np.vstack([torus, np.repeat(torus[:3], 10, axis=0)])  # 30 of 5,030: under the 1% a part must hold
    for points in (pair, torus, repeated):
        assert density.evened(points, SAMPLE_RADIUS * object_diagonal(points)) is None
    assert multires.contracted_cloud(pair) is None


def test_a_pile_of_repeated_points_is_thinned_without_a_warning(recwarn):
    """Coincident points are read as a millionth of a cell apart: finite densities; at most one of the pile is kept
    (its voxel keeps the point nearest its centre, which may be a neighbour of the pile, read dense too), and the
    surface away from it nearly as it was (where a cloud is thinned, a random sample's chance clumps more than
    EVEN times as dense keep one point a voxel too)."""
    from skelcore import density
    from skelcore.normalise import SAMPLE_RADIUS, object_diagonal

    torus = make_shape("torus", 3000, seed=0).points
    points = np.vstack([torus, np.repeat(torus[:1], 300, axis=0)])
    kept = density.evened(points, SAMPLE_RADIUS * object_diagonal(points))
    away = np.flatnonzero(np.linalg.norm(torus - torus[0], axis=1) > 0.1 * object_diagonal(torus))
    assert np.isin(away, kept).mean() > 0.98 and len(away) > 2700 and (kept >= 3000).sum() <= 1
    assert not [warning for warning in recwarn if issubclass(warning.category, RuntimeWarning)]


def test_cli_run_says_that_it_thinned_a_dense_part(tmp_path, capsys):
    """`skelcore run` names the thinning in its progress and in metrics.json; --full-resolution turns it off."""
    from skelcore.cli import main

    path = tmp_path / "ball.ply"
    write_points_ply(path, _ball_with_a_dense_patch(3000, 3000))
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 0
    assert "dense parts: " in capsys.readouterr().out
    reduction = json.loads((tmp_path / "out" / "metrics.json").read_text())["multiresolution"]
    assert reduction["dense_parts_thinned"] and reduction["contracted_points"] < reduction["input_points"]
    assert main(["run", str(path), "--out", str(tmp_path / "all"), "--quiet", "--full-resolution"]) == 0
    assert json.loads((tmp_path / "all" / "metrics.json").read_text())["multiresolution"] is None


def test_thinned_points_are_carried_and_kept_ones_stay_where_the_contraction_put_them():
    """A left-out point moves with the kept points around it (a convex blend); a kept point is not blended: its
    carried position is its own contracted one."""
    from skelcore.neighbours import one_rings
    from skelcore.params import default_k

    reduction = multires.thin_dense(_ball_with_a_dense_patch(3000, 3000))
    assert reduction is not None and reduction.thinned
    carrier = reduction.carrier(one_rings(reduction.points, default_k(len(reduction.points))))
    moved = np.random.default_rng(0).normal(size=reduction.points.shape)
    carried = carrier @ moved
    kept = np.flatnonzero(np.all(reduction.input_points == reduction.points[reduction.voxel_of], axis=1))
    assert len(kept) == len(reduction.points)
    np.testing.assert_allclose(carried[kept], moved[reduction.voxel_of[kept]])
    np.testing.assert_allclose(np.asarray(carrier.sum(axis=1)).ravel(), 1.0)


def test_the_api_thins_a_dense_part_unless_told_to_contract_every_point():
    import skelcore

    points = _ball_with_a_dense_patch(2000, 2000)
    assert skelcore.skeletonize(points).reduction.thinned
    assert skelcore.skeletonize(points, point_budget=0).reduction is None
