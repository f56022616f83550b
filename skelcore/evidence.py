"""What the verdict's skeleton checks read of a run (skelcore.verdict): the skeleton's pieces and loops beside
those of the contracted cloud and of the input, lengths in multiples of the skeleton's sample radius (the
input's in multiples of its gap unit, Skeleton.gap: a sparse cloud's spacing where larger), and the loops
through the solid a closed mesh input bounds (io.Cloud.solid_loops: its genus, exact from its faces)."""
from __future__ import annotations

import numpy as np

from .persistence import persistence_summary, piece_counts
from .skeleton import Skeleton
from .step import IterationState


def skeleton_evidence(skeleton: Skeleton, state: IterationState, original: np.ndarray, source: dict | None = None,
                      cloud: dict | None = None, solid_loops: int | None = None, solid_read: bool = False,
                      solid_at_surface: int | None = None) -> dict:
    """What the verdict's skeleton checks read: the skeleton's nodes (with those GLSkeleton's light graph left out
    of a straight stretch, which are no collapse), pieces and loops, and the pieces and loops
    of the contracted cloud and the pieces of the input, lengths in multiples of the skeleton's sample radius
    and of its gap unit (only the contracted cloud's loops need a complex: the input's pieces come from
    piece_counts). source: input_evidence of `original` at the gap unit, and cloud: persistence_summary of the
    state's points at the radius, when already known (see `cloud_evidence`). solid_loops: the loops through the
    input's solid, the skeleton's floor: a closed mesh's genus (io.Cloud.solid_loops), or with solid_read those
    a closed cloud's inside test reads (skelcore.cloud_topology), and solid_at_surface its grid's plain count at
    the surface; None: no solid known."""
    topology = skeleton.topology()
    cloud = cloud or persistence_summary(state.points, skeleton.radius)
    source = source or input_evidence(original, skeleton.gap)
    nodes = skeleton.graph.number_of_nodes()
    return {"nodes": nodes, "nodes_with_dropped": nodes + skeleton.dropped, "components": topology["components"],
            "cycles": topology["cycles"], "cloud_pieces": cloud["pieces"], "cloud_loops": cloud["loops"],
            "input_pieces": source["pieces"], "input_loops": solid_loops,
            "input_loops_read": bool(solid_read and solid_loops is not None),
            "input_loops_at_surface": solid_at_surface, "cut_beyond_solid": skeleton.beyond_solid}


def cloud_evidence(state: IterationState, original: np.ndarray, radius: float, gap: float) -> tuple[dict, dict]:
    """The parts of skeleton_evidence that need no skeleton, only its radius and gap unit: (source, cloud) as it
    takes them."""
    return input_evidence(original, gap), persistence_summary(state.points, radius)


def input_evidence(original: np.ndarray, gap: float) -> dict:
    """What the skeleton checks read of the input: {"pieces": piece_counts at the skeleton's gap unit}. The
    same at every iteration of a run."""
    return {"pieces": piece_counts(original, gap)}
