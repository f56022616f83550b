"""What the verdict's skeleton checks read of a run (skelcore.verdict): the skeleton's pieces and loops beside
those of the contracted cloud and of the input, lengths in multiples of the skeleton's sample radius."""
from __future__ import annotations

import numpy as np

from .persistence import persistence_summary, piece_counts
from .skeleton import Skeleton
from .step import IterationState


def skeleton_evidence(skeleton: Skeleton, state: IterationState, original: np.ndarray, source: dict | None = None,
                      cloud: dict | None = None) -> dict:
    """What the verdict's skeleton checks read: the skeleton's nodes (with those GLSkeleton's light graph left out
    of a straight stretch, which are no collapse), pieces and loops, and the pieces and loops
    of the contracted cloud and the pieces of the input, lengths in multiples of the skeleton's sample radius
    (only the contracted cloud's loops need a complex: the input's pieces come from piece_counts).
    source: {"pieces": piece_counts of `original` at that radius}, and cloud: persistence_summary of the
    state's points at that radius, when already known (see `cloud_evidence`)."""
    topology = skeleton.topology()
    cloud = cloud or persistence_summary(state.points, skeleton.radius)
    source = source or {"pieces": piece_counts(original, skeleton.radius)}
    nodes = skeleton.graph.number_of_nodes()
    return {"nodes": nodes, "nodes_with_dropped": nodes + skeleton.dropped, "components": topology["components"],
            "cycles": topology["cycles"], "cloud_pieces": cloud["pieces"], "cloud_loops": cloud["loops"],
            "input_pieces": source["pieces"]}


def cloud_evidence(state: IterationState, original: np.ndarray, radius: float) -> tuple[dict, dict]:
    """The parts of skeleton_evidence that need no skeleton, only its radius: (source, cloud) as it takes them."""
    return {"pieces": piece_counts(original, radius)}, persistence_summary(state.points, radius)
