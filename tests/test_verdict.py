"""The verdict: no verdict at iteration 0, the iteration named, plain values, skeleton checks, explanation."""
import numpy as np
import pytest

from skelcore.errors import InputError, ParameterError
from skelcore.verdict import (OFF_NOTE, StabilityThresholds, count_loops, count_pieces, explanation_markdown, features,
                              judge, piece_range, run_verdict)


# Fixed thresholds, so that these tests do not follow the study's calibration of the defaults.
T = StabilityThresholds(max_d_theta_peaks=1, max_delta_kappa_peaks=1, min_symmetry=0.8, d_theta_tolerance=0.1,
                        delta_kappa_tolerance=0.05, min_inside_share=0.9, shrink_tolerance=0.01, max_step_shrink=0.5,
                        min_spread_ratio=0.5, min_curve_share=0.8, loop_death=4.0)


def entry(d_mean=0.5, k_mean=0.0, peaks=1, symmetry=0.95, inside=1.0, growth=-0.1, spread=0.9, linear=0.95,
          iteration=3, d_peaks=None):
    stats = lambda mean, count: {"mean": mean, "peaks": {"count": count}, "symmetry": symmetry}
    return {"iteration": iteration, "d_theta": stats(d_mean, peaks if d_peaks is None else d_peaks),
            "delta_kappa": stats(k_mean, peaks),
            "boundedness": {"inside_share": inside, "growth": growth, "spread_ratio": spread},
            "curve": {"curve_share": linear}, "verdict": {"label": "stable"}}


def evidence(nodes=40, components=1, cycles=1, loops=((0.3, 25.0),), cloud_pieces=1, input_pieces=1):
    return {"nodes": nodes, "components": components, "cycles": cycles,
            "cloud_pieces": {"1": cloud_pieces, "2": cloud_pieces, "4": 1},
            "cloud_loops": [list(loop) for loop in loops],
            "input_pieces": {"1": input_pieces, "2": input_pieces, "4": 1}}


def test_iteration_zero_has_no_verdict_and_later_ones_name_their_iteration():
    assert judge(features(entry()), 0)["label"] is None
    verdict = judge(features(entry()), 4)
    assert verdict["label"] == "stable" and verdict["iteration"] == 4
    assert "No verdict" in explanation_markdown(judge(features(entry()), 0))


def test_an_iteration_that_has_barely_contracted_is_not_yet_converged_by_default():
    """A cloud whose normals have barely turned (mean D_theta 0.03, nearer its start 0 than its target 0.5)
    has not contracted, whatever else passes: seen on an 80k torus at iteration 2 with a ring ratio of 0.95."""
    verdict = judge(features(entry(d_mean=0.03, linear=0.0), evidence()), 2)
    assert verdict["label"] == "not yet converged"
    assert any(reason.startswith("mean D_theta: 0.03") for reason in verdict["reasons"])
    assert judge(features(entry(d_mean=0.3), evidence()), 2)["label"] == "stable"


def test_a_step_that_grows_the_spread_by_3_to_5_percent_still_counts_as_shrinking_by_default():
    """Right runs on bunnies and the elephant end on a step whose RMS spread grows 3-5%, and not by a fling (on the
    Stanford bunny the box shrinks): within the default tolerance; 6% is not."""
    assert judge(features(entry(growth=0.045), evidence()), 5)["label"] == "stable"
    verdict = judge(features(entry(growth=0.06), evidence()), 5)
    assert verdict["label"] == "unstable" and "spread change this step: +6.0% (at most +5%): fail" in verdict["reasons"]


def test_d_theta_peaks_are_shown_not_counted_by_default_and_delta_kappa_peaks_still_decide():
    """A drilled plate contracts within its own plane: its faces' normals keep their line and the outward sign
    splits them between D_theta 0 and 1, three peaks on a right skeleton (calibrated off on 2026-12-07); two
    delta_kappa peaks still make an iteration unstable."""
    verdict = judge(features(entry(d_peaks=3), evidence()), 5)
    rows = {c["name"]: c for c in verdict["criteria"]}
    assert verdict["label"] == "stable"
    assert rows["D_theta peaks"]["text"] == "D_theta peaks: 3 (for information only): not counted"
    assert rows["delta_kappa peaks"]["passed"] is True
    verdict = judge(features(entry(peaks=2, d_peaks=1), evidence()), 5)
    assert verdict["label"] == "unstable"
    assert verdict["reasons"] == ["delta_kappa peaks: 2 (at most 1 (2% rule)): fail"]


def test_a_drilled_plates_right_skeleton_is_stable_though_d_theta_shows_its_faces_and_rims_apart():
    import skelcore
    from skelcore.solids import sample_mesh, solid_mesh

    points, _ = sample_mesh(*solid_mesh("block_2_holes"), 10000, seed=0)
    result = skelcore.skeletonize(points)
    rows = {c["name"]: c for c in result.verdict["criteria"]}
    assert result.skeleton.topology()["cycles"] == 2
    peaks = result.metrics[-1].d_theta_stats["peaks"]
    # the faces' normals kept their line (D_theta 0 and 1), the rims' turned a right angle (0.5)
    assert peaks["count"] == 3 and peaks["positions"][0] < 0.1 < 0.4 < peaks["positions"][1] < 0.6 < 0.9 \
        < peaks["positions"][2]
    assert rows["D_theta peaks"]["passed"] is None and result.verdict["label"] == "stable"


def test_values_are_stated_plainly():
    verdict = judge(features(entry(d_mean=0.26)), 2, T)
    assert verdict["label"] == "not yet converged"
    assert "mean D_theta: 0.26 (target 0.5 within 0.1): fail" in verdict["reasons"]
    table = explanation_markdown(verdict)
    assert "| mean D_theta | 0.26 | target 0.5 within 0.1 | **fail** (not yet converged) |" in table
    assert table.startswith("**Iteration 2: not yet converged**")


@pytest.mark.parametrize("change, label", [
    ({"peaks": 2}, "unstable"), ({"d_peaks": 2}, "unstable"), ({"inside": 0.5}, "unstable"), ({"growth": 0.2}, "unstable"),
    ({"growth": -0.9}, "unstable"), ({"spread": 0.1}, "unstable"), ({"linear": 0.3}, "not yet converged"),
    ({"symmetry": 0.3}, "not yet converged"), ({"k_mean": 0.3}, "not yet converged"),
])
def test_each_criterion_decides(change, label):
    assert judge(features(entry(**change)), 2, T)["label"] == label


def test_one_step_is_never_stable():
    # A thin ring is curve-like and small after any single step: everything else passes, the steps do not.
    verdict = judge(features(entry(), evidence()), 1, T)
    assert verdict["label"] == "not yet converged"
    assert verdict["reasons"] == ["contraction steps taken: 1 (at least 2): fail"]
    assert "| contraction steps taken | 1 | at least 2 | **fail** (not yet converged) |" \
        in explanation_markdown(verdict)
    assert "- *contraction steps taken*: the paper's stability is a trend" in explanation_markdown(verdict)
    assert judge(features(entry(), evidence()), 2, T)["label"] == "stable"
    assert judge(features(entry(), evidence()), 2, StabilityThresholds(**{**T.__dict__, "min_steps": 3}))["label"] \
        == "not yet converged"
    with pytest.raises(ParameterError, match="min_steps"):
        StabilityThresholds(min_steps=0).validated()


def test_curve_share_is_stated_as_a_share():
    verdict = judge(features(entry(linear=0.3)), 4, T)
    assert "curve-like share of the cloud: 30% (at least 80%): fail" in verdict["reasons"]


@pytest.mark.parametrize("change", [
    {"nodes": 2, "cycles": 0, "loops": ()},  # collapsed
    {"components": 2},  # disconnected
    {"cycles": 0},  # a loop the contracted cloud holds, lost
    {"loops": ()},  # a loop the cloud does not hold, invented
    {"input_pieces": 2},  # the input has two pieces, the skeleton one
])
def test_skeleton_checks_make_wrong_skeletons_unstable(change):
    assert judge(features(entry(), evidence()), 3, T)["label"] == "stable"
    verdict = judge(features(entry(), evidence(**change)), 3, T)
    assert verdict["label"] == "unstable", verdict["reasons"]


def test_a_skeleton_with_fewer_loops_than_a_closed_meshs_solid_is_unstable_though_the_cloud_agrees():
    """A tall pipe's bore is pulled onto its axis: the contracted cloud holds no loop, and the skeleton agrees
    with it, but the mesh's genus says the solid has one."""
    closed_shut = evidence(cycles=0, loops=())
    assert judge(features(entry(), closed_shut), 3, T)["label"] == "stable"  # a point cloud: nothing to tell
    verdict = judge(features(entry(), {**closed_shut, "input_loops": 1}), 3, T)
    assert verdict["label"] == "unstable"
    assert ("skeleton loops: 0 (as many as the contracted cloud holds (0) or, where more, the mesh's genus (1)): "
            "fail") in verdict["reasons"]
    assert judge(features(entry(), {**evidence(), "input_loops": 1}), 3, T)["label"] == "stable"
    # more loops than the genus are the contracted cloud's to judge, as before
    assert judge(features(entry(), {**evidence(), "input_loops": 0}), 3, T)["label"] == "stable"


def test_a_skeleton_cut_to_its_solids_loops_is_not_held_to_the_false_loops_of_its_contracted_cloud():
    """A hinge's wedge leaves the contracted cloud a loop the mesh's solid has not: the skeleton, cut to the genus
    (SkeletonParams.cut_beyond_solid), keeps none, and that is not a skeleton that lost a loop. Uncut, the same
    count fails, as does a cut skeleton that keeps fewer than the genus. A point cloud's skeleton cut to what its
    inside test reads passes the same way."""
    wedged = {**evidence(cycles=0), "input_loops": 0}
    assert "skeleton loops: 0 (as many as the contracted cloud holds (1) or, where more, the mesh's genus (0)): " \
           "fail" in judge(features(entry(), wedged), 3, T)["reasons"]
    verdict = judge(features(entry(), {**wedged, "cut_beyond_solid": 1}), 3, T)
    assert verdict["label"] == "stable"
    assert verdict["criteria"][-1]["text"] == ("skeleton loops: 0 (as many as the contracted cloud holds (1), but "
                                               "for those cut beyond the mesh's genus (0)): pass")
    lost = {**evidence(cycles=0, loops=((0.3, 25.0), (0.3, 25.0))), "input_loops": 1, "cut_beyond_solid": 1}
    assert judge(features(entry(), lost), 3, T)["label"] == "unstable"
    # a point cloud's skeleton cut to the most loops its inside test reads (no genus): said so, and passed
    read = judge(features(entry(), {**evidence(cycles=0), "cut_beyond_solid": 1}), 3, T)
    assert read["label"] == "stable"
    assert read["criteria"][-1]["text"] == ("skeleton loops: 0 (as many as the contracted cloud holds (1), but for "
                                            "those cut beyond what its solid holds as its inside test reads it (0)): "
                                            "pass")


def test_a_straight_stretch_drawn_as_one_edge_has_not_collapsed():
    """GLSkeleton draws a rod as one edge between its ends: the collapse check counts the nodes its light graph
    left out of that straight stretch, not only the two it drew."""
    rod = evidence(nodes=2, cycles=0, loops=())
    verdict = judge(features(entry(), {**rod, "nodes_with_dropped": 30}), 3, T)
    assert verdict["label"] == "stable", verdict["reasons"]
    assert "skeleton nodes: 2 drawn of 30 (at least 3): pass" in [c["text"] for c in verdict["criteria"]]
    collapsed = judge(features(entry(), {**rod, "nodes_with_dropped": 2}), 3, T)
    assert "skeleton nodes: 2 (at least 3): fail" in collapsed["reasons"]


def test_counts_of_pieces_and_loops():
    t = StabilityThresholds(piece_gap=2.0, loop_birth=2.0, loop_death=4.0)
    pieces = {"1": 5, "1.5": 3, "2": 2, "3": 1}
    assert count_pieces(pieces, t) == 2
    assert count_pieces(pieces, StabilityThresholds(piece_gap=2.5)) == 2
    assert count_pieces(pieces, StabilityThresholds(piece_gap=0.5)) == 5
    assert count_loops([[0.3, 25.0], [0.2, 0.5], [12.0, 20.0]], t) == 1
    assert count_loops([], t) == 0


def test_pieces_parted_by_a_gap_under_two_radii_may_stay_apart():
    # a chain of three links whose surfaces pass 1.5 radii apart: one piece fewer at 2 radii, all three at 1.5
    chain = {"1": 3, "1.5": 3, "2": 2, "3": 1}
    assert piece_range(chain, T) == (2, 3)
    assert piece_range({"1": 1, "1.5": 2, "2": 2}, T) == (2, 2)  # strays under 1% dropped at the narrowest gap
    kept_apart = judge(features(entry(), {**evidence(components=3, cloud_pieces=3), "input_pieces": chain}), 3, T)
    assert kept_apart["label"] == "stable", kept_apart["reasons"]
    assert ("skeleton pieces: 3 (as many as the contracted cloud (3) and the input (2 to 3)): pass"
            in [c["text"] for c in kept_apart["criteria"]])
    # a skeleton split beyond what even the narrowest gap parts, or joined across a gap over two radii, is not
    for components in (1, 4):
        verdict = judge(features(entry(), {**evidence(components=components), "input_pieces": chain,
                                           "cloud_pieces": chain}), 3, T)
        assert verdict["label"] == "unstable"
        assert (f"skeleton pieces: {components} (as many as the contracted cloud (2 to 3) and the input (2 to 3)): "
                "fail") in verdict["reasons"]


def test_run_verdict_judges_the_last_iteration():
    history = [entry(iteration=0), entry(d_mean=0.1, iteration=1), entry(iteration=2)]
    history[0]["verdict"] = {"label": None}
    verdict = run_verdict(history, evidence(), T)
    assert verdict["label"] == "stable" and verdict["iteration"] == 2
    assert [i["iteration"] for i in verdict["iterations"]] == [0, 1, 2]
    assert run_verdict(history[:1])["label"] is None
    with pytest.raises(InputError):
        run_verdict([])
    with pytest.raises(InputError, match="iterations"):
        run_verdict([{"d_theta": {}}])


def test_thresholds_are_checked():
    with pytest.raises(ParameterError, match="min_spread_ratio"):
        StabilityThresholds(min_spread_ratio=1.5).validated()
    with pytest.raises(ParameterError):
        StabilityThresholds(piece_gap=np.nan).validated()


def test_a_criterion_at_its_loosest_is_shown_not_counted_and_decides_nothing():
    loose = StabilityThresholds(**{**T.__dict__, "d_theta_tolerance": 0.5, "min_symmetry": 0.0, "max_step_shrink": 1.0})
    verdict = judge(features(entry(d_mean=0.04, symmetry=0.1, growth=-0.99)), 4, loose)
    rows = {c["name"]: c for c in verdict["criteria"]}
    assert rows["mean D_theta"]["passed"] is None and rows["mean D_theta"]["value"] == "0.04"
    assert rows["mean D_theta"]["threshold"] == "target 0.5; for information only"
    assert rows["D_theta symmetry"]["text"] == "D_theta symmetry: 0.10 (for information only): not counted"
    assert rows["spread change this step"]["threshold"] == "at most +1%" and rows["spread change this step"]["passed"]
    table = explanation_markdown(verdict)
    assert "| mean D_theta | 0.04 | target 0.5; for information only | not counted |" in table
    # why such a row does not count, said once under the table in words a new reader follows (not "off" and "n/a")
    assert table.count(OFF_NOTE) == 1 and "does not count in the verdict" in OFF_NOTE
    assert "off (" not in table and "n/a" not in table
    assert verdict["label"] == "stable"  # what would fail is off
    assert judge(features(entry(d_mean=0.04, growth=0.05)), 4, loose)["reasons"] == [
        "spread change this step: +5.0% (at most +1%): fail"]


def test_loops_the_contracted_cloud_cannot_count_are_held_to_the_solids():
    """A loop the contracted cloud traces only with a gap over loop_birth radii, or round a hole under loop_death
    radii, is not in its count: a skeleton that keeps it passes when the solid's unambiguous count has it (a
    closed mesh's genus, or a closed cloud's read whose grid has no other loop at the surface), and fails when it
    keeps more than the solid has, or nothing vouches (a read among noise's pinholes: the floor only)."""
    small = evidence(cycles=2, loops=((0.3, 3.0), (2.7, 12.0)))  # a small hole, and one traced with a wide gap
    assert count_loops(small["cloud_loops"], T) == 0
    unbacked = judge(features(entry(), small), 3, T)
    assert unbacked["label"] == "unstable"
    assert "skeleton loops: 2 (as many as the contracted cloud holds (0)): fail" in unbacked["reasons"]
    read = {**small, "input_loops": 2, "input_loops_read": True, "input_loops_at_surface": 2}
    verdict = judge(features(entry(), read), 3, T)
    assert verdict["label"] == "stable"
    assert verdict["criteria"][-1]["text"] == ("skeleton loops: 2 (as many as the contracted cloud holds (0) or, where "
                                               "more, its solid (2, read from its inside test)): pass")
    pinholes = judge(features(entry(), {**read, "input_loops_at_surface": 5}), 3, T)
    assert pinholes["label"] == "unstable"
    assert pinholes["criteria"][-1]["text"] == ("skeleton loops: 2 (as many as the contracted cloud holds (0), and no "
                                                "fewer than its solid holds (2, read from its inside test)): fail")
    assert judge(features(entry(), {**small, "input_loops": 2}), 3, T)["label"] == "stable"  # a mesh's genus
    for solid in (1, 3):  # one loop beyond the solid's, or one short of it
        assert judge(features(entry(), {**small, "input_loops": solid}), 3, T)["label"] == "unstable"
