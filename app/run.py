"""One contraction run of the inspector's session: its states from iteration 0 and what was derived from them
(skeletons, their evidence, metrics, the multi-resolution reduction, the state computed ahead). A restart or a
load replaces the run as a whole, so a result computed for an old run never lands in the new one."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from skelcore import multires, pipeline
from skelcore.contraction import IterationState
from skelcore.io import Cloud
from skelcore.metrics import UNREAD, Unread
from skelcore.params import ContractionParams
from skelcore.skeleton import Skeleton, SkeletonParams


@dataclass(eq=False)
class Run:
    """One run from iteration 0: its states and what was derived from them."""
    cloud: Cloud
    start_params: ContractionParams
    history: list[IterationState]
    skeletons: dict[tuple[int, SkeletonParams], Skeleton] = field(default_factory=dict)
    evidence: dict[tuple[int, SkeletonParams], dict] = field(default_factory=dict)  # of each skeleton, for the verdict
    input_topology: dict[float, dict] = field(default_factory=dict)  # the input's, by skeleton gap unit: one per run
    # by the skeleton's loops and radius, and the loops the verdict counts in its contracted cloud (None: not asked)
    solid_loops: dict[tuple[int, float, int | None], pipeline.SolidRead] = field(default_factory=dict)
    metrics: pipeline.IterationMetricsCache | None = None  # built on first use
    weights: np.ndarray | None = None  # per-point contraction weights of the run (None: all 1)
    label_weights: dict[int, float] = field(default_factory=dict)  # that gave them, if any
    # Above the point budget the voxel-reduced cloud is contracted (skelcore.multires) and `history` holds its
    # states carried to every input point; `reduced` holds its own states, of which skeletons are made.
    reduction: multires.Reduction | None = None
    reduced: list[IterationState] = field(default_factory=list)
    carrier: object = None  # (n, m) sparse weights carrying the reduced cloud's points to the input's
    # The cloud's voxel reduction at multires.POINT_BUDGET as read at the start (None: it has none), which the
    # metrics' inside test samples; UNREAD for a run opened from a file
    voxels: multires.Reduction | None | Unread = UNREAD
    # (rings, point ids, skelcore.surface.OriginalSurface) of the last skeleton: the states on the same rings share it
    surface: tuple | None = None
    # The next state, computed before Step asks for it (Session.look_ahead), and its reduced-resolution original:
    # not part of the run until committed; its metrics and skeleton are cached under the index it will take.
    ahead: IterationState | None = None
    ahead_reduced: IterationState | None = None

    def state(self, index: int, reduced: bool = False) -> IterationState:
        """history[index] (reduced: the contracted cloud's own state), or the state ahead at index len(history)."""
        states = self.reduced if reduced and self.reduction is not None else self.history
        if index == len(self.history) and self.ahead is not None:
            return self.ahead_reduced if reduced and self.reduction is not None else self.ahead
        return states[index]
