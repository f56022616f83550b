"""The inspector's session: one cloud, one contraction run kept as a history of iteration states, the
parameters, and the skeleton and metrics of each state, computed on demand and cached.

The run (step, tune, restart, load) is driven from one thread. Skeletons and metrics may be asked for
from another: each belongs to a `Run`, which a restart or a load replaces as a whole, so a result
computed for an old run never lands in the new one. Skeletons are cached per skeleton parameters; a
lock keeps the metrics, which build on each other in iteration order, to one thread at a time.
"""
from __future__ import annotations

import dataclasses
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from skelcore import contraction, pipeline
from skelcore.contraction import IterationState, contract, record
from skelcore.io import Cloud
from skelcore.metrics import IterationMetrics, run_verdict
from skelcore.params import ContractionParams
from skelcore.skeleton import Skeleton, SkeletonParams

LOG_LENGTH = 200


@dataclass(eq=False)
class Run:
    """One run from iteration 0: its states and what was derived from them."""
    cloud: Cloud
    start_params: ContractionParams
    history: list[IterationState]
    skeletons: dict[tuple[int, SkeletonParams], Skeleton] = field(default_factory=dict)
    metrics: pipeline.IterationMetricsCache | None = None  # built on first use


class Session:
    def __init__(self, cloud: Cloud, params: ContractionParams = ContractionParams(),
                 skeleton_params: SkeletonParams = SkeletonParams()):
        self.skeleton_params = skeleton_params.validated()
        self.log: list[str] = []
        self._lock = threading.Lock()
        self._start(cloud, params)

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
    def start_params(self) -> ContractionParams:
        return self.run.start_params

    @property
    def params(self) -> ContractionParams:
        """The parameters the next step will use."""
        return self._pending or self.latest.params

    def restart(self, params: ContractionParams | None = None) -> None:
        """Start the run again from iteration 0 (with new parameters when given)."""
        self._start(self.cloud, params or self.latest.params)

    def load(self, cloud: Cloud) -> None:
        """Start a run on a new cloud with the current parameters (automatic k and W_L0 stay automatic)."""
        self._start(cloud, self.latest.params)

    def _start(self, cloud: Cloud, params: ContractionParams) -> None:
        params = params.validated()
        generator = contract(cloud.points, params, stages=True)
        first = next(generator)  # the one-rings: an error here leaves the current run as it was
        self._generator, self._pending, self._within_step = generator, None, False
        self.run = Run(cloud, params, [first])
        self.note(f"start: {Path(cloud.name).name}, {len(cloud.points):,} points, {_describe(params)}")

    def tune(self, params: ContractionParams) -> str:
        """Take the panel's parameters: live ones apply from the next step, the others on restart.
        Returns what changed, in words ("" when nothing did)."""
        params = params.validated()
        current = self.params
        live = dataclasses.replace(current, **{name: getattr(params, name) for name in current.to_dict()
                                               if name not in contraction.RESTART_FIELDS})
        changed = [name for name in current.to_dict() if getattr(live, name) != getattr(current, name)]
        waiting = [name for name in contraction.RESTART_FIELDS if getattr(params, name) != getattr(current, name)]
        parts = []
        if changed:
            self._pending = live
            parts.append(f"{_assignments(live, changed)} from iteration {self.latest.iteration + 1}")
        if waiting:
            parts.append(f"{_assignments(params, waiting)} on restart")
        message = "; ".join(parts)
        if message:
            self.note(f"tuned at iteration {self.latest.iteration}: {message}")
        return message

    def step(self, paused: Callable[[], bool] = lambda: False) -> IterationState | None:
        """One iteration (retuned by gen.send when parameters changed); None when the run has ended, or
        when `paused()` turned true between two stages of the step: the next call resumes it there."""
        if self.finished:
            return None
        if self._within_step:
            state = next(self._generator)
        else:
            pending, self._pending = self._pending, None
            state = self._generator.send(pending)  # send(None) is next()
        while state is None:  # between two stages of the step
            self._within_step = True
            if paused():
                return None
            state = next(self._generator)
        self._within_step = False
        record(self.run.history, state)
        if state.termination:
            self.note(f"ended at iteration {state.iteration}: {state.message}")
        return state

    # -- derived data of history[index], cached per run
    def set_skeleton_params(self, params: SkeletonParams) -> None:
        self.skeleton_params = params.validated()
        self.note(f"skeleton sample radius {params.sample_radius:g} of the diagonal")

    def skeleton(self, index: int, run: Run | None = None) -> Skeleton:
        run = run or self.run
        key = (index, self.skeleton_params)
        if key not in run.skeletons:
            run.skeletons[key] = pipeline.skeleton_of_state(run.history[index], run.cloud.points, key[1])
        return run.skeletons[key]

    def metrics_upto(self, index: int, run: Run | None = None) -> list[IterationMetrics]:
        """The paper's metrics of history[0..index], each computed once, in order."""
        run = run or self.run
        with self._lock:
            if run.metrics is None:
                run.metrics = pipeline.IterationMetricsCache(run.cloud)
            return [run.metrics.get(run.history, i) for i in range(index + 1)]

    def metrics(self, index: int, run: Run | None = None) -> IterationMetrics:
        return self.metrics_upto(index, run)[-1]

    def verdict(self, index: int, run: Run | None = None) -> dict:
        return run_verdict(self.metrics_upto(index, run))

    def write_results(self, index: int, out_dir: Path) -> None:
        """The files of `skelcore run` (skeleton.json/.ply, contracted.ply, metrics.json, params.json)
        for the run up to history[index]."""
        run = self.run
        options = pipeline.RunOptions(params=run.start_params, sample_radius=self.skeleton_params.sample_radius)
        pipeline.write_results(out_dir, run.cloud, run.history[:index + 1], self.skeleton(index, run),
                               self.metrics_upto(index, run), options)

    def note(self, line: str) -> None:
        self.log.append(line)
        del self.log[:-LOG_LENGTH]


def _assignments(params: ContractionParams, names: list[str]) -> str:
    return ", ".join(f"{name}={getattr(params, name)}" for name in names)


def _describe(params: ContractionParams) -> str:
    k = params.k or "auto"
    wl0 = "auto" if params.wl0 is None else f"{params.wl0:g}"
    return (f"method {params.method}, k {k}, W_L0 {wl0}, W_H0 {params.wh0:g}, s_L {params.sl:g}, "
            f"W_L cap {params.wl_max:g}, max iterations {params.max_iterations}, termination {params.termination:g}")


def bundled_assets(directory: Path | None = None) -> dict[str, Path]:
    """Shape files shipped in assets/, by file name."""
    from skelcore.io import FORMATS

    directory = directory or Path(__file__).resolve().parents[1] / "assets"
    if not directory.is_dir():
        return {}
    return {path.name: path for path in sorted(directory.iterdir())
            if path.is_file() and path.suffix.lower() in FORMATS}
