"""Semantic LBC on a tree: label the trunk by a simple rule, contract with and without a trunk weight, compare.

    python examples/semantic_tree.py [--input ../shared/reference/cloudcontr_tree_small_pointcloud.off]
                                     [--weight 10] [--out /tmp/semantic_tree]

The rule (z is up): a point is trunk when it lies in the lowest TRUNK_HEIGHT of the tree's height and within
TRUNK_RADIUS of that height (horizontally) of the axis through the centroid of the lowest 5% of the height.
Writes OUT/tree_labelled.ply (xyz and a `label` property: 1 trunk, 0 rest; `skelcore run OUT/tree_labelled.ply
--label-weight 1=10` repeats the weighted run from the command line) and the result folders OUT/unweighted and
OUT/weighted, and prints a table of figures for both runs.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import networkx as nx
import numpy as np

import skelcore
from skelcore.export import write_points_ply

TREE = Path(__file__).resolve().parents[1].parent / "shared" / "reference" / "cloudcontr_tree_small_pointcloud.off"
TRUNK_HEIGHT = 0.25  # share of the tree's height, from the ground
TRUNK_RADIUS = 0.10  # share of the tree's height
SLICES = 10  # horizontal slices of the trunk for its cross-section radius


def trunk_labels(points: np.ndarray) -> np.ndarray:
    """1 for trunk points, 0 for the rest (the rule of the module docstring)."""
    z = points[:, 2]
    height = np.ptp(z)
    base = points[z < z.min() + 0.05 * height, :2].mean(axis=0)
    near_axis = np.linalg.norm(points[:, :2] - base, axis=1) < TRUNK_RADIUS * height
    return ((z < z.min() + TRUNK_HEIGHT * height) & near_axis).astype(np.int64)


def cross_section_radius(points: np.ndarray, heights: np.ndarray) -> float:
    """Mean over horizontal slices of the trunk of the RMS horizontal distance to the slice's centroid."""
    edges = np.linspace(heights.min(), heights.max(), SLICES + 1)
    radii = []
    for low, high in zip(edges[:-1], edges[1:]):
        inside = points[(heights >= low) & (heights <= high), :2]
        if len(inside) > 2:
            radii.append(np.sqrt(((inside - inside.mean(axis=0)) ** 2).sum(axis=1).mean()))
    return float(np.mean(radii))


def figures(result: skelcore.Result) -> dict:
    original = result.cloud.points  # the points contracted (cleaning may have dropped some)
    trunk = result.cloud.labels == 1
    first = result.states[1]
    moved = np.linalg.norm(first.points[first.owner] - original, axis=1)
    final = result.states[-1].points[result.states[-1].owner]
    nodes = np.unique(result.correspondence[trunk])
    sub = result.graph.subgraph(nodes)
    degrees = np.array([result.graph.degree(n) for n in nodes])
    diagonal = np.linalg.norm(np.ptp(original, axis=0))
    return {
        "iterations": result.states[-1].iteration,
        "trunk: moved in step 1 (% diag)": 100 * moved[trunk].mean() / diagonal,
        "rest: moved in step 1 (% diag)": 100 * moved[~trunk].mean() / diagonal,
        "trunk cross-section radius after (% of before)":
            100 * cross_section_radius(final[trunk], original[trunk, 2]) / cross_section_radius(original[trunk], original[trunk, 2]),
        "rest: RMS distance to its skeleton node (% diag)":
            100 * np.sqrt((np.linalg.norm(final[~trunk] - result.nodes[result.correspondence[~trunk]], axis=1) ** 2).mean()) / diagonal,
        "skeleton nodes": result.graph.number_of_nodes(),
        "skeleton junctions / ends / cycles": "{junctions} / {ends} / {cycles}".format(**result.topology),
        "trunk: skeleton nodes (junctions among them)": f"{len(nodes)} ({int((degrees >= 3).sum())})",
        "trunk: skeleton pieces": nx.number_connected_components(sub) if len(nodes) else 0,
        "verdict": result.verdict["label"],
        "seconds": result.elapsed,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--input", type=Path, default=TREE)
    parser.add_argument("--weight", type=float, default=10.0, help="trunk weight (pc-skeletor's SLBC default: 10)")
    parser.add_argument("--out", type=Path, default=Path("/tmp/semantic_tree"))
    args = parser.parse_args(argv)
    cloud = skelcore.load(args.input)
    labels = trunk_labels(cloud.points)
    trunk = labels == 1
    args.out.mkdir(parents=True, exist_ok=True)
    write_points_ply(args.out / "tree_labelled.ply", cloud.points, labels=labels)
    print(f"{args.input.name}: {len(labels):,} points, {trunk.sum():,} labelled trunk ({trunk.mean():.1%})")
    rows = {}
    for name, label_weights in (("unweighted", None), ("weighted", {1: args.weight})):
        result = skelcore.skeletonize(cloud, labels=labels, label_weights=label_weights)
        result.save(args.out / name, force=True)  # this example's own results of an earlier run
        rows[name] = figures(result)
        print(f"{name}: {'; '.join(result.cloud.notes) or 'nothing removed'}")
    print(f"| figure | without weights | trunk weight {args.weight:g} |\n|---|---|---|")
    for key in rows["unweighted"]:
        cells = [f"{row[key]:.2f}" if isinstance(row[key], float) else str(row[key]) for row in rows.values()]
        print(f"| {key} | {' | '.join(cells)} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
