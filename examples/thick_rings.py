"""Both methods on tori of growing tube radius: how far each skeleton lies from the true centre circle.

    python examples/thick_rings.py [--tubes 0.15 0.25 0.35 0.45 0.55 0.65] [--points 10000] [--seeds 0 1 2]

Each torus has ring radius 1 and the given tube radius; its surface is sampled evenly (skelcore.solids.sample_mesh)
and skeletonised with the defaults. Printed per tube radius and method: the mean Chamfer distance and the largest
Hausdorff distance to the centre circle over the draws (fractions of the circle's diagonal, skelcore.evaluate),
and in how many draws the skeleton is exactly one loop (no junction, no end); then GLSkeleton's Chamfer against
LBC's. The bench-quality shapes judge topology only, so this is where a loop kept but drawn off the axis shows.
"""
from __future__ import annotations

import argparse

import numpy as np

import skelcore
from skelcore.evaluate import evaluate, make_graph
from skelcore.solids import sample_mesh, solid_arrays, torus

METHODS = ("lbc", "glskeleton")


def torus_points(tube: float, points: int, seed: int) -> np.ndarray:
    return sample_mesh(*solid_arrays(torus(1.0, tube)), points, seed)[0]


def centre_circle(samples: int = 400):
    angle = np.linspace(0, 2 * np.pi, samples, endpoint=False)
    ring = np.arange(samples)
    return make_graph(np.c_[np.cos(angle), np.sin(angle), np.zeros(samples)], np.c_[ring, (ring + 1) % samples],
                      "centre circle")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tubes", type=float, nargs="+", default=[0.15, 0.25, 0.35, 0.45, 0.55, 0.65])
    parser.add_argument("--points", type=int, default=10_000)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    args = parser.parse_args()
    truth = centre_circle()
    for tube in args.tubes:
        figures = {method: [] for method in METHODS}
        for seed in args.seeds:
            cloud = torus_points(tube, args.points, seed)
            for method in METHODS:
                result = skelcore.skeletonize(cloud, method=method)
                found = evaluate(make_graph(result.nodes, result.edges, method), truth)
                figures[method].append((found["chamfer"], found["hausdorff"], found["topology"]["matches"]))
        cells = [f"{method}: Chamfer {100 * np.mean([f[0] for f in rows]):.2f}%, Hausdorff up to "
                 f"{100 * max(f[1] for f in rows):.1f}%, one clean loop {sum(f[2] for f in rows)}/{len(rows)}"
                 for method, rows in figures.items()]
        ratio = np.mean([f[0] for f in figures["glskeleton"]]) / np.mean([f[0] for f in figures["lbc"]])
        print(f"tube {tube:g}: " + " | ".join(cells) + f" | GLSkeleton / LBC {ratio:.1f}x", flush=True)


if __name__ == "__main__":
    main()
