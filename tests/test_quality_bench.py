"""The quality benchmark's shapes, perturbations and command, on a small fast subset."""
import json
import re

import numpy as np
import pytest
from scipy.spatial import cKDTree

from skelcore import perturb as perturbations
from skelcore import solids
from skelcore.errors import InputError, ParameterError
from skelcore.solids import EVERYDAY

N = 3000


@pytest.mark.parametrize("name", list(solids.SOLIDS))
def test_every_solid_has_the_genus_and_pieces_its_construction_promises(name):
    vertices, faces = solids.solid_mesh(name)
    topology = solids.mesh_topology(vertices, faces)
    assert topology["closed"]
    expected = {"block_1_hole": (1, 1), "block_2_holes": (2, 1), "block_3_holes": (3, 1), "block_4_holes": (4, 1),
                "mug": (1, 1), "pretzel": (3, 1), "linked_rings_2": (2, 2), "linked_rings_3": (3, 3),
                "gear": (5, 1), "chain": (3, 3), "trefoil": (1, 1), "handled_ball": (3, 1),
                "thin_handled_ball": (3, 1), "thick_torus": (1, 1), "table": (0, 1), "chair": (2, 1),
                "stool": (3, 1)}[name]
    assert (topology["genus"], topology["components"]) == expected


@pytest.mark.parametrize("name", list(EVERYDAY))
def test_every_everyday_part_is_closed_with_the_genus_its_description_gives(name):
    vertices, faces = solids.solid_mesh(name)
    topology = solids.mesh_topology(vertices, faces)
    stated = re.search(r"\(genus (\d)(?:, (\d) pieces)?\)", EVERYDAY[name][2])
    assert topology["closed"] and topology["components"] == (int(stated.group(2) or 1) if stated else 1)
    assert topology["genus"] == (int(stated.group(1)) if stated else 0)
    assert name not in solids.shape_names()  # not in the default grid, nor in `skelcore study`


def test_bench_quality_runs_the_everyday_parts_by_flag_or_by_name(capsys, monkeypatch):
    from skelcore import cli, quality_bench

    import inspect

    asked = []

    def recorded(**kwargs):
        asked.append(kwargs["shapes"])
        return []

    recorded.__signature__ = inspect.signature(quality_bench.run_quality_bench)  # the flags' defaults read it
    monkeypatch.setattr(quality_bench, "run_quality_bench", recorded)
    monkeypatch.setattr(quality_bench, "format_table", lambda *args: "")
    assert cli.main(["bench-quality", "--parts", "--quiet"]) == 0
    assert cli.main(["bench-quality", "--shapes", "wrench", "block_1_hole", "--quiet"]) == 0
    assert asked == [list(EVERYDAY), ["wrench", "block_1_hole"]]
    assert cli.main(["bench-quality", "--parts", "--shapes", "key", "--quiet"]) == 2
    assert "--parts and --shapes: choose one" in capsys.readouterr().err
    shape = solids.benchmark_shapes(names=["key"], points=500)[0]  # sampled like a solid, its truth from its mesh
    assert (shape.name, shape.cycles, shape.components, shape.ends) == ("key", 1, 1, 1) and len(shape.points) == 500


@pytest.mark.parametrize("name", ["linked_rings_2", "linked_rings_3", "chain"])
def test_separate_pieces_stay_apart_under_the_strongest_noise(name):
    shape = solids.solid_shape(name, N, seed=0)
    radius = perturbations.LINK_SPACINGS * np.median(cKDTree(shape.points).query(shape.points, k=2)[0][:, 1])
    labels = perturbations._labels(shape.points, radius)
    assert len(np.unique(labels)) == shape.components
    gap = min(cKDTree(shape.points[labels != piece]).query(shape.points[labels == piece])[0].min()
              for piece in np.unique(labels))
    sigma = perturbations.NOISE["noise_1"] * _diagonal(shape.points)
    assert gap > 8 * sigma  # noise of +-4 sigma on both sides cannot join two pieces


def test_a_torus_by_euler_characteristic():
    import trimesh

    torus = trimesh.creation.torus(1.0, 0.3)
    assert solids.mesh_topology(torus.vertices, torus.faces) == {
        "components": 1, "euler": 0, "boundary_loops": 0, "genus": 1, "closed": True}
    opened = trimesh.Trimesh(torus.vertices, torus.faces[1:])  # one triangle removed: a boundary loop
    assert solids.mesh_topology(opened.vertices, opened.faces)["genus"] == 1


def test_benchmark_shapes_are_seeded_samples_on_the_surface_with_outward_normals():
    shapes = solids.benchmark_shapes(reference_dir="/nonexistent", points=N, seed=3,
                                     names=["block_2_holes", "linked_rings_2"])
    again = solids.benchmark_shapes(reference_dir="/nonexistent", points=N, seed=3,
                                    names=["block_2_holes", "linked_rings_2"])
    for shape, same in zip(shapes, again):
        assert shape.points.shape == (N, 3) and np.array_equal(shape.points, same.points)
        assert np.allclose(np.linalg.norm(shape.normals, axis=1), 1.0)
        # outward: the mesh's nearest vertex lies behind a sample, seen along its normal, no more than inward
        scene = _raycasting_scene(*solids.solid_mesh(shape.name))
        assert np.abs(scene.compute_distance(shape.points.astype(np.float32)).numpy()).max() < 1e-3  # float32 scene
        inward = (shape.points - 0.02 * shape.normals).astype(np.float32)
        outward = (shape.points + 0.02 * shape.normals).astype(np.float32)
        assert scene.compute_occupancy(inward).numpy().mean() > 0.99
        assert scene.compute_occupancy(outward).numpy().mean() < 0.01
        # evenly spread: no two samples much closer than the Poisson-disk spacing would allow
        spacing = cKDTree(shape.points).query(shape.points, k=2)[0][:, 1]
        assert spacing.min() > 0.2 * np.median(spacing)
    other = solids.benchmark_shapes(reference_dir="/nonexistent", points=N, seed=4, names=["block_2_holes"])[0]
    assert not np.array_equal(other.points, shapes[0].points)
    assert [s.cycles for s in shapes] == [2, 2] and [s.components for s in shapes] == [1, 2]


def _raycasting_scene(vertices, faces):
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(vertices.astype(np.float32), faces.astype(np.uint32))
    return scene


def test_benchmark_shapes_without_the_reference_folder_are_the_solids():
    assert solids.shape_names("/nonexistent") == list(solids.SOLIDS)
    with pytest.raises(InputError, match="unknown or its reference folder is missing"):
        solids.benchmark_shapes(reference_dir="/nonexistent", points=N, names=["horse"])


def test_reference_meshes_have_the_stated_genus(reference_dir):
    from skelcore import io

    import trimesh

    for name, reference in solids.REFERENCES.items():
        if not reference.mesh:
            continue  # scans: the truth is stated with its reason
        cloud = io.load(reference_dir / reference.file, sample=0)  # the mesh itself
        assert cloud.faces is not None, name

        parts = trimesh.Trimesh(cloud.points, cloud.faces).split(only_watertight=False)
        main = max(parts, key=lambda part: len(part.faces))  # stray slivers of a few triangles aside
        topology = solids.mesh_topology(main.vertices, main.faces)
        assert (topology["genus"], 1) == (reference.cycles, reference.components), name
        assert all(len(part.faces) <= 4 for part in parts if part is not main), name


def test_reference_shapes_load_and_sample(reference_dir):
    shapes = solids.benchmark_shapes(reference_dir, points=N, names=["hand", "duck"])
    assert [s.points.shape for s in shapes] == [(N, 3), (N, 3)]
    assert shapes[0].normals is not None and shapes[1].normals is None
    assert shapes[0].ends == 6  # the rig's leaves: five finger tips and the wrist
    assert shapes[0].mesh is not None and shapes[1].mesh is None  # the duck is a scan: no "mesh" run


# --- perturbations ----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def rings():
    return solids.solid_shape("linked_rings_2", N, seed=0)


def _diagonal(points):
    return np.linalg.norm(points.max(axis=0) - points.min(axis=0))


def test_variants_are_pure_functions_of_points_and_seed(rings):
    for variant in (*perturbations.VARIANTS, *perturbations.MORE_VARIANTS):
        first = perturbations.perturb(rings.points, variant, seed=1, normals=rings.normals)
        assert np.array_equal(first, perturbations.perturb(rings.points, variant, seed=1, normals=rings.normals))
    assert not np.array_equal(perturbations.perturb(rings.points, "noise_1", seed=1),
                              perturbations.perturb(rings.points, "noise_1", seed=2))
    assert np.array_equal(perturbations.perturb(rings.points, "clean"), rings.points)


@pytest.mark.parametrize("variant,share", [("noise_0.5", 0.005), ("noise_1", 0.01)])
def test_noise_has_the_stated_share_of_the_diagonal(rings, variant, share):
    moved = perturbations.perturb(rings.points, variant, seed=0) - rings.points
    assert np.std(moved) == pytest.approx(share * _diagonal(rings.points), rel=0.05)


def test_outliers_are_two_percent_inside_the_bounding_box(rings):
    noisy = perturbations.perturb(rings.points, "outliers_2", seed=0)
    assert len(noisy) == N + 60 and np.array_equal(noisy[:N], rings.points)
    extra = noisy[N:]
    assert (extra >= rings.points.min(axis=0)).all() and (extra <= rings.points.max(axis=0)).all()


def test_two_scans_are_half_the_points_each_registered_a_fraction_of_a_percent_apart(rings):
    """A second scan's half is moved rigidly: its points keep their distances to one another, and move by about
    the misregistration's shift (a turn of 0.01 rad adds at most 0.01 of the radius)."""
    moved = perturbations.perturb(rings.points, "two_scans", seed=0)
    shifted = np.linalg.norm(moved - rings.points, axis=1) > 0
    assert len(moved) == N and 0.4 < shifted.mean() < 0.6
    angle, shift = perturbations.MISREGISTRATION
    diagonal = _diagonal(rings.points)
    offsets = np.linalg.norm(moved[shifted] - rings.points[shifted], axis=1)
    assert (np.abs(offsets - shift * diagonal) <= angle * diagonal).all()
    pairs = np.flatnonzero(shifted)[:50]
    before = np.linalg.norm(rings.points[pairs, None] - rings.points[pairs], axis=2)
    after = np.linalg.norm(moved[pairs, None] - moved[pairs], axis=2)
    np.testing.assert_allclose(after, before, atol=1e-12)


def test_layered_coordinates_are_multiples_of_the_step(rings):
    layered = perturbations.perturb(rings.points, "layered", seed=0)
    step = perturbations.LAYER_STEP * _diagonal(rings.points)
    np.testing.assert_allclose(layered / step, np.round(layered / step), atol=1e-9)
    assert np.abs(layered - rings.points).max() <= step / 2 * (1 + 1e-9) * np.sqrt(3)


def test_scan_lines_lie_in_parallel_planes_the_gap_apart_a_step_apart_along_them():
    """The mesh cut by parallel planes SCAN_LINE_GAP of its diagonal apart, across the seed's direction, the first
    half a gap in: every point's height along that direction a whole number of gaps from there; along its line the
    nearest point SCAN_LINE_STEP away (or the line's end)."""
    torus = solids.benchmark_shapes(seed=0, names=["thick_torus"])[0]
    lines = perturbations.scan_lines(*torus.mesh, seed=0)
    np.testing.assert_array_equal(lines, perturbations.scan_lines(*torus.mesh, seed=0))
    assert not np.allclose(perturbations.scan_direction(0), perturbations.scan_direction(1))
    diagonal = np.linalg.norm(np.ptp(torus.mesh[0], axis=0))
    direction = perturbations.scan_direction(0)
    planes = (lines @ direction - (torus.mesh[0] @ direction).min()) / (perturbations.SCAN_LINE_GAP * diagonal) - 0.5
    np.testing.assert_allclose(planes, np.round(planes), atol=1e-6)
    nearest = cKDTree(lines).query(lines, k=2)[0][:, 1]
    assert np.median(nearest) == pytest.approx(perturbations.SCAN_LINE_STEP * diagonal, rel=0.05)


def test_density_keeps_thirty_percent_on_one_half(rings):
    thinned = perturbations.perturb(rings.points, "density_30", seed=0)
    axis = perturbations._principal_axes(rings.points)[:, 0]
    along = (rings.points - rings.points.mean(axis=0)) @ axis
    median = np.median(along)
    kept = (thinned - rings.points.mean(axis=0)) @ axis
    assert (kept <= median).sum() == (along <= median).sum()
    assert (kept > median).sum() / (along > median).sum() == pytest.approx(0.3, abs=0.04)


def test_the_thinned_half_is_thinned_evenly_whatever_drew_its_points():
    """The capsule's sampler draws from default_rng(seed), as the variants once did: thinned by the same
    draws that had placed its points, its thinned half lost its cap and a band across it (two pieces)."""
    from skelcore.shapes import make_shape

    capsule = make_shape("capsule", N, seed=0).points
    thinned = perturbations.perturb(capsule, "density_30", seed=0)
    slabs = np.linspace(capsule[:, 0].min(), capsule[:, 0].max(), 9)
    kept = np.histogram(thinned[:, 0], slabs)[0] / np.histogram(capsule[:, 0], slabs)[0]
    assert kept.min() > 0.15, kept  # every slab of the thinned half keeps about 30% of its points


@pytest.mark.parametrize("name", ["linked_rings_3", "block_3_holes", "chain"])
def test_partial_scan_sees_one_side_and_keeps_each_piece_whole(name):
    shape = solids.solid_shape(name, N, seed=0)
    radius = perturbations.LINK_SPACINGS * np.median(cKDTree(shape.points).query(shape.points, k=2)[0][:, 1])
    for normals in (shape.normals, None):  # the mesh's normals, and PCA normals oriented outward
        seen, towards = perturbations.partial_scan(shape.points, normals)
        assert 0.4 * N < len(seen) < 0.6 * N
        assert len(np.unique(perturbations._labels(shape.points[seen], radius))) == shape.components
        facing = shape.normals @ towards > 0
        # back faces gone (PCA normals differ from the mesh's on sharp edges and thin rings)
        assert facing[seen].mean() > (0.999 if normals is not None else 0.9)
        assert len(seen) >= (1 - perturbations.ISLAND_SHARE) * facing.sum() - 0.01 * N
    assert np.array_equal(perturbations.perturb(shape.points, "partial", normals=shape.normals),
                          shape.points[perturbations.partial_scan(shape.points, shape.normals)[0]])


def test_a_partial_scan_of_a_shape_with_loops_drops_no_handle():
    """Seen from the default view, one thin handle's visible arc is an island (its feet face away) holding
    1.5% of what the view sees, which a genus-0 scan may drop as clean-up. With loops, the view must keep every
    patch: the handle, and with it the truth of 3 loops, stays."""
    shape = solids.solid_shape("thin_handled_ball", 10_000, seed=0)
    radius = perturbations.LINK_SPACINGS * np.median(cKDTree(shape.points).query(shape.points, k=2)[0][:, 1])
    dropping, towards = perturbations.partial_scan(shape.points, shape.normals)
    facing = np.flatnonzero(shape.normals @ towards > 0)
    assert 0 < len(facing) - len(dropping) <= perturbations.ISLAND_SHARE * len(facing)
    keeping, towards = perturbations.partial_scan(shape.points, shape.normals, island_share=0.0)
    assert len(keeping) == np.count_nonzero(shape.normals @ towards > 0)
    assert len(np.unique(perturbations._labels(shape.points[keeping], radius))) == 1
    assert np.array_equal(perturbations.perturb(shape.points, "partial", normals=shape.normals, loops=True),
                          shape.points[keeping])


def test_pca_normals_point_outward(rings):
    estimated = perturbations.estimate_normals(rings.points)
    assert (np.einsum("ij,ij->i", estimated, rings.normals) > 0).mean() > 0.99


def test_bad_perturbation_requests_are_refused(rings):
    with pytest.raises(ParameterError, match="unknown variant 'blur'"):
        perturbations.perturb(rings.points, "blur")
    with pytest.raises(ParameterError, match="at least 20 points"):
        perturbations.perturb(np.zeros((5, 3)), "clean")
    with pytest.raises(ParameterError, match="do not match"):
        perturbations.perturb(rings.points, "partial", normals=rings.normals[:10])


# --- the benchmark --------------------------------------------------------------------------------

def _result(shape, variant, method, cycles, nodes, expected_cycles=1, error=None, seed=0):
    from skelcore.quality_bench import CaseResult

    topology = None if error else {"cycles": cycles, "components": 1, "junctions": 0, "ends": 0}
    return CaseResult(shape, variant, method, {"cycles": expected_cycles, "components": 1, "ends": 0}, 100, seed,
                      topology, None if error else nodes, seconds=1.0, error=error)


def test_summary_counts_exact_runs_collapses_and_lost_loops():
    from skelcore.quality_bench import format_table, summarise

    results = [_result("a", "clean", "lbc", 1, 40), _result("a", "noise_1", "lbc", 1, 19),
               _result("a", "partial", "lbc", 0, 20), _result("b", "clean", "lbc", 0, 30),
               _result("b", "noise_1", "lbc", 1, 30), _result("b", "partial", "lbc", 0, 0, error="ValueError: x")]
    summary = summarise(results)["lbc"]
    assert (summary["clean_exact"], summary["clean_runs"]) == (1, 2)
    assert (summary["perturbed_exact"], summary["perturbed_runs"]) == (2, 4)
    assert summary["collapsed"] == ["a/noise_1", "b/partial"]  # 19 < 40 / 2; an error keeps no nodes
    assert (summary["no_collapse"], summary["collapse_checked"]) == (2, 4)
    assert summary["clean_loops_lost"] == ["b"]
    assert summary["by_variant"] == {"clean": [1, 2], "noise_1": [2, 2], "partial": [0, 2]}
    table = format_table(results, summarise(results), 6.0)
    assert "on clean clouds 1/2 (50%), on perturbed 2/4 (50%)" in table
    assert "error: b partial lbc: ValueError: x" in table and "ERROR" in table


def test_several_seeds_are_counted_apart_and_each_run_checked_against_the_clean_run_of_its_draw():
    from skelcore.quality_bench import format_table, summarise

    results = [_result("a", "clean", "lbc", 1, 40, seed=0), _result("a", "noise_1", "lbc", 1, 25, seed=0),
               _result("a", "clean", "lbc", 1, 60, seed=1), _result("a", "noise_1", "lbc", 0, 25, seed=1)]
    summary = summarise(results)["lbc"]
    assert summary["collapsed"] == ["a/noise_1 seed 1"]  # 25 of seed 1's 60, but not of seed 0's 40
    assert summary["perturbed_by_seed"] == {"0": [1, 1], "1": [0, 1]}
    assert (summary["perturbed_exact"], summary["perturbed_runs"]) == (1, 2)
    table = format_table(results, summarise(results), 4.0)
    assert "exact perturbed by seed: 0 1/1, 1 0/1" in table
    rows = [line.split() for line in table.splitlines() if line.startswith("a ")]
    assert [row[2] for row in rows] == ["0", "0", "1", "1"]  # a seed column once there are several


def test_mesh_runs_are_counted_apart_from_the_perturbed_clouds():
    from skelcore.quality_bench import format_table, summarise

    results = [_result("a", "clean", "lbc", 1, 40), _result("a", "noise_1", "lbc", 0, 40),
               _result("a", "mesh", "lbc", 1, 40)]
    summary = summarise(results)["lbc"]
    assert (summary["perturbed_exact"], summary["perturbed_runs"]) == (0, 1)
    assert (summary["mesh_exact"], summary["mesh_runs"]) == (1, 1)
    assert "on perturbed 0/1 (0%), on mesh files 1/1 (100%)" in format_table(results, summarise(results), 3.0)


def test_the_mesh_variant_gives_the_pipeline_the_shapes_mesh_file_and_skips_scans(tmp_path):
    """A drilled block's mesh file: the loader samples it to the benchmark's count and reads its genus, which the
    run's evidence carries (a point cloud's has none)."""
    from skelcore.quality_bench import run_quality_bench

    results = run_quality_bench(methods=["glskeleton"], shapes=["block_1_hole"], variants=["clean", "mesh"],
                                points=N, keep_dir=tmp_path)
    clean, mesh = results
    assert mesh.variant == "mesh" and mesh.n_points == N and mesh.error is None and mesh.exact
    metrics = json.loads((tmp_path / "block_1_hole_mesh_glskeleton" / "metrics.json").read_text())
    assert metrics["skeleton_evidence"]["input_loops"] == 1
    assert json.loads((tmp_path / "block_1_hole_clean_glskeleton" / "metrics.json").read_text()
                      )["skeleton_evidence"]["input_loops"] is None


def test_bench_quality_refuses_seeds_that_are_no_draw(capsys):
    from skelcore.cli import main

    with pytest.raises(SystemExit) as stop:  # the command line refuses it as it reads its arguments
        main(["bench-quality", "--seeds", "-1", "--shapes", "block_1_hole", "--quiet"])
    assert stop.value.code == 2 and "invalid seed -1" in capsys.readouterr().err


def test_bench_quality_runs_prints_one_table_and_survives_a_failing_run(monkeypatch, capsys, tmp_path):
    from skelcore import pipeline
    from skelcore.cli import main

    real = pipeline.run_pipeline

    def failing_for_glskeleton(source, out, options, progress=None):
        if options.params.method == "glskeleton":
            raise RuntimeError("a broken step")
        return real(source, out, options, progress)

    monkeypatch.setattr(pipeline, "run_pipeline", failing_for_glskeleton)
    code = main(["bench-quality", "--shapes", "block_1_hole", "--variants", "clean", "noise_0.5",
                 "--points", str(N), "--json", str(tmp_path / "q.json"), "--quiet"])
    assert code == 0
    out = capsys.readouterr().out
    rows = [line for line in out.splitlines() if line.startswith("block_1_hole")]
    assert len(rows) == 2 and all("ERROR" in row for row in rows)
    # A drilled block (a thick ring) is one loop LBC keeps on the clean cloud.
    clean = rows[0].split("|")[1].split()
    assert clean[0].startswith("1/1/") and clean[2] == "yes", out
    assert "lbc: exact (cycles and components) on clean clouds 1/1 (100%), on perturbed" in out
    assert "glskeleton: exact" in out and "2 errors" in out
    assert "error: block_1_hole clean glskeleton: RuntimeError: a broken step" in out
    import json

    document = json.loads((tmp_path / "q.json").read_text())
    assert len(document["runs"]) == 4 and document["summary"]["lbc"]["clean_exact"] == 1


def test_bench_quality_refuses_unknown_shapes_in_one_line(capsys):
    from skelcore.cli import main

    assert main(["bench-quality", "--shapes", "samovar", "--quiet"]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("skelcore bench-quality: error: shape 'samovar': unknown") and "\n" not in error


def test_bench_quality_refuses_a_reference_folder_that_is_not_there(tmp_path, capsys, monkeypatch):
    from skelcore import quality_bench
    from skelcore.cli import main

    monkeypatch.setattr(quality_bench, "run_case", lambda *args, **kwargs: pytest.fail("a run started"))
    assert main(["bench-quality", "--reference", str(tmp_path / "nonexistent"), "--quiet"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "--reference" in error and "nonexistent: no such folder" in error


def test_a_twig_thinner_than_the_sampling_is_seen_from_every_side():
    rng = np.random.default_rng(0)
    grid = np.stack(np.meshgrid(np.linspace(-1, 1, 40), np.linspace(-1, 1, 40)), axis=-1).reshape(-1, 2)[:1500]
    sheet = np.column_stack([grid + rng.normal(0.0, 0.005, grid.shape), 0.3 * grid[:, 0] ** 2])  # bent, evenly sampled
    twig = np.column_stack([np.zeros(200), np.zeros(200), np.linspace(0.05, 1.5, 200)])
    twig += rng.normal(0.0, 1e-3, twig.shape)
    assert perturbations.linearity(twig).min() > perturbations.LINEAR
    assert (perturbations.linearity(sheet) > perturbations.LINEAR).mean() < 0.01
    cloud = np.vstack([sheet, twig])
    seen, _ = perturbations.partial_scan(cloud)
    assert set(range(1500, 1700)) <= set(seen.tolist())


@pytest.fixture(scope="module")
def partial_tree():
    from conftest import REFERENCE

    if not REFERENCE.is_dir():
        pytest.skip("../shared/reference is absent: reference data not available")
    shape = solids.benchmark_shapes(REFERENCE, names=["tree"])[0]
    return perturbations.perturb(shape.points, "partial", normals=shape.normals)


@pytest.mark.parametrize("method", ["lbc", "glskeleton"])
def test_the_partial_tree_scan_has_no_loop_where_a_twig_jumps_a_gap(partial_tree, method):
    """In the single-view scan of the tree (10k points, as the benchmark samples it), a twig's tip ends beside
    another branch across a gap the one-rings reach over; the skeleton cuts that cycle at the gap."""
    from skelcore.quality_bench import run_case

    outcome = run_case(partial_tree, method, name="tree")
    assert outcome["topology"]["cycles"] == 0 and outcome["topology"]["components"] == 1


@pytest.mark.parametrize("method", ["lbc", "glskeleton"])
def test_the_duck_scans_body_closes_no_loop(reference_dir, method):
    """The duck scan (draw 1, as the benchmark samples it) barely contracts and leaves shards whose gaps close a
    cycle through its body; that cycle's fan disk reads a few percent outside (cells deep inside the body whose
    nearest sample's normal points the wrong way), but no open space goes through it, so it is cut."""
    from skelcore.quality_bench import run_case

    duck = solids.benchmark_shapes(reference_dir, seed=1, names=["duck"])[0]
    outcome = run_case(duck.points, method, name="duck", seed=1)
    assert outcome["topology"]["cycles"] == 0 and outcome["topology"]["components"] == 1


def test_the_noisy_gears_narrow_holes_stay_loops():
    """The gear with 1% noise (draw 0): noise narrows its four holes to a few grid cells across, so the open
    space through them lies beside most disk points rather than straight along the disk's normal; all five
    loops stay."""
    from skelcore.quality_bench import run_case

    gear = solids.benchmark_shapes(seed=0, names=["gear"])[0]
    cloud = perturbations.perturb(gear.points, "noise_1", seed=0, normals=gear.normals, loops=True)
    outcome = run_case(cloud, "lbc", name="gear", seed=0)
    assert outcome["topology"]["cycles"] == 5 and outcome["topology"]["components"] == 1


def test_a_chairs_back_rail_closes_no_loop_of_its_own(monkeypatch):
    """The clean chair at 5,000 points (draw 0): the flat middle rail of its back contracts into two strands that
    bulge into the openings above and below it, a sliver cycle whose disk reads 2.8% outside, nearly all of it
    along the cycle itself. Outside space next to the rim is no hole, so only the back's two openings stay loops;
    counting it, the sliver was a third."""
    from skelcore import loops
    from skelcore.quality_bench import run_case

    chair = solids.benchmark_shapes(points=5000, seed=0, names=["chair"])[0]
    assert run_case(chair.points, "lbc", name="chair", seed=0)["topology"]["cycles"] == 2
    monkeypatch.setattr(loops, "_AWAY_FROM_RIM", np.ones_like(loops._AWAY_FROM_RIM))
    assert run_case(chair.points, "lbc", name="chair", seed=0)["topology"]["cycles"] == 3


def test_flat_and_framed_parts_keep_their_loops_and_ends():
    """A fast subset of `bench-quality --parts`: the wrench (a plate: a ring end and an open jaw) and the glasses
    (two rims of thin rod, a bridge and temples), clean, both methods."""
    from skelcore.quality_bench import run_quality_bench

    results = run_quality_bench(methods=("lbc", "glskeleton"), shapes=["wrench", "glasses"], variants=("clean",))
    assert len(results) == 4
    for result in results:
        assert result.exact and result.topology["ends"] == result.expected["ends"], (result.shape, result.method,
                                                                                      result.topology)


def test_containers_wire_handles_keep_their_loops():
    """The bucket and the cooking pot at 10,000 points, clean, both methods. The bucket's bail, a wire 0.5 thick
    about three points around, lost its loop as cleaning's denoising flattened it into a ribbon (skelcore.clean)
    and, where a cross-section held too few points to tell, the thin-handle test counted that as a vote against a
    tube (skelcore.curveness): the bail was neither held nor kept in place and shrank onto the rim. One of the
    pot's two wire handles split into pieces that closed no loop where a few points fell unevenly round the wire
    and their centroid, off its axis, read them as no hollow tube (the circle through them finds the axis)."""
    from skelcore.quality_bench import run_quality_bench

    for result in run_quality_bench(methods=("lbc", "glskeleton"), shapes=["bucket", "cooking_pot"],
                                    variants=("clean",)):
        assert result.exact, (result.method, result.topology)


def test_a_slot_under_an_arm_closes_no_loop():
    """The stapler at 10,000 points, clean, GLSkeleton: its arm over its base, the slot between them 1.2-2.6
    sample radii wide, closed at the hinge and open at three sides. The one-rings bridged the slot 3.5 spacings
    long, their middles about a radius from both walls, so the distance rule saw no jump and the skeleton's rungs
    across the slot closed two false loops, whose disks the slot's walls cross as a hole's would. Those middles
    lie outside the solid: the rungs are jumps (skelcore.loops)."""
    from skelcore.quality_bench import run_quality_bench

    result, = run_quality_bench(methods=("glskeleton",), shapes=["stapler"], variants=("clean",))
    assert result.exact, result.topology


def test_a_depth_camera_s_layers_add_no_loop_to_a_drilled_plate():
    """The plate with one hole at 10,000 points with coordinates in layers of 0.5% of the diagonal (draw 0): the
    rows of points on its faces used to make flat one-ring triangles whose clamped cotangents pulled points 0.1
    apart together in one step (W_H up to 3,000), and the run ended flung with a second loop."""
    from skelcore.quality_bench import run_case

    plate = solids.benchmark_shapes(seed=0, names=["block_1_hole"])[0]
    cloud = perturbations.perturb(plate.points, "layered", seed=0)
    outcome = run_case(cloud, "lbc", name="plate", seed=0)
    assert outcome["topology"]["cycles"] == 1 and outcome["topology"]["components"] == 1
    assert outcome["termination"] != "flung"


@pytest.mark.parametrize("name, method", [("coffee_table", "lbc"), ("basket", "glskeleton")])
def test_thin_plates_keep_the_loops_through_their_openings(name, method):
    """A coffee table's top and shelf (3 and 2 thick, 1.9 and 1.2 point spacings at 10,000 points) and a basket's
    0.6 wall: cleaning's denoising pulls each wall's faces into one sheet, whose normals turn the space on one
    side solid, and the false-loop rule found the openings between the legs and under the handle inside the solid
    and cut their loops (2 of 3 and 0 of 1). The inside tests now sample the points with the faces kept apart."""
    from skelcore.quality_bench import run_case

    shape = solids.benchmark_shapes(seed=0, names=[name])[0]
    topology = run_case(shape.points, method, name=name, seed=0)["topology"]
    assert (topology["cycles"], topology["components"]) == (shape.cycles, 1)


def test_a_crates_side_keeps_the_loops_of_its_six_openings():
    """A plate 0.4 thick (1.2 point spacings at 10,000 points) with six openings: the contraction keeps their six
    loops, and the false-loop rule cut them all (0 of 6, with 7 spurs), as the openings' walls, that low, have
    no PCA normal of their own to cross the loops' disks; the sheet's edges there cross them now."""
    from skelcore.quality_bench import run_case

    shape = solids.benchmark_shapes(seed=0, names=["crate_side"])[0]
    topology = run_case(shape.points, "lbc", name="crate_side", seed=0)["topology"]
    assert (topology["cycles"], topology["components"], topology["ends"]) == (6, 1, 0)
