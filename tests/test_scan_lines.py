"""Clouds sampled on scan lines: read from their neighbourhoods, contracted as voxel centroids one line spacing apart."""
import numpy as np
import pytest

from skelcore import multires, perturb, solids
from skelcore.scan_lines import LINE_RATIO, line_spacing
from skelcore.shapes import make_shape


@pytest.fixture(scope="module")
def plate():
    return solids.benchmark_shapes(seed=0, names=["block_2_holes"])[0]


@pytest.fixture(scope="module")
def plate_lines(plate):
    return perturb.scan_lines(*plate.mesh, seed=0)


def test_scan_lines_are_read_with_their_spacing_and_ratio(plate, plate_lines):
    """The plate cut every 1.5% of its diagonal, a point every 0.3% on each cut: its lines lie at least the planes'
    gap apart, farther on faces slanted to the planes (1.8% in all), five to six times the points' spacing."""
    gap = perturb.SCAN_LINE_GAP * np.linalg.norm(np.ptp(plate.points, axis=0))
    spacing, ratio = line_spacing(plate_lines)
    assert 4 < ratio < 8 and gap <= spacing < 1.5 * gap


@pytest.mark.parametrize("variant", ["clean", "noise_1", "density_30", "layered"])
def test_evenly_sampled_clouds_and_lattices_are_no_scan_lines(plate, variant):
    cloud = np.unique(perturb.perturb(plate.points, variant, seed=0), axis=0)
    assert line_spacing(cloud) is None


def test_a_cloud_of_curves_is_no_scan_lines():
    """Points on circles far apart have no neighbour across their line within reach: curves, read as they are."""
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    circles = [np.column_stack([np.cos(t) * r, np.sin(t) * r, np.full_like(t, 3.0 * r)]) for r in (1.0, 2.0, 3.0)]
    assert line_spacing(np.vstack(circles)) is None


@pytest.fixture(scope="module")
def pretzel_lines():
    return perturb.scan_lines(*solids.benchmark_shapes(seed=0, names=["pretzel"])[0].mesh, seed=0)


def test_scan_lines_are_contracted_one_line_spacing_apart_and_every_point_carried(pretzel_lines):
    reduction = multires.contracted_cloud(pretzel_lines)
    spacing, ratio = line_spacing(pretzel_lines)
    assert reduction is not None and reduction.scan_lines == ratio and reduction.voxel_size == spacing
    assert len(reduction.voxel_of) == len(pretzel_lines) and len(reduction.points) < len(pretzel_lines) / 3
    assert "scan lines" in reduction.note() and "--full-resolution" in reduction.note()
    assert reduction.describe()["scan_lines"] == ratio
    assert multires.contracted_cloud(pretzel_lines, None) is None  # --full-resolution: every point as it is
    assert multires.contracted_cloud(make_shape("torus", 3000, seed=0).points) is None


def test_scan_lines_above_the_budget_are_read_on_its_centroids_and_contracted_one_line_spacing_apart(plate_lines):
    """The plate's lines hold 27,377 points: the budget's 20,000 centroids lie on the same lines, whose spacing
    is wider than the budget's voxels."""
    budget = multires.reduce_cloud(plate_lines)
    spacing, ratio = line_spacing(budget.points)
    reduction = multires.contracted_cloud(plate_lines)
    assert reduction.scan_lines == ratio > LINE_RATIO
    assert reduction.voxel_size == spacing > budget.voxel_size and len(reduction.voxel_of) == len(plate_lines)


@pytest.mark.parametrize("method", ["lbc", "glskeleton"])
def test_a_pretzel_scanned_in_lines_keeps_its_three_loops(method):
    """12,212 points on lines, under the budget: contracted point by point, the strips of long thin fan triangles
    between the lines lost one of the pretzel's loops and left 3 ends, with either method."""
    from skelcore.quality_bench import run_case

    pretzel = solids.benchmark_shapes(seed=0, names=["pretzel"])[0]
    lines = perturb.scan_lines(*pretzel.mesh, seed=0)
    assert len(lines) < multires.POINT_BUDGET
    topology = run_case(lines, method, name="pretzel")["topology"]
    assert (topology["cycles"], topology["components"], topology["ends"]) == (3, 1, 0)


def test_the_verdict_reads_a_cloud_on_scan_lines_inside_by_its_voxel_centroids(pretzel_lines):
    """The inside test read from the lines' own neighbourhoods put half the pretzel's contracted points outside the
    original (49%: "unstable" on its right skeleton); it samples the surface by the centroids one line spacing apart,
    as the contraction does."""
    import skelcore

    verdict = skelcore.skeletonize(pretzel_lines).verdict
    inside = next(c for c in verdict["criteria"] if c["name"] == "points inside the original")
    assert inside["passed"] and verdict["label"] == "stable"


@pytest.mark.parametrize("cloud_of", ["torus", "pretzel lines"])
def test_a_run_reads_scan_lines_once_for_its_contraction_and_its_inside_test(monkeypatch, pretzel_lines, cloud_of):
    """The reading the contraction's reduction makes serves the metrics' inside test, as a reduction or as none."""
    import skelcore
    from app.session import Session
    from skelcore import scan_lines
    from skelcore.io import validate

    points = make_shape("torus", 2000, seed=0).points if cloud_of == "torus" else pretzel_lines
    reads = []
    monkeypatch.setattr(scan_lines, "line_spacing", lambda cloud: reads.append(len(cloud)) or line_spacing(cloud))
    assert skelcore.skeletonize(points).skeleton.topology()["cycles"] == (1 if cloud_of == "torus" else 3)
    assert len(reads) == 1  # a run contracted once (a lost loop's second run reads its own)
    session = Session(validate(points, name="cloud.xyz"))
    session.metrics(0)
    assert len(reads) == 2
