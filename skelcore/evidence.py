"""What the verdict's skeleton checks read of a run (skelcore.verdict): the skeleton's pieces and loops beside
those of the contracted cloud and of the input, lengths in multiples of the skeleton's sample radius."""
from __future__ import annotations

import numpy as np

from .persistence import persistence_summary, piece_counts
from .skeleton import Skeleton
from .step import IterationState


def skeleton_evidence(skeleton: Skeleton, state: IterationState, original: np.ndarray, source: dict | None = None,
                      cloud: dict | None = None) -> dict:
    """What the verdict's skeleton checks read: the skeleton's nodes, pieces and loops, and the pieces and loops
    of the contracted cloud and the pieces of the input, lengths in multiples of the skeleton's sample radius
    (only the contracted cloud's loops need a complex: the input's pieces come from piece_counts).
    source: {"pieces": piece_counts of `original` at that radius}, and cloud: persistence_summary of the
    state's points at that radius, when already known (see `cloud_evidence`)."""
    topology = skeleton.topology()
    cloud = cloud or persistence_summary(state.points, skeleton.radius)
    source = source or {"pieces": piece_counts(original, skeleton.radius)}
    return {"nodes": skeleton.graph.number_of_nodes(), "spaced_nodes": spaced_nodes(skeleton),
            "components": topology["components"],
            "cycles": topology["cycles"], "cloud_pieces": cloud["pieces"], "cloud_loops": cloud["loops"],
            "input_pieces": source["pieces"]}


def spaced_nodes(skeleton: Skeleton) -> int:
    """The nodes the skeleton would hold at one per sample radius along its edges: its own, and one more for every
    further radius an edge spans. The graph step's nodes lie about a radius apart, but GLSkeleton's light graph
    draws a straight stretch as one edge (skelcore.refine.drop_collinear), so its own count says nothing of size."""
    lengths = np.array([length for _, _, length in skeleton.graph.edges(data="length")], dtype=float)
    extra = np.maximum(np.rint(lengths / skeleton.radius) - 1, 0).sum() if len(lengths) else 0
    return skeleton.graph.number_of_nodes() + int(extra)


def cloud_evidence(state: IterationState, original: np.ndarray, radius: float) -> tuple[dict, dict]:
    """The parts of skeleton_evidence that need no skeleton, only its radius: (source, cloud) as it takes them."""
    return {"pieces": piece_counts(original, radius)}, persistence_summary(state.points, radius)
