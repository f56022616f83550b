"""The whole pipeline for one input: load, contract, measure, extract the skeleton, write the results.

`run_pipeline` is what `skelcore run` and `skelcore batch` call; the inspector uses `skeleton_of_state`,
`IterationMetricsCache` and `write_results` on the states it already holds.
"""
from __future__ import annotations

import dataclasses
import errno
import json
import os
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from . import __version__, io, multires
from .clean import CleaningParams, clean, cleaned
from .curveness import skeleton_scale_share
from .contraction import TERMINATION_MESSAGES, IterationState, contract, record
from .errors import InputError, OutputError, ParameterError, SkelError
from .inside import InsideTest
from .labels import check_weights, weights_from_labels
from .metrics import NORMAL_CONVENTION, IterationMetrics, MetricsReference
from .params import ContractionParams, default_k
from .persistence import persistence_summary, piece_counts
from .skeleton import Skeleton, SkeletonParams, extract_skeleton
from .solver import backend
from .surface import OriginalSurface
from .verdict import run_verdict

METRICS_K = 30  # the paper's neighbourhood for PCA normals and curvature (see skelcore.metrics)
# A curve skeleton says something once the one-rings have shrunk to this share of their size at iteration 0
# (the ring-size ratio a_t); before that the graph joins points across holes the contraction has not opened.
RESULT_FILES = ("skeleton.json", "skeleton.ply", "contracted.ply", "metrics.json", "params.json")
EARLIER_RUN_FILES = ("done.json", "report.html")  # what `skelcore batch` adds to a run's folder


@dataclass(frozen=True)
class RunOptions:
    """Everything that shapes a run besides the input: contraction and skeleton parameters, sampling, labels."""
    params: ContractionParams = ContractionParams()
    sample_radius: float = SkeletonParams.sample_radius  # skeleton ball radius, fraction of the object's diagonal
    seed: int = 0
    sample: int | None = None  # mesh input: points sampled evenly over the surface
    voxel_size: float | None = None
    max_points: int = io.MAX_POINTS
    metrics_k: int = METRICS_K
    normal_convention: str = NORMAL_CONVENTION  # D_theta's normals (skelcore.metrics)
    cleaning: CleaningParams = CleaningParams()  # outliers and stray pieces removed before contraction
    labels: str | None = None  # label file or PLY vertex property; None: the PLY's label property, if any
    label_weights: tuple[tuple[int, float], ...] = ()  # (label, contraction weight) pairs (skelcore.labels)
    point_budget: int | None = multires.POINT_BUDGET  # larger clouds: multi-resolution (None or 0: never)

    def weights(self, cloud: io.Cloud) -> np.ndarray | None:
        """Per-point contraction weights from the cloud's labels and `label_weights` (None: none given)."""
        if not self.label_weights:
            return None
        if cloud.labels is None:
            raise InputError(f"{cloud.name}: label weights given but the input has no labels "
                             f"(a PLY label property or --labels FILE)")
        return weights_from_labels(cloud.labels, dict(self.label_weights))

    def skeleton_params(self) -> SkeletonParams:
        """The skeleton parameters of this run, validated."""
        # GLSkeleton's graph step drops collinear degree-2 nodes (Wen et al. 2024).
        return SkeletonParams(sample_radius=self.sample_radius,
                              drop_collinear=self.params.method == "glskeleton").validated()


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


def provisional_target(state: IterationState) -> float:
    """The curve-like share below which a state's skeleton is provisional: the share the contraction itself aims
    at (its params.curve_share; the owner's default when the run turned that aim off)."""
    return state.params.curve_share if state.params.curve_share > 0 else ContractionParams.curve_share


def skeleton_is_provisional(state: IterationState, share: float) -> bool:
    """True while the cloud is not curve-like enough for its curve skeleton to mean anything: fewer than
    provisional_target of its points are curve-like (`share`, from state_curve_share). Iteration 0 always is;
    a run's last state never is: its skeleton is the run's result."""
    if state.iteration == 0:
        return True
    return state.termination is None and share < provisional_target(state)


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


def original_surface(state: IterationState, original: np.ndarray, inside: InsideTest | None = None
                     ) -> OriginalSurface:
    """What a state's skeleton reads of the original points and surface (skelcore.surface): the same for every
    state on the same rings. `original`: the points the state contracts (a reduction's, for a reduced run).
    inside: the run's metrics' inside test (MetricsReference.inside), whose oriented normals the false-loop
    probe takes when it samples the same points."""
    return OriginalSurface.of(original, state.point_ids[state.rings.triangles], inside)


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
    return {"nodes": skeleton.graph.number_of_nodes(), "components": topology["components"],
            "cycles": topology["cycles"], "cloud_pieces": cloud["pieces"], "cloud_loops": cloud["loops"],
            "input_pieces": source["pieces"]}


def cloud_evidence(state: IterationState, original: np.ndarray, radius: float) -> tuple[dict, dict]:
    """The parts of skeleton_evidence that need no skeleton, only its radius: (source, cloud) as it takes them."""
    return {"pieces": piece_counts(original, radius)}, persistence_summary(state.points, radius)


class IterationMetricsCache:
    """The paper's metrics of each state of one run, computed on demand, once, in iteration order
    (each iteration's normals are oriented from the one before). A restarted run needs a new cache."""

    def __init__(self, cloud: io.Cloud, k: int = METRICS_K, seed: int = 0, convention: str = NORMAL_CONVENTION,
                 reduction: multires.Reduction | None = None, tree=None) -> None:
        """reduction: the cloud's voxel reduction at multires.POINT_BUDGET, when the run made it (the inside
        test samples a large cloud's surface by it). tree: a cKDTree over the cloud's points (or that
        reduction's), when the run has one (MetricsReference.from_points)."""
        self.reference = MetricsReference.from_points(cloud.points, cloud.faces, k=k, seed=seed, convention=convention,
                                                      reduction=reduction, tree=tree)
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


class StageClock:
    """Seconds per pipeline stage, in order."""

    def __init__(self) -> None:
        self.start = self.last = time.perf_counter()
        self.stages: dict[str, float] = {}

    def mark(self, stage: str) -> None:
        """Close `stage`: the seconds since the previous mark (or the start)."""
        now = time.perf_counter()
        self.stages[stage] = now - self.last
        self.last = now

    def elapsed(self) -> float:
        """Seconds since the clock started."""
        return time.perf_counter() - self.start


class _Helpers:
    """A run's two helper threads: one measures the states in order (the paper's metrics, after carrying a reduced
    run's states to every input point), the other computes the parts of the skeleton evidence that need only the
    last state. Their numpy, LAPACK, k-d tree and gudhi work releases the GIL, so they use the second core while
    the contraction and the skeleton's graph step (Python) run on the first. An error in a task is raised where
    its result is read, or by `wait`; leaving the block cancels what has not started."""

    def __enter__(self) -> "_Helpers":
        self._measure = ThreadPoolExecutor(1, thread_name_prefix="skelcore-metrics")
        self._judge = ThreadPoolExecutor(1, thread_name_prefix="skelcore-evidence")
        self._measuring: list[Future] = []
        return self

    def measuring(self, task: Callable, *args) -> Future:
        """Queue `task(*args)` behind the measuring tasks queued before it."""
        self._measuring.append(self._measure.submit(task, *args))
        return self._measuring[-1]

    def judging(self, task: Callable, *args) -> Future:
        """Run `task(*args)` on the evidence thread."""
        return self._judge.submit(task, *args)

    def wait(self) -> None:
        """Wait until every measuring task is done; the first error of one is raised."""
        for task in self._measuring:
            task.result()

    def __exit__(self, *exc) -> None:
        for pool in (self._measure, self._judge):
            pool.shutdown(wait=True, cancel_futures=True)


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


def compute(source, options: RunOptions = RunOptions(), progress: Callable[[str], None] | None = None, *,
            labels=None, weights=None, clock: StageClock | None = None) -> Computed:
    """The whole run on a file path or a validated Cloud: load (with the options' sampling and labels;
    `labels` overrides options.labels and may be an array), clean (unless the cloud was), contract to the
    end, the paper's metrics of every state, the skeleton of the last. `weights`: explicit per-point
    contraction weights of the cloud before cleaning, else those of options.label_weights. A cloud above
    options.point_budget is contracted at reduced resolution, every input point carried (skelcore.multires).
    `clock` records the seconds of each stage."""
    clock = clock or StageClock()
    options.params.validated()
    options.skeleton_params()  # bad parameters fail before any work
    if weights is not None and options.label_weights:
        raise ParameterError("parameter weights: give per-point weights or label weights, not both")
    if isinstance(source, io.Cloud):
        cloud = source
    else:
        cloud = io.load(source, sample=options.sample, voxel_size=options.voxel_size, max_points=options.max_points,
                        seed=options.seed, labels=options.labels if labels is None else labels)
    clock.mark("load")
    weights = None if weights is None else check_weights(weights, len(cloud.points))
    try:
        if cloud.cleaning is None:  # not cleaned yet; labels and explicit weights follow the points kept
            report = clean(cloud.points, options.cleaning)
            cloud = cleaned(cloud, options.cleaning, report=report)
            weights = None if weights is None else weights[report.kept]
        clock.mark("clean")
        for note in cloud.notes:
            _say(progress, f"{cloud.name}: {note}")
        weights = options.weights(cloud) if weights is None else weights
        reduction = multires.reduce_cloud(cloud.points, options.point_budget)
        # The inside test samples a large surface at POINT_BUDGET: the run's reduction serves when it is that one.
        samples = reduction if options.point_budget == multires.POINT_BUDGET else None
        with _Helpers() as helpers:
            cache = helpers.measuring(IterationMetricsCache, cloud, options.metrics_k, options.seed,
                                      options.normal_convention, samples)
            if reduction is None:
                # each state is measured on the second core while the contraction goes on
                states = run_states(cloud, options.params, progress, weights,
                                    lambda state: helpers.measuring(lambda: cache.result().append(state)))
                clock.mark("contract")
                surface = original_surface(states[-1], cloud.points, cache.result().reference.inside)
                radius = options.sample_radius * surface.diagonal  # the skeleton's (extract_skeleton)
                evidence = helpers.judging(cloud_evidence, states[-1], cloud.points, radius)
                skeleton = skeleton_of_state(states[-1], cloud.points, options.skeleton_params(), surface=surface)
                clock.mark("skeleton")
            else:
                _say(progress, f"{cloud.name}: {reduction.note()}")
                clock.mark("reduce")
                reduced = run_states(io.Cloud(points=reduction.points, name=cloud.name), options.params, progress,
                                     None if weights is None else reduction.mean(weights))
                clock.mark("contract")
                lifted = helpers.measuring(_lift, reduction, reduced)
                helpers.measuring(lambda: [cache.result().append(state) for state in lifted.result()])
                surface = original_surface(reduced[-1], reduction.points, cache.result().reference.inside)
                radius = options.sample_radius * surface.diagonal  # the skeleton's (extract_skeleton)
                evidence = helpers.judging(lambda: cloud_evidence(lifted.result()[-1], cloud.points, radius))
                skeleton = skeleton_of_state(reduced[-1], cloud.points, options.skeleton_params(), reduction, surface)
                clock.mark("skeleton")
                states = lifted.result()
                clock.mark("carry")
            helpers.wait()
            cache.result().forget(len(states))  # a run that ended on an earlier state drops the later ones
            metrics = cache.result().all(states)
            clock.mark("metrics")
            source, cloud_parts = evidence.result() if radius == skeleton.radius else (None, None)
            evidence = skeleton_evidence(skeleton, states[-1], cloud.points, source, cloud_parts)
            clock.mark("evidence")
    except SkelError as error:
        raise named(error, cloud.name) from None
    return Computed(cloud, states, metrics, skeleton, weights, reduction, evidence)


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
    _say(progress, f"stopped after iteration {final.iteration}: {final.message or final.termination}")
    return states


def state_curve_share(state: IterationState, cloud: io.Cloud) -> float:
    """The share of a state's points that are curve-like (skelcore.curveness) at the skeleton's default sample
    radius, a fraction of the input cloud's object diagonal (the skeleton's own scale, which the
    contraction's stop rule, skelcore.step.goes_on, and the verdict also use)."""
    return skeleton_scale_share(state.points, cloud.diagonal)


def metrics_document(cloud: io.Cloud, states: list[IterationState], metrics: list[IterationMetrics],
                     reduction: multires.Reduction | None = None, skeleton: dict | None = None) -> dict:
    """metrics.json: per-iteration engine figures and the paper's statistics, and the run's verdict (with the
    skeleton checks given the skeleton's evidence, see skeleton_evidence)."""
    iterations = []
    for state, measured in zip(states, metrics):
        iterations.append({
            "iteration": state.iteration, "n_points": state.n_points, "wl": state.wl,
            "wh_mean": float(np.mean(state.wh)), "wh_max": float(np.max(state.wh)),
            "ring_ratio": state.ring_ratio, "curve_share": measured.curve["curve_share"], "anchored": state.anchored,
            "timings": state.timings, **measured.to_dict(),
        })
    final = states[-1]
    return {"method": final.params.method, "n_points": len(cloud.points), "cleaning": cloud.cleaning,
            "iterations": iterations,
            "termination": final.termination,
            "termination_message": final.message or TERMINATION_MESSAGES.get(final.termination, ""),
            "multiresolution": None if reduction is None else reduction.describe(),
            "skeleton_evidence": skeleton, "verdict": run_verdict(metrics, skeleton)}


def params_document(cloud: io.Cloud, states: list[IterationState], options: RunOptions, input_path=None,
                    weights: np.ndarray | None = None) -> dict:
    """params.json: everything needed to reproduce the run, the resolved defaults included. `weights`: the
    run's per-point contraction weights; given through labels, the labels source and label weights say them,
    otherwise their values are listed."""
    params = states[0].params
    resolved = dataclasses.replace(params, k=params.k or default_k(len(cloud.points)), wl0=params.wl0 or states[0].wl)
    return {
        # without a path (the inspector's bundles) only the file's name: no server path leaves the server
        "input": str(Path(input_path).resolve()) if input_path is not None else Path(cloud.name).name,
        "contraction": resolved.to_dict(), "skeleton": options.skeleton_params().to_dict(),
        "seed": options.seed, "sample": options.sample, "voxel_size": options.voxel_size,
        "max_points": options.max_points, "metrics_k": options.metrics_k, "cleaning": options.cleaning.to_dict(),
        "normal_convention": options.normal_convention, "point_budget": options.point_budget,
        "retuned": [state.message for state in states if "retuned" in state.message],
        "weights": weights_document(weights, options),
        "skelcore_version": __version__, "solver": backend(),
    }


def weights_document(weights: np.ndarray | None, options: RunOptions) -> dict | None:
    """The contraction weights of a run for params.json (None: every weight 1)."""
    if weights is None:
        return None
    document = {"labels": options.labels or "the input's labels", "label_weights": dict(options.label_weights),
                "weighted_points": int((weights != 1).sum()), "min": float(weights.min()),
                "max": float(weights.max()), "mean": float(weights.mean())}
    if not options.label_weights:
        document.update(labels=None, values=weights.tolist())
    return document


def write_results(out_dir, cloud: io.Cloud, states: list[IterationState], skeleton: Skeleton,
                  metrics: list[IterationMetrics], options: RunOptions, *, input_path=None,
                  elapsed: float | None = None, weights: np.ndarray | None = None,
                  reduction: multires.Reduction | None = None, evidence: dict | None = None) -> dict:
    """Write the five result files, each atomically (a temporary file renamed into place). evidence: the final
    state's skeleton_evidence, when the caller has it already."""
    from .export import skeleton_document, write_points_ply, write_skeleton_ply

    out_dir = Path(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise InputError(f"{out_dir}: cannot create the output folder ({error.strerror})") from None
    final = states[-1]
    evidence = skeleton_evidence(skeleton, final, cloud.points) if evidence is None else evidence
    summary = metrics_document(cloud, states, metrics, reduction, evidence)
    if elapsed is not None:
        summary["elapsed_seconds"] = elapsed
    labels = None if cloud.labels is None else cloud.labels[final.point_ids]  # a labelled input: its labels too
    contracted, skeleton = final.points * cloud.scale, _at_scale(skeleton, cloud.scale)
    write_atomic(out_dir / "contracted.ply", lambda path: write_points_ply(path, contracted, labels=labels))
    write_atomic(out_dir / "skeleton.ply", lambda path: write_skeleton_ply(path, skeleton))
    # compact: its correspondence lists every input point, which an indented layout puts one per line through
    # json's pure-Python encoder (4x slower: 0.3 s instead of 0.08 s at 1M points)
    write_atomic(out_dir / "skeleton.json", lambda path: _write_json(path, skeleton_document(skeleton), indent=None))
    write_atomic(out_dir / "metrics.json", lambda path: _write_json(path, summary))
    write_atomic(out_dir / "params.json",
                 lambda path: _write_json(path, params_document(cloud, states, options, input_path, weights)))
    return summary


def named(error: SkelError, name: str) -> SkelError:
    """The error with the input's name in front of its message, unless the message names it already."""
    message = str(error)
    return error if name in message else type(error)(f"{name}: {message}")


def _at_scale(skeleton: Skeleton, scale: float) -> Skeleton:
    """The skeleton in the file's coordinates (io.Cloud.scale: not 1 only for extreme coordinates)."""
    if scale == 1.0:
        return skeleton
    graph = skeleton.graph.copy()
    for _, attrs in graph.nodes(data=True):
        attrs["pos"] = np.asarray(attrs["pos"]) * scale
    for _, _, attrs in graph.edges(data=True):
        attrs["length"] = attrs["length"] * scale
    return dataclasses.replace(skeleton, graph=graph, radius=skeleton.radius * scale)


def write_atomic(path: Path, write: Callable[[Path], None]) -> None:
    """write(temporary) then rename it to `path`: a failure (a full disk) leaves the file as it was and
    raises an OutputError naming it."""
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(temporary)
        os.replace(temporary, path)
    except OSError as error:
        reason = "the disk is full" if error.errno in (errno.ENOSPC, errno.EDQUOT) else error.strerror or "error"
        raise OutputError(f"{path}: cannot write ({reason}); the files written before it are kept") from None
    except SkelError as error:  # a writer's own message, about the temporary file
        raise OutputError(f"{str(error).replace(str(temporary), str(path))}; the files written before it "
                          f"are kept") from None
    finally:
        temporary.unlink(missing_ok=True)


def prepare_output(out_dir, force: bool = False) -> Path:
    """The output folder, created; one that already holds a run's results is refused, or with `force`
    emptied of them first (other files stay), so no file of an earlier run is left beside the new ones."""
    out_dir = Path(out_dir)
    earlier = [out_dir / name for name in (*RESULT_FILES, *EARLIER_RUN_FILES) if (out_dir / name).exists()]
    earlier += list(out_dir.glob(".*.tmp")) if out_dir.is_dir() else []
    if earlier and not force:
        raise OutputError(f"{out_dir}: already holds the results of a run ({earlier[0].name}, ...); "
                          f"choose another folder or pass --force to replace them")
    try:
        for path in earlier:
            path.unlink()
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise OutputError(f"{out_dir}: cannot prepare the output folder ({error.strerror})") from None
    return out_dir


def _write_json(path: Path, document: dict, indent: int | None = 1) -> None:
    path.write_text(json.dumps(document, indent=indent, default=_json_default))


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def _say(progress: Callable[[str], None] | None, line: str) -> None:
    if progress is not None:
        progress(line)
