"""The inspector's session: one cloud, one contraction run kept as a history of iteration states, the
parameters, and the skeleton and metrics of each state, computed on demand and cached.

The run (step, tune, restart, load) is driven from one thread. Skeletons and metrics may be asked for
from another: each belongs to a `Run` (app.run), which a restart or a load replaces as a whole, so a result
computed for an old run never lands in the new one. Skeletons are cached per skeleton parameters; a
lock keeps the metrics, which build on each other in iteration order, to one thread at a time.
"""
from __future__ import annotations

import dataclasses
import threading
from pathlib import Path
from typing import Callable

import numpy as np

from skelcore import contraction, multires, pipeline, single_view
from skelcore.clean import clean, cleaned
from skelcore.api import Result
from skelcore.contraction import IterationState, record
from skelcore.errors import ParameterError
from skelcore.evidence import input_evidence, skeleton_evidence
from skelcore.io import Cloud
from skelcore.labels import check_label_weights, check_weights, weights_from_labels
from skelcore.metrics import IterationMetrics
from skelcore.persistence import persistence_summary
from skelcore.options import RunOptions
from skelcore.verdict import count_loops, run_verdict
from skelcore.params import ContractionParams
from skelcore.provisional import skeleton_is_provisional, state_curve_share
from skelcore.skeleton import Skeleton, SkeletonParams, beyond_solid_notes

from .run import Run
from .words import PARAMETER_LABELS, assignments, start_text, weights_text

LOG_LENGTH = 200


class Session:
    """label_weights: {label: contraction weight} for clouds with labels, applied on every (re)start.
    weights: explicit per-point weights of `cloud` (replaced by label weights once those are set, dropped on
    load). history: the states of a finished run on `cloud` (e.g. a skelcore.Result's) to open at.
    look_ahead: whether the inspector has the next iteration computed while the run waits for Step."""

    def __init__(self, cloud: Cloud, params: ContractionParams = ContractionParams(),
                 sample_radius: float = RunOptions.sample_radius, *, label_weights=None, weights=None,
                 history: list[IterationState] | None = None, point_budget: int | None = multires.POINT_BUDGET,
                 look_ahead: bool = True):
        self.sample_radius = sample_radius
        self.point_budget = point_budget  # larger clouds contract at reduced resolution (None or 0: never)
        self.looks_ahead = look_ahead
        self.log: list[str] = []
        self._lock = threading.Lock()  # the metrics
        self._engine = threading.Lock()  # the contraction generator: Step and the look-ahead
        self.label_weights = check_label_weights(label_weights)
        self._point_weights = None if weights is None else check_weights(weights, len(cloud.points))
        self._start(cloud if history else self._cleaned(cloud), params, history)

    # -- the run
    @property
    def cloud(self) -> Cloud:
        return self.run.cloud

    @property
    def history(self) -> list[IterationState]:
        return self.run.history

    @property
    def latest(self) -> IterationState:
        return self.run.history[-1]

    @property
    def finished(self) -> bool:
        return self.latest.termination is not None

    @property
    def ready_ahead(self) -> bool:
        """Whether the next step was computed ahead with the parameters in force (Step only has to take it)."""
        return self.run.ahead is not None and self._pending is None and not self._within_step

    @property
    def start_params(self) -> ContractionParams:
        return self.run.start_params

    @property
    def params(self) -> ContractionParams:
        """The parameters the next step will use."""
        return self._pending or self._engine_params

    def restart(self, params: ContractionParams | None = None) -> None:
        """Start the run again from iteration 0 (with new parameters when given)."""
        self._start(self.cloud, params or self.latest.params)

    def load(self, cloud: Cloud) -> str:
        """Start a run on a new cloud with the parameters last tuned, those waiting for a restart included (the
        panel's), else the run's (automatic k and W_L0 stay automatic). Returns, in words, those of them that
        differ from the defaults ("" when none do): a new object runs with them, which the person may not expect."""
        point_weights, self._point_weights = self._point_weights, None
        params = self._tuned or self.latest.params
        try:
            self._start(self._cleaned(cloud), params)
        except Exception:
            self._point_weights = point_weights
            raise
        for note in cloud.notes:  # what loading did (the notification that says it goes away)
            self.note(f"{Path(cloud.name).name}: {note}")
        defaults = ContractionParams()
        kept = [name for name in PARAMETER_LABELS if getattr(params, name) != getattr(defaults, name)]
        if not kept:
            return ""
        words = f"parameters {assignments(params, kept)} kept from before (defaults: {assignments(defaults, kept)})"
        self.note(words)
        return words

    def _cleaned(self, cloud: Cloud) -> Cloud:
        """The cloud as `skelcore run` contracts it: outliers and stray pieces out, denoised (its notes say
        so); explicit per-point weights follow the points kept."""
        if cloud.cleaning is not None:
            return cloud
        options = RunOptions().cleaning
        report = clean(cloud.points, options)
        if self._point_weights is not None:
            self._point_weights = self._point_weights[report.kept]
        return cleaned(cloud, options, report=report,
                       walls=multires.within_budget(len(report.kept), self.point_budget))

    def set_label_weights(self, label_weights) -> None:
        """Contraction weights per label, used from the next restart."""
        self.label_weights = check_label_weights(label_weights)
        self._point_weights = None
        self.note(f"label weights {weights_text(self.label_weights)}: applies on restart")

    def weights_for(self, cloud: Cloud) -> np.ndarray | None:
        """The per-point contraction weights a run on `cloud` uses."""
        if self._point_weights is not None:
            return self._point_weights
        if self.label_weights and cloud.labels is not None:
            return weights_from_labels(cloud.labels, self.label_weights)
        return None

    def _start(self, cloud: Cloud, params: ContractionParams, history: list[IterationState] | None = None) -> None:
        params = params.validated()
        weights = self.weights_for(cloud)
        if history:
            if history[-1].termination is None:
                raise ParameterError("a run to open must have ended (its last state carries a termination)")
            generator, states = None, list(history)
            read = reduction = None
        else:
            read = multires.contracted_cloud(cloud.points, self.point_budget)
            reduction = None if read is None else read.denoised(RunOptions().cleaning.denoise_neighbours)
            points = cloud.points if reduction is None else reduction.points
            reduced_weights = weights if reduction is None or weights is None else reduction.mean(weights)
            generator = contraction.contract(points, params, reduced_weights, stages=True)
            states = [next(generator)]  # the one-rings: an error here leaves the current run as it was
        with self._engine:  # no look-ahead is under way on the run it replaces
            self._generator, self._pending, self._within_step = generator, None, False
            self._engine_params = params  # those the generator steps with
            self._tuned = None  # the parameters last tuned, for a load (the run's own until then)
            self._live_note = self._restart_note = ""  # changes waiting for the next step, for a restart
            self.run = Run(cloud, params, states, weights=weights,
                           label_weights=dict(self.label_weights) if weights is not None and self._point_weights is None
                           else {})
            if generator is not None and self.point_budget == multires.POINT_BUDGET:
                # the metrics' inside test samples the surface by this read (a thinned cloud read no voxels)
                self.run.voxels = None if read is None or read.thinned else read
            if reduction is not None:
                self.run.reduction, self.run.reduced = reduction, states
                self.run.carrier = reduction.carrier(states[0].rings)
                self.run.history = [reduction.lift(states[0], self.run.carrier)]
                self.note(reduction.note())
            weighted = "" if weights is None else f", weights in [{weights.min():g}, {weights.max():g}]"
            self.note(f"start: {Path(cloud.name).name}, {len(cloud.points):,} points, {start_text(params)}{weighted}")

    def tune(self, params: ContractionParams) -> str:
        """Take the panel's parameters: live ones apply from the next step, the others on restart.
        Returns what changed, in words ("" when nothing did)."""
        params = self._tuned = params.validated()
        current, shown = self.params, self.latest.params
        live = dataclasses.replace(current, **{name: getattr(params, name) for name in current.to_dict()
                                               if name not in contraction.RESTART_FIELDS})
        changed = [name for name in current.to_dict() if getattr(live, name) != getattr(shown, name)]
        waiting = [name for name in contraction.RESTART_FIELDS if getattr(params, name) != getattr(current, name)]
        if changed and self.finished:  # no next step: only a restart can use them
            waiting, changed = waiting + changed, []
        elif live != current:  # a state computed ahead with `current` is computed again (look_ahead)
            self._pending = live
        self._live_note = changed and f"{assignments(live, changed)} from iteration {self.latest.iteration + 1}"
        ended = " (the run has ended)" if self.finished else ""
        self._restart_note = waiting and f"{assignments(params, waiting)} at restart{ended}"
        message = self.pending
        if message:
            self.note(f"tuned at iteration {self.latest.iteration}: {message}")
        return message

    @property
    def pending(self) -> str:
        """Parameter changes not used yet, in words ("" when none)."""
        return "; ".join(filter(None, (self._live_note, self._restart_note)))

    def step(self, paused: Callable[[], bool] = lambda: False) -> IterationState | None:
        """One iteration (retuned by gen.send when parameters changed); None when the run has ended, or
        when `paused()` turned true between two stages of the step: the next call resumes it there. A state
        computed ahead (look_ahead) with the parameters still in force is taken as it is."""
        if self.finished:
            return None
        with self._engine:
            run = self.run
            if self.ready_ahead:
                state, reduced = run.ahead, run.ahead_reduced
                run.ahead = run.ahead_reduced = None
            else:
                advanced = self._advance(paused)
                if advanced is None:
                    return None
                state, reduced = advanced
            self._live_note = ""
            if run.reduction is not None:
                record(run.reduced, reduced)
            record(run.history, state)
            self._forget_from(len(run.history))  # a run that ends on an earlier state drops the states after it
        if state.termination:
            self.note(f"ended at iteration {state.iteration}: {state.message}")
        return state

    def look_ahead(self, paused: Callable[[], bool] = lambda: False, skeleton: bool = False,
                   provisional: bool = False) -> bool:
        """Compute the next state before Step asks for it, with the parameters in force, and its metrics (and
        its skeleton: when `skeleton`, unless it would be provisional and `provisional` is off), so that Step
        only has to show them. The state is not part of the run until Step takes it; a parameter change
        meanwhile has it computed again (contraction.Redo). Stops between two stages when `paused()` turns
        true (the next call goes on from there) and then returns False; True once everything asked for is ready,
        or when the run has ended."""
        with self._engine:
            run = self.run
            if self.finished:
                return True
            if not self.ready_ahead:
                advanced = self._advance(paused)
                if advanced is None:
                    return False
                run.ahead, run.ahead_reduced = advanced
            ahead, index = run.ahead, len(run.history)
        if ahead.iteration <= run.history[-1].iteration:  # a rejected step: a state of the run again, measured as such
            return True
        if paused():
            return False
        self.metrics_upto(index, run)
        if skeleton:
            if paused():
                return False
            if provisional or not skeleton_is_provisional(ahead, state_curve_share(ahead, run.cloud)):
                self.skeleton(index, run)
        return True

    def _advance(self, paused: Callable[[], bool]) -> tuple[IterationState, IterationState] | None:
        """The generator's next state (lifted to every input point, and as contracted); None when paused within
        the step. A state computed ahead is redone when parameters changed after it was begun."""
        run = self.run
        while True:
            if self._within_step:
                state = next(self._generator)
            else:
                pending, self._pending = self._pending, None
                redo = run.ahead is not None
                self._discard_ahead()
                state = self._generator.send(contraction.Redo(pending) if redo else pending)  # send(None) is next()
                self._engine_params = pending or self._engine_params
            while state is None:  # between two stages of the step
                self._within_step = True
                if paused():
                    return None
                state = next(self._generator)
            self._within_step = False
            if self._pending is None:
                break
            run.ahead = run.ahead_reduced = state  # begun before the parameters changed: redone with them
        reduced = state
        if run.reduction is not None:
            state = run.reduction.lift(state, run.carrier)
        return state, reduced

    def _discard_ahead(self) -> None:
        """Forget the state computed ahead and what was derived from it (it took the next index)."""
        run = self.run
        if run.ahead is None:
            return
        self._forget_from(len(run.history))
        run.ahead = run.ahead_reduced = None

    def _forget_from(self, index: int) -> None:
        """Forget what was derived from the states at `index` and after (the state ahead's, or those of states
        the run dropped)."""
        run = self.run
        with self._lock:
            if run.metrics is not None:
                run.metrics.forget(index)
        for cache in (run.skeletons, run.evidence):
            for key in [key for key in list(cache) if key[0] >= index]:
                cache.pop(key, None)

    # -- derived data of history[index], cached per run
    def run_options(self, run: Run | None = None) -> RunOptions:
        """What `skelcore run` would be given for this run: the one owner of the skeleton parameters."""
        run = run or self.run
        return RunOptions(params=run.start_params, sample_radius=self.sample_radius,
                          label_weights=tuple(sorted(run.label_weights.items())))

    @property
    def skeleton_params(self) -> SkeletonParams:
        return self.run_options().skeleton_params()

    def set_sample_radius(self, radius: float) -> None:
        RunOptions(sample_radius=radius).skeleton_params()  # refuses a bad radius, keeping the old one
        self.sample_radius = radius
        self.note(f"skeleton sample radius {radius:g} of the diagonal")

    def skeleton(self, index: int, run: Run | None = None) -> Skeleton:
        run = run or self.run
        key = (index, self.run_options(run).skeleton_params())
        if key not in run.skeletons:
            state = run.state(index, reduced=True)
            kept = run.surface
            if kept is None or kept[0] is not state.rings or not np.array_equal(kept[1], state.point_ids):
                original = run.cloud.points if run.reduction is None else run.reduction.points
                inside = None if run.metrics is None else run.metrics.reference.inside  # none yet: the probe's own
                samples = run.cloud.surface if run.reduction is None else None
                kept = run.surface = (state.rings, state.point_ids,
                                      pipeline.original_surface(state, original, inside, samples,
                                                                run.cloud.loops_at_most))
            run.skeletons[key] = pipeline.skeleton_of_state(state, run.cloud.points, key[1], run.reduction, kept[2])
        return run.skeletons[key]

    def solid_loops(self, index: int, run: Run | None = None) -> int | None:
        """The loops through the run's solid (pipeline.solid_loops: the verdict's floor for its skeletons, and why
        `skelcore run` tries a run held inside), when the skeleton of history[index] may lack some; else None."""
        return self.solid_read(index, run).loops

    def solid_read(self, index: int, run: Run | None = None, contracted: dict | None = None) -> pipeline.SolidRead:
        """pipeline.solid_loops for the skeleton of history[index]; given `contracted` (the state's
        persistence_summary) also where the skeleton keeps more loops than the verdict counts in it."""
        run = run or self.run
        skeleton = self.skeleton(index, run)
        held = None if contracted is None else count_loops(contracted["loops"])
        key = (skeleton.topology()["cycles"], skeleton.radius, held)
        if key not in run.solid_loops:
            if run.metrics is None:  # its inside test comes with the metrics: asked again once they are made
                return pipeline.SolidRead(run.cloud.solid_loops, "")
            run.solid_loops[key] = pipeline.solid_loops(run.cloud, run.metrics.reference.inside, *key[:2],
                                                        contracted=None if contracted is None else contracted["loops"])
        return run.solid_loops[key]

    def metrics_upto(self, index: int, run: Run | None = None) -> list[IterationMetrics]:
        """The paper's metrics of history[0..index] (index len(history): the state ahead too), each computed
        once, in order."""
        run = run or self.run
        states = run.history if index < len(run.history) else [*run.history, run.state(index)]
        with self._lock:
            if run.metrics is None:
                run.metrics = pipeline.IterationMetricsCache(run.cloud, reduction=run.voxels)
            return [run.metrics.get(states, i) for i in range(index + 1)]

    def metrics(self, index: int, run: Run | None = None) -> IterationMetrics:
        return self.metrics_upto(index, run)[-1]

    def verdict(self, index: int, run: Run | None = None, with_skeleton: bool = False) -> dict:
        """The verdict on history[index]; with_skeleton: also its skeleton checks (computes the skeleton)."""
        run = run or self.run
        evidence = None
        if with_skeleton:
            key = (index, self.skeleton_params)
            if key not in run.evidence:
                skeleton = self.skeleton(index, run)
                if skeleton.gap not in run.input_topology:  # the same at every iteration: computed once
                    run.input_topology[skeleton.gap] = input_evidence(run.cloud.points, skeleton.gap)
                self.metrics_upto(index, run)  # a point cloud's solid is read from the metrics' inside test
                contracted = persistence_summary(run.history[index].points, skeleton.radius)
                solid = self.solid_read(index, run, contracted)
                run.evidence[key] = skeleton_evidence(skeleton, run.history[index], run.cloud.points,
                                                      run.input_topology[skeleton.gap], contracted, solid.loops,
                                                      solid_read=run.cloud.solid_loops is None,
                                                      solid_at_surface=solid.at_surface)
            evidence = run.evidence[key]
        return run_verdict(self.metrics_upto(index, run), evidence)

    def write_results(self, index: int, out_dir: Path) -> None:
        """The files of `skelcore run` (skeleton.json/.ply, contracted.ply, metrics.json, params.json)
        for the run up to history[index]."""
        run = self.run
        self.verdict(index, run, with_skeleton=True)  # the evidence the inspector judged by (a cloud's solid read)
        skeleton = self.skeleton(index, run)
        notes = single_view.with_note(run.cloud.notes, None if run.metrics is None else run.metrics.reference.inside)
        cloud = dataclasses.replace(run.cloud, name=Path(run.cloud.name).name,  # never the server's paths
                                    notes=notes + beyond_solid_notes(skeleton, run.cloud.loops_at_most is not None))
        Result(cloud, run.history[:index + 1], skeleton, self.metrics_upto(index, run),
               self.run_options(run), run.weights, reduction=run.reduction,
               evidence=run.evidence[(index, self.skeleton_params)]).save(out_dir)

    def note(self, line: str) -> None:
        self.log.append(line)
        del self.log[:-LOG_LENGTH]

