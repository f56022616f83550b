"""Holding a contraction inside the original solid: shrinking-ball medial samples, points put on them, and a run
on a closed mesh whose skeleton lost loops through the solid tried again with the hold."""
import json

import numpy as np
import pytest
import trimesh

from skelcore.medial import MedialHold, shrinking_ball_centres


def _sphere(n=2000):
    golden = np.pi * (3 - np.sqrt(5))
    z = 1 - 2 * (np.arange(n) + 0.5) / n
    ring = np.sqrt(1 - z ** 2)
    points = np.c_[ring * np.cos(golden * np.arange(n)), ring * np.sin(golden * np.arange(n)), z]
    return points, points.copy()


def test_a_spheres_balls_close_on_its_centre_and_a_slabs_on_its_middle():
    points, outward = _sphere()
    centres, radii = shrinking_ball_centres(points, outward)
    assert np.linalg.norm(centres, axis=1).max() < 0.05 and np.allclose(radii, 1.0, atol=0.05)
    grid = np.stack(np.meshgrid(np.linspace(-2, 2, 41), np.linspace(-2, 2, 41)), -1).reshape(-1, 2)
    slab = np.r_[np.c_[grid, np.full(len(grid), 0.25)], np.c_[grid, np.full(len(grid), -0.25)]]
    normals = np.r_[np.tile([0.0, 0.0, 1.0], (len(grid), 1)), np.tile([0.0, 0.0, -1.0], (len(grid), 1))]
    centres, radii = shrinking_ball_centres(slab, normals)
    assert np.abs(centres[:, 2]).max() < 0.02 and np.allclose(radii, 0.25, atol=0.02)


def test_a_ball_on_an_open_sheet_never_closes():
    grid = np.stack(np.meshgrid(np.linspace(-1, 1, 21), np.linspace(-1, 1, 21)), -1).reshape(-1, 2)
    sheet = np.c_[grid, np.zeros(len(grid))]
    centres, radii = shrinking_ball_centres(sheet, np.tile([0.0, 0.0, 1.0], (len(sheet), 1)))
    assert np.isnan(radii).all() and np.isnan(centres).all()


def test_points_outside_a_torus_go_onto_its_medial_samples_and_those_inside_stay():
    torus = trimesh.creation.torus(1.0, 0.3)
    points = trimesh.sample.sample_surface_even(torus, 4000, seed=0)[0]
    hold = MedialHold.of_cloud(points, float(np.linalg.norm(np.ptp(points, axis=0))))
    # the medial samples of a round tube lie on its core circle
    core = np.abs(np.hypot(hold.centres[:, 0], hold.centres[:, 1]) - 1.0)
    assert np.median(core) < 0.05 and np.median(np.abs(hold.centres[:, 2])) < 0.05
    inside = np.array([[1.0, 0.0, 0.0], [0.0, -1.1, 0.1]])
    outside = np.array([[0.0, 0.0, 0.0], [0.3, 0.2, 0.0], [2.0, 0.0, 0.0]])
    held, moved = hold.hold(np.r_[inside, outside])
    assert moved == 3
    assert np.array_equal(held[:2], inside)
    assert np.allclose(np.linalg.norm(held[2:] - hold.centres[hold.tree.query(outside)[1]], axis=1), 0)


def _tall_pipe():
    import manifold3d as m3d

    from skelcore.solids import solid_arrays

    solid = (m3d.Manifold.cylinder(2.0, 1.0, 1.0, 64, True) - m3d.Manifold.cylinder(3.0, 0.5, 0.5, 64, True))
    return trimesh.Trimesh(*solid_arrays(solid))


@pytest.mark.parametrize("method", ["lbc", "glskeleton"])
def test_a_tall_pipes_loop_closed_by_the_contraction_is_kept_by_holding_its_points_inside(method, tmp_path):
    """A pipe twice as tall as its bore is wide: plain contraction pulls its wall onto the axis (no loop); the mesh's
    genus says the solid has one, so the run is made again with the points held inside, and that run keeps it."""
    import skelcore

    pipe = _tall_pipe()
    result = skelcore.skeletonize(pipe, method, point_budget=None, hold_inside=None)  # None: unset
    assert result.cloud.solid_loops == 1
    assert result.topology["cycles"] == 1 and result.states[-1].params.hold_inside  # the retry's run
    assert any("keeps 0 of the 1 loop through the mesh's solid" in note and "and is the result" in note
               for note in result.cloud.notes)
    folder = result.save(tmp_path / method)
    assert any("and is the result" in note for note in json.loads((folder / "metrics.json").read_text())["notes"])
    # the held run's points stay in the material: none lies in the bore
    radial = np.hypot(*result.states[-1].points[:, :2].T)
    assert np.mean(radial < 0.45) < 0.01


def test_the_flag_reaches_params_json_and_no_hold_inside_leaves_a_cloud_as_contracted(tmp_path):
    from skelcore.cli import main

    pipe = _tall_pipe()
    np.savetxt(tmp_path / "pipe.xyz", trimesh.sample.sample_surface_even(pipe, 6000, seed=0)[0])
    assert main(["run", str(tmp_path / "pipe.xyz"), "--out", str(tmp_path / "cloud"), "--quiet",
                 "--no-hold-inside"]) == 0
    assert not json.loads((tmp_path / "cloud" / "params.json").read_text())["contraction"]["hold_inside"]
    metrics = json.loads((tmp_path / "cloud" / "metrics.json").read_text())
    assert metrics["skeleton_evidence"]["cycles"] == 0 and metrics["skeleton_evidence"]["input_loops"] == 1
    # the loop the points' solid holds is the verdict's floor, as a mesh's genus is
    loops = next(c for c in metrics["verdict"]["criteria"] if c["name"] == "skeleton loops")
    assert loops["passed"] is False and "or, where more, its solid (1, read from its inside test)" in loops["threshold"]
    assert main(["run", str(tmp_path / "pipe.xyz"), "--out", str(tmp_path / "held"), "--quiet", "--hold-inside"]) == 0
    params = json.loads((tmp_path / "held" / "params.json").read_text())
    assert params["contraction"]["hold_inside"]


def test_hold_inside_chosen_either_way_decides_and_nothing_is_run_again(tmp_path, capsys):
    """`--no-hold-inside` (the API's hold_inside=False) means no hold at all: the pipe keeps the plain run's skeleton
    and no note; `--hold-inside` holds from the first run, with no second one either."""
    import skelcore
    from skelcore.cli import main

    pipe = _tall_pipe()
    plain = skelcore.skeletonize(pipe, "glskeleton", hold_inside=False)
    assert plain.topology["cycles"] == 0 and not plain.states[-1].params.hold_inside
    assert not any("hold_inside" in note for note in plain.cloud.notes)
    pipe.export(tmp_path / "pipe.stl")
    for flag, held in (("--no-hold-inside", False), ("--hold-inside", True)):
        out = tmp_path / flag
        assert main(["run", str(tmp_path / "pipe.stl"), "--out", str(out), "--method", "glskeleton", flag]) == 0
        assert "run again" not in capsys.readouterr().out
        assert json.loads((out / "params.json").read_text())["contraction"]["hold_inside"] is held
        assert not any("run again" in note for note in json.loads((out / "metrics.json").read_text())["notes"])


def test_a_second_run_that_fails_leaves_the_first_as_the_result(monkeypatch):
    import skelcore
    from skelcore.errors import SolverError
    from skelcore.step import RunStart

    def broken(self):
        raise SolverError("the medial surface broke")

    monkeypatch.setattr(RunStart, "medial", property(broken))
    result = skelcore.skeletonize(_tall_pipe(), "lbc")
    assert result.topology["cycles"] == 0 and not result.states[-1].params.hold_inside
    assert any("that run failed (" in note and "the medial surface broke" in note
               and "so the first run is the result" in note for note in result.cloud.notes)
