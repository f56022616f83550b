"""The whole pipeline for one input: load, contract, measure, extract the skeleton, write the results.

`run_pipeline` is what `skelcore run` and `skelcore batch` call; the inspector uses `skeleton_of_state` and
`IterationMetricsCache` on the states it already holds (and skelcore.results to write them).
"""
from __future__ import annotations

import dataclasses
from concurrent.futures import Future
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np

from . import cloud_topology, io, multires, single_view
from .clean import clean, cleaned
from .contraction import IterationState, contract, record
from .step import REJECTION_CAUSES
from .errors import ParameterError, SkelError, SolverError
from .evidence import cloud_evidence, skeleton_evidence
from .inside import InsideTest
from .loops import cloud_inside
from .metrics import NORMAL_CONVENTION, UNREAD, IterationMetrics, MetricsReference, Unread
from .normalise import object_diagonal
from .options import METRICS_K, RunOptions
from .params import ContractionParams
from .results import write_results
from .run_threads import Helpers, StageClock, made
from .skeleton import Skeleton, SkeletonParams, beyond_solid_notes, extract_skeleton
from .verdict import count_loops
from .surface import OriginalSurface


@dataclass
class RunResult:
    """What run_pipeline wrote and computed: the folder, the cloud, the states, the skeleton, metrics.json."""
    out_dir: Path
    cloud: io.Cloud
    states: list[IterationState]
    skeleton: Skeleton
    metrics: dict
    elapsed: float
    stages: dict = field(default_factory=dict)  # seconds per pipeline stage (load, clean, contract, ...)

    def summary_line(self) -> str:
        """One line: iterations, termination, skeleton size and topology, verdict, time, folder."""
        topology = self.skeleton.topology()
        final = self.states[-1]
        return (f"{self.cloud.name}: {final.iteration} iterations ({final.termination}), "
                f"skeleton {self.skeleton.graph.number_of_nodes()} nodes, {topology['cycles']} cycles, "
                f"{topology['junctions']} junctions, {topology['ends']} ends; "
                f"verdict {self.metrics['verdict']['label']}; {self.elapsed:.1f} s -> {self.out_dir}")


def skeleton_of_state(state: IterationState, original: np.ndarray, params: SkeletonParams,
                      reduction: multires.Reduction | None = None, surface: OriginalSurface | None = None) -> Skeleton:
    """Curve skeleton of a state; every input point takes the position of the point that represents it.
    With a multi-resolution `reduction`, `state` is the reduced cloud's (its rings name voxel centroids) and
    every input point of `original` gets its voxel's node. surface: original_surface of a state on the same
    rings, kept from an earlier skeleton of the run."""
    if reduction is not None:
        return reduction.skeleton_for_input(skeleton_of_state(state, reduction.points, params, surface=surface))
    return extract_skeleton(state.points[state.owner], original,
                            original_surface(state, original) if surface is None else surface, params)


def original_surface(state: IterationState, original: np.ndarray, inside: InsideTest | None = None,
                     samples: np.ndarray | None = None, genus: int | None = None) -> OriginalSurface:
    """What a state's skeleton reads of the original points and surface (skelcore.surface): the same for every
    state on the same rings. `original`: the points the state contracts (a reduction's, for a reduced run).
    inside: an inside test made ahead (the run's metrics', MetricsReference.inside, or loops.cloud_inside),
    whose oriented normals the false-loop probe takes when it samples the same points; samples: what the probe's
    inside test samples in place of `original` (io.Cloud.surface); genus: the loops its skeleton keeps at most,
    where known exactly (io.Cloud.loops_at_most)."""
    return OriginalSurface.of(original, state.point_ids[state.rings.triangles], inside, samples, genus)


class IterationMetricsCache:
    """The paper's metrics of each state of one run, computed on demand, once, in iteration order
    (each iteration's normals are oriented from the one before). A restarted run needs a new cache."""

    def __init__(self, cloud: io.Cloud, k: int = METRICS_K, seed: int = 0, convention: str = NORMAL_CONVENTION,
                 reduction: multires.Reduction | None | Unread = UNREAD, tree=None) -> None:
        """reduction: the cloud's voxel reduction at multires.POINT_BUDGET, None when the run read none (the
        inside test samples a large cloud's surface by it; by default it is read here). tree: a cKDTree over the
        cloud's points (or that reduction's), when the run has one (MetricsReference.from_points)."""
        self.reference = MetricsReference.from_points(cloud.points, cloud.faces, k=k, seed=seed, convention=convention,
                                                      reduction=reduction, tree=tree, surface=cloud.surface)
        self._metrics: list[IterationMetrics] = []

    def get(self, states: list[IterationState], index: int) -> IterationMetrics:
        """The metrics of states[index], computing those before it first."""
        while len(self._metrics) <= index:
            self.append(states[len(self._metrics)])
        return self._metrics[index]

    def append(self, state: IterationState) -> None:
        """Measure the state that follows the last one measured."""
        previous = self._metrics[-1] if self._metrics else None
        self._metrics.append(self.reference.evaluate(state.points, state.point_ids, previous=previous,
                                                     iteration=state.iteration))

    def forget(self, index: int) -> None:
        """Drop the metrics of states[index:] (a state that was replaced, and those after it)."""
        del self._metrics[index:]

    def all(self, states: list[IterationState]) -> list[IterationMetrics]:
        """The metrics of every state."""
        return [self.get(states, index) for index in range(len(states))]


def run_pipeline(input_path, out_dir, options: RunOptions = RunOptions(),
                 progress: Callable[[str], None] | None = None) -> RunResult:
    """Load INPUT, contract it to the end, and write the result files into OUT_DIR."""
    clock = StageClock()
    run = compute(input_path, options, progress, clock=clock)
    summary = write_results(out_dir, run.cloud, run.states, run.skeleton, run.metrics, options,
                            input_path=input_path, elapsed=clock.elapsed(), weights=run.weights,
                            reduction=run.reduction, evidence=run.evidence)
    clock.mark("write")
    return RunResult(Path(out_dir), run.cloud, run.states, run.skeleton, summary, clock.elapsed(), clock.stages)


def _read_ahead(surface: OriginalSurface, grid: Future | None, at_most: int | None = None) -> None:
    """Give `surface` the most loops its skeleton keeps: `at_most` when given, else the most its solid has from
    its grid read ahead (cloud_topology.read; None: not read; a failed read leaves the surface to read it, and to
    report the error, if its skeleton asks)."""
    if at_most is not None:
        surface.read_ahead(at_most)
    elif grid is not None and grid.exception() is None:
        surface.read_ahead(None if grid.result() is None else grid.result().most)


def _lift(reduction: multires.Reduction, reduced: list[IterationState]) -> list[IterationState]:
    """The states of a reduced run carried to every input point."""
    carrier = reduction.carrier(reduced[0].rings)
    return [reduction.lift(state, carrier) for state in reduced]


@dataclass
class Computed:
    """What a run computes, before anything is written."""
    cloud: io.Cloud
    states: list[IterationState]
    metrics: list[IterationMetrics]
    skeleton: Skeleton
    weights: np.ndarray | None  # the per-point contraction weights used (None: all 1)
    reduction: multires.Reduction | None = None  # the multi-resolution reduction (None: every point contracted)
    evidence: dict | None = None  # skeleton_evidence of the skeleton
    inside: InsideTest | None = None  # the original solid, as the metrics' boundedness reads it
    grid: cloud_topology.GridLoops | None = None  # the inside test's grid as read ahead for `solid_loops`


def compute(source, options: RunOptions = RunOptions(), progress: Callable[[str], None] | None = None, *,
            labels=None, weights=None, clock: StageClock | None = None) -> Computed:
    """The whole run on a file path or a validated Cloud: load (with the options' sampling and labels;
    `labels` overrides options.labels and may be an array), clean (unless the cloud was), contract to the
    end, the paper's metrics of every state, the skeleton of the last. `weights`: explicit per-point
    contraction weights of the cloud before cleaning, else those of options.label_weights. A cloud above
    options.point_budget is contracted at reduced resolution, every input point carried (skelcore.multires). A
    cloud whose skeleton keeps fewer loops than its solid has (a closed mesh's genus, or those a closed point
    cloud's inside test reads: skelcore.cloud_topology) is contracted again holding its points inside the solid
    (`_held_inside`). `clock` records the seconds of each stage."""
    clock = clock or StageClock()
    options.validated()  # bad parameters fail before any work
    if weights is not None and options.label_weights:
        raise ParameterError("parameter weights: give per-point weights or label weights, not both")
    if isinstance(source, io.Cloud):
        cloud = source
    else:
        cloud = io.load(source, sample=options.sample, voxel_size=options.voxel_size, max_points=options.max_points,
                        seed=options.seed, labels=options.labels if labels is None else labels,
                        drop_nonfinite=options.drop_nonfinite)
    clock.mark("load")
    weights = io.weights_of(source, cloud, weights)
    try:
        if cloud.cleaning is None:  # not cleaned yet; labels and explicit weights follow the points kept
            report = clean(cloud.points, options.cleaning)
            # the inside tests sample the points where no reduction's voxel centroids stand for them
            cloud = cleaned(cloud, options.cleaning, report=report,
                            walls=multires.within_budget(len(report.kept), options.point_budget))
            weights = None if weights is None else weights[report.kept]
        clock.mark("clean")
        for note in cloud.notes:
            _say(progress, f"{cloud.name}: {note}")
        weights = options.weights(cloud) if weights is None else weights
        computed = _contract_and_judge(cloud, options, weights, progress, clock)
        if computed.inside is not None and computed.inside.single_view:
            computed = _noted(computed, single_view.NOTE, progress)
        read = solid_loops(computed.cloud, computed.inside, computed.evidence["cycles"], computed.skeleton.radius,
                           computed.grid, computed.evidence["cloud_loops"])
        loops = read.loops
        clock.mark("solid loops")
        if loops is not None and computed.evidence["cycles"] < loops and options.hold_retry \
                and not options.params.hold_inside:
            computed = _held_inside(computed, options, progress, loops, read.words)
            clock.mark("hold inside")
        for note in beyond_solid_notes(computed.skeleton, cloud.loops_at_most is not None):
            computed = _noted(computed, note, progress)
        params = options.params
        for start, cap in params.starts_above_caps():
            computed = _noted(computed, f"{start}={getattr(params, start):g} is above {cap}={getattr(params, cap):g}: "
                                        f"the run started at the cap, where a larger {start} changes nothing", progress)
        if loops is not None and cloud.solid_loops is None:  # a closed cloud's read: the verdict's floor too
            computed = dataclasses.replace(computed, evidence={**computed.evidence, "input_loops": loops,
                                                               "input_loops_read": True,
                                                               "input_loops_at_surface": read.at_surface})
    except SkelError as error:
        raise named(error, cloud.name) from None
    return computed


class SolidRead(NamedTuple):
    """The loops through the solid a cloud bounds (`solid_loops`)."""
    loops: int | None  # None: no solid to go by, or nothing to read
    words: str  # whose loops they are
    at_surface: int | None = None  # a closed cloud's: its grid's plain count at the surface (cloud_topology.read)


def solid_loops(cloud: io.Cloud, inside: InsideTest | None, cycles: int, radius: float,
                grid: cloud_topology.GridLoops | None = None, contracted=None) -> SolidRead:
    """The loops through the solid a cloud bounds for a skeleton of `cycles` loops drawn at `radius`: a closed
    mesh's genus; else those its inside test (the metrics' MetricsReference.inside) reads when the cloud reads
    closed (skelcore.cloud_topology; `grid`: that test's read, when made ahead), read only where the test's plain
    count leaves room for a loop the skeleton lacks, or, given `contracted` (the persistence pairs of the
    contracted cloud's loops, the skeleton evidence's cloud_loops), for loops the skeleton keeps beyond those the
    verdict counts in that cloud (skelcore.verdict.count_loops), which the solid's may vouch for."""
    if cloud.solid_loops is not None:
        return SolidRead(cloud.solid_loops, "the mesh's solid (its genus)")
    if grid is None or grid.reach != radius:
        grid = None if inside is None else cloud_topology.read(inside, radius, ceiling=False)
    held = cycles if contracted is None else count_loops(contracted)
    if grid is None or grid.at_surface <= min(cycles, held):
        return SolidRead(None, "")
    return SolidRead(cloud_topology.solid_loops(grid.offset, radius),
                     "the solid the input bounds (as its inside test reads it)", grid.at_surface)


def _held_inside(plain: Computed, options: RunOptions, progress: Callable[[str], None] | None, wanted: int,
                 solid: str) -> Computed:
    """A run whose skeleton keeps fewer loops than the `wanted` loops through `solid` (in words: a closed mesh's
    genus, or a closed cloud's read), run again with the points held inside the solid (ContractionParams.hold_inside,
    skelcore.medial): that run when its skeleton keeps more of them, else `plain` (also when the second run fails:
    the first one is not lost); a note says which. The held run's loops beyond `wanted` are cut as those beyond a
    solid's are (SkeletonParams.cut_beyond_solid): `plain` lacks loops the solid has, and of the held run's more,
    those the solid holds at the skeleton's scale are the ones to keep."""
    cloud, kept = plain.cloud, plain.evidence["cycles"]
    try:
        held = _contract_and_judge(cloud, dataclasses.replace(options, params=options.params.replace(hold_inside=True)),
                                   plain.weights, progress, StageClock(), at_most=wanted)
    except SkelError as error:
        held, outcome = None, f"failed ({error}), so the first run is the result"
    else:
        again = held.evidence["cycles"]
        outcome = (f"keeps {again}, and is the result" if kept < again <= wanted else
                   f"keeps {again}, more than the solid has, so the first run is the result" if again > wanted else
                   f"keeps {again}, no more, so the first run is the result")
    better = held is not None and kept < held.evidence["cycles"] <= wanted
    loops = "loop" if wanted == 1 else "loops"
    note = (f"the skeleton keeps {kept} of the {wanted} {loops} through {solid}, so the "
            f"contraction was run again with the points held inside the solid (hold_inside): that run {outcome}")
    return _noted(dataclasses.replace(held if better else plain, cloud=cloud), note, progress)


def _noted(computed: Computed, note: str, progress: Callable[[str], None] | None) -> Computed:
    """`computed` with `note` said and added to its cloud's notes."""
    _say(progress, f"{computed.cloud.name}: {note}")
    return dataclasses.replace(computed, cloud=dataclasses.replace(computed.cloud, notes=[*computed.cloud.notes, note]))


def _contract_and_judge(cloud: io.Cloud, options: RunOptions, weights: np.ndarray | None,
                        progress: Callable[[str], None] | None, clock: StageClock,
                        at_most: int | None = None) -> Computed:
    """Contract a loaded, cleaned cloud to the end (reduced first when it is over options.point_budget), the
    paper's metrics of every state, the skeleton of the last and its evidence for the verdict. at_most: the most
    loops the skeleton keeps, in place of the most its solid has (with SkeletonParams.cut_beyond_solid)."""
    reduction = multires.contracted_cloud(cloud.points, options.point_budget)
    # The inside test samples a large surface, or one on scan lines, by the voxel reduction at POINT_BUDGET: the
    # run's read serves when it was made at that budget (its centroids as they are: the original surface, as the
    # inspector's metrics sample it), and so does its finding none (a thinned cloud found none: it is thinned
    # only then), so the lines are not read twice.
    samples = ((None if reduction is None or reduction.thinned else reduction)
               if options.point_budget == multires.POINT_BUDGET else UNREAD)
    reduction = None if reduction is None else reduction.denoised(options.cleaning.denoise_neighbours)
    with Helpers() as helpers:
        cache = helpers.measuring(IterationMetricsCache, cloud, options.metrics_k, options.seed,
                                  options.normal_convention, samples)
        ceiling = at_most is None and cloud.loops_at_most is None and options.skeleton_params().cut_beyond_solid
        # no genus: the loops a closed cloud's solid has are read (`solid_loops`; a held run is given its own)
        floor = at_most is None and cloud.solid_loops is None
        if reduction is None:
            radius = options.sample_radius * object_diagonal(cloud.points)  # the skeleton's (extract_skeleton)
            # the loops the solid has, at most (the skeleton's ceiling) and at least (the run's floor), read from the
            # metrics' inside test on the evidence thread while the contraction runs
            grid = helpers.judging(lambda: cloud_topology.read(cache.result().reference.inside, radius, ceiling)) \
                if ceiling or floor else None
            # each state is measured on the second core while the contraction goes on
            states = run_states(cloud, options.params, progress, weights,
                                lambda state: helpers.measuring(lambda: cache.result().append(state)))
            clock.mark("contract")
            surface = original_surface(states[-1], cloud.points, cache.result().reference.inside, cloud.surface,
                                       cloud.loops_at_most)
            _read_ahead(surface, grid if ceiling else None, at_most)
            evidence = helpers.judging(cloud_evidence, states[-1], cloud.points, radius, surface.gap_unit(radius))
            skeleton = skeleton_of_state(states[-1], cloud.points, options.skeleton_params(), surface=surface)
            clock.mark("skeleton")
        else:
            _say(progress, f"{cloud.name}: {reduction.note()}")
            # the metrics' inside test samples the centroids before denoising: the false-loop probe's own, of
            # the contracted points, is made on the second core while the contraction runs
            probe_inside = helpers.judging(cloud_inside, reduction.points, 0.0)
            radius = options.sample_radius * object_diagonal(reduction.points)  # the skeleton's (extract_skeleton)
            most = helpers.judging(lambda: cloud_topology.read(probe_inside.result(), radius)) if ceiling else None
            grid = helpers.judging(lambda: cloud_topology.read(cache.result().reference.inside, radius, False)) \
                if floor else None
            clock.mark("reduce")
            reduced = run_states(io.Cloud(points=reduction.points, name=cloud.name), options.params, progress,
                                 None if weights is None else reduction.mean(weights))
            clock.mark("contract")
            lifted = helpers.measuring(_lift, reduction, reduced)
            helpers.measuring(lambda: [cache.result().append(state) for state in lifted.result()])
            # a failure there is the probe's to report, if it ever needs that test
            surface = original_surface(reduced[-1], reduction.points,
                                       None if probe_inside.exception() else probe_inside.result(),
                                       genus=cloud.loops_at_most)
            _read_ahead(surface, most, at_most)
            evidence = helpers.judging(lambda: cloud_evidence(lifted.result()[-1], cloud.points, radius,
                                                              surface.gap_unit(radius)))
            skeleton = skeleton_of_state(reduced[-1], cloud.points, options.skeleton_params(), reduction, surface)
            clock.mark("skeleton")
            states = lifted.result()
            clock.mark("carry")
        helpers.wait()
        cache.result().forget(len(states))  # a run that ended on an earlier state drops the later ones
        metrics = cache.result().all(states)
        clock.mark("metrics")
        ahead = (radius, surface.gap_unit(radius)) == (skeleton.radius, skeleton.gap)
        source, cloud_parts = evidence.result() if ahead else (None, None)
        evidence = skeleton_evidence(skeleton, states[-1], cloud.points, source, cloud_parts, cloud.solid_loops)
        clock.mark("evidence")
        for note in surface.scale_notes(options.sample_radius):
            _say(progress, f"{cloud.name}: {note}")
    return Computed(cloud, states, metrics, skeleton, weights, reduction, evidence, cache.result().reference.inside,
                    made(grid))


def run_states(cloud: io.Cloud, params: ContractionParams, progress: Callable[[str], None] | None = None,
               weights: np.ndarray | None = None, new_state: Callable[[IterationState], object] | None = None
               ) -> list[IterationState]:
    """Contract a cloud to the end; its states, with a progress line per accepted iteration. new_state: called
    with each state as it joins the run (the input first; not the repeat a rejected step yields)."""
    states: list[IterationState] = []
    for state in contract(cloud.points, params, weights):
        if not record(states, state):
            continue
        if new_state is not None:
            new_state(state)
        if state.iteration > 0:
            seconds = sum(state.timings.values())
            _say(progress, f"iteration {state.iteration}: W_L={state.wl:.4g} ring ratio={state.ring_ratio:.4f} "
                           f"points={state.n_points} ({seconds:.2f} s)")
    final = states[-1]
    if final.iteration == 0:  # the first step was rejected: nothing contracted, so no skeleton or verdict to give
        reason = "; ".join(filter(None, [REJECTION_CAUSES.get(final.termination, final.termination), final.detail]))
        raise SolverError(f"the first contraction step failed ({reason}); nothing "
                          f"was contracted: check the per-point weights and the cloud's coordinates")
    _say(progress, f"stopped after iteration {final.iteration}: {final.message or final.termination}")
    return states


def named(error: SkelError, name: str) -> SkelError:
    """The error with the input's name in front of its message, unless the message names it already."""
    message = str(error)
    return error if name in message else type(error)(f"{name}: {message}")


def _say(progress: Callable[[str], None] | None, line: str) -> None:
    if progress is not None:
        progress(line)
