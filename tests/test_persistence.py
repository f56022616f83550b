"""Pieces and loops of point clouds from the alpha complex."""
import numpy as np

from skelcore.persistence import persistence_summary, piece_counts
from skelcore.verdict import StabilityThresholds, count_loops, count_pieces


def ring(n=400, radius=1.0, centre=(0.0, 0.0, 0.0), seed=0):
    """A thin tube of points around a circle: evenly spread along it, jittered across."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    circle = np.column_stack([radius * np.cos(t), radius * np.sin(t), np.zeros(n)])
    return circle + 0.01 * rng.normal(size=(n, 3)) + centre


def test_a_ring_holds_one_loop_and_one_piece():
    summary = persistence_summary(ring(), unit=0.05)
    t = StabilityThresholds()
    assert count_loops(summary["loops"], t) == 1 and count_pieces(summary["pieces"], t) == 1
    birth, death = summary["loops"][0]
    assert birth < 2 and death > 30  # traced densely; its hole is the ring's diameter, 40 units


def test_two_rings_apart_are_two_pieces_and_a_stray_point_is_none():
    points = np.concatenate([ring(), ring(centre=(5.0, 0.0, 0.0), seed=1), [[2.5, 3.0, 0.0]]])
    summary = persistence_summary(points, unit=0.05)
    assert count_pieces(summary["pieces"], StabilityThresholds()) == 2
    assert count_loops(summary["loops"], StabilityThresholds()) == 2


def test_a_collapsed_cloud_has_one_piece_and_no_loop():
    summary = persistence_summary(np.zeros((50, 3)), unit=0.05)
    assert count_pieces(summary["pieces"], StabilityThresholds()) == 1 and summary["loops"] == []


def test_the_pieces_alone_are_those_of_the_complex():
    rng = np.random.default_rng(3)
    blobs = np.concatenate([rng.normal(size=(400, 3)) * 0.05, rng.normal(size=(300, 3)) * 0.05 + (0.4, 0, 0),
                            rng.normal(size=(5, 3)) * 0.05 + (3.0, 0, 0)])  # two pieces apart 3 to 7 units, a stray one
    clouds = [ring(), np.concatenate([ring(), ring(centre=(5.0, 0.0, 0.0), seed=1), [[2.5, 3.0, 0.0]]]),
              blobs, ring(n=5000), np.zeros((50, 3))]
    for points in clouds:
        summary = persistence_summary(points, unit=0.05)
        assert piece_counts(points, unit=0.05) == summary["pieces"]
    assert len(set(persistence_summary(blobs, unit=0.05)["pieces"].values())) > 1  # the gaps part them differently


def test_a_wheel_holds_all_sixteen_loops_between_its_spokes():
    """The 12 longest-lived loops were kept: a bicycle wheel's 16 read 12, and its right skeleton "unstable"."""
    rng = np.random.default_rng(0)
    hub = ring(500, radius=0.12)
    directions = [np.array([np.cos(a), np.sin(a), 0.0]) for a in np.linspace(0, 2 * np.pi, 16, endpoint=False)]
    spokes = [np.outer(0.12 + 0.88 * rng.random(300), direction) for direction in directions]
    wheel = np.concatenate([ring(4000), hub, *spokes])
    summary = persistence_summary(wheel, unit=0.02 * np.linalg.norm(np.ptp(wheel, axis=0)))
    assert count_loops(summary["loops"], StabilityThresholds()) == 16
