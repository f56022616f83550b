"""`skelcore study`: the verdict's criteria measured against ground truth over a grid of runs.

Inputs: the synthetic shapes (skelcore.shapes, known centrelines and topology) and the real-shape
benchmark (skelcore.solids, known loops and pieces); each at several seeds and in scan-like variants
(skelcore.perturb). Settings range from good to deliberately bad (SETTINGS). Every run records each iteration's
statistics under both normal conventions, the skeleton evidence of its last iteration and the truth:
topology exact, and Chamfer/Hausdorff where a centreline exists. Runs are appended to OUT/runs.jsonl as
they finish, so a killed study resumes where it stopped; skelcore.study_analysis turns them into the
tables, the page and the calibrated thresholds.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

from .clean import clean
from .errors import ParameterError
from .metrics import NORMAL_CONVENTIONS, MetricsReference
from .params import CleaningParams, ContractionParams, is_integer
from .paths import writable_folder

STUDY_POINTS = 3000  # points per cloud of the study unless asked otherwise
# name -> (changes to ContractionParams, W_L0 multiplier of the automatic W_L0)
SETTINGS = {
    "default": ({}, None),
    "wl0 x0.1": ({}, 0.1),
    "wl0 x10": ({}, 10.0),
    "wl0 x100": ({}, 100.0),
    "sl 1.5": ({"sl": 1.5}, None),
    "sl 10": ({"sl": 10.0}, None),
    "stop after 1": ({"max_iterations": 1}, None),
    "stop after 2": ({"max_iterations": 2}, None),
    "glskeleton": ({"method": "glskeleton"}, None),
}
PERTURBED_SETTINGS = ("default", "glskeleton")  # run on the scan-like variants; clean clouds get every setting
STUDY_VARIANTS = ("noise_1", "outliers_2", "density_30")  # of skelcore.perturb.VARIANTS, after the clean cloud
CHAMFER_RIGHT = 0.01  # a right skeleton: topology exact and Chamfer <= this share of the diagonal
RUNS_FILE = "runs.jsonl"


@dataclass(frozen=True)
class StudyInput:
    """One cloud of the study: a shape in one variant at one seed, with what its skeleton should be."""
    shape: str
    source: str  # "synthetic" or the benchmark shape's source
    variant: str
    seed: int
    points: np.ndarray
    truth: dict  # {"components", "cycles"} and, for synthetic shapes, the centreline and full topology

    @property
    def key(self) -> str:
        """shape|variant|seed: the run's identity in runs.jsonl, with the setting."""
        return f"{self.shape}|{self.variant}|{self.seed}"


def study_inputs(points: int = STUDY_POINTS, seeds=(0,), benchmark: bool = True, shapes=None) -> Iterator[StudyInput]:
    """Every (shape, variant, seed) of the study."""
    from .shapes import SHAPES, make_shape
    from .solids import benchmark_shapes

    for name in [n for n in shapes or SHAPES if n in SHAPES]:
        for seed in seeds:
            shape = make_shape(name, points, seed=seed)
            for variant, cloud in _variants(shape.points, seed):
                yield StudyInput(name, "synthetic", variant, seed, cloud, _shape_truth(shape))
    if not benchmark:
        return
    for seed in seeds:
        for shape in benchmark_shapes(points=points, seed=seed):
            if shapes and shape.name not in shapes:
                continue
            truth = {"components": int(shape.components), "cycles": int(shape.cycles)}
            for variant, cloud in _variants(shape.points, seed):
                yield StudyInput(shape.name, str(shape.source), variant, seed, cloud, truth)


def _variants(points: np.ndarray, seed: int) -> list[tuple[str, np.ndarray]]:
    """[(variant, points)]: the clean cloud, then each of STUDY_VARIANTS."""
    from .perturb import perturb

    return [("clean", points)] + [(name, perturb(points, name, seed=seed)) for name in STUDY_VARIANTS]


def _shape_truth(shape) -> dict:
    return {**shape.topology, "nodes": shape.nodes.tolist(), "edges": shape.edges.tolist()}


def run_one(item: StudyInput, setting: str, auto_wl0: float | None = None, cache: dict | None = None) -> dict:
    """One run of the grid: contraction, every iteration's statistics under both conventions, the skeleton
    of the last iteration, its evidence, and the truth. `cache` keeps what the runs of one input share."""
    from .contraction import run_contraction
    from .evaluate import evaluate, make_graph
    from .evidence import skeleton_evidence
    from .options import METRICS_K, RunOptions
    from .pipeline import skeleton_of_state

    cache = {} if cache is None else cache
    if "points" not in cache:  # cleaned as `skelcore run` cleans its input
        cache["points"] = item.points[clean(item.points, CleaningParams()).kept]
    points = cache["points"]
    changes, multiplier = SETTINGS[setting]
    params = ContractionParams(**changes)
    if multiplier is not None:
        params = params.replace(wl0=multiplier * auto_wl0)
    started = time.perf_counter()
    record = {"shape": item.shape, "source": item.source, "variant": item.variant, "seed": item.seed,
              "setting": setting, "points": len(item.points), "cleaned_points": len(points)}
    try:
        states = run_contraction(points, params)
    except Exception as error:  # a failed run is a finding of the study, not its end
        return {**record, "error": f"{type(error).__name__}: {error}"}
    record.update(termination=states[-1].termination, iterations=states[-1].iteration, wl0=states[0].wl)
    conventions = {}
    for convention in NORMAL_CONVENTIONS:
        if convention not in cache:
            cache[convention] = MetricsReference.from_points(points, k=METRICS_K, convention=convention)
        reference = cache[convention]
        previous, entries = None, []
        for state in states:
            previous = reference.evaluate(state.points, state.point_ids, previous=previous, iteration=state.iteration)
            entries.append(_statistics(previous.to_dict()))
        conventions[convention] = entries
    record["conventions"] = conventions
    skeleton_params = RunOptions(params=params).skeleton_params()
    skeleton = skeleton_of_state(states[-1], points, skeleton_params)
    record["evidence"] = skeleton_evidence(skeleton, states[-1], points, cache.get(("input", skeleton.gap)))
    cache[("input", skeleton.gap)] = {"pieces": record["evidence"]["input_pieces"]}
    record["truth"] = _truth(skeleton, item, evaluate, make_graph, record["evidence"]["nodes_with_dropped"])
    record["seconds"] = time.perf_counter() - started
    return record


def _statistics(entry: dict) -> dict:
    """The figures of one iteration the study keeps (histograms left out)."""
    kept = {}
    for key in ("d_theta", "delta_kappa"):
        stats = entry[key]
        kept[key] = {name: stats[name] for name in ("mean", "median", "std", "skewness", "kurtosis", "symmetry",
                                                    "unimodality", "n_undefined")}
        kept[key]["peaks"] = {name: stats["peaks"][name] for name in ("count", "positions")}
    kept["boundedness"] = entry["boundedness"]
    kept["curve"] = entry["curve"]
    return kept


def _truth(skeleton, item: StudyInput, evaluate, make_graph, graph_nodes: int) -> dict:
    """What is right about a run; graph_nodes: its skeleton's nodes with those GLSkeleton's light graph left out
    (a collapse leaves few)."""
    topology = skeleton.topology()
    nodes = skeleton.graph.number_of_nodes()
    truth = {"skeleton": {**topology, "nodes": nodes}, "chamfer": None, "hausdorff": None,
             "collapsed": graph_nodes < 3 or skeleton.graph.number_of_edges() == 0,
             "disconnected": topology["components"] > item.truth["components"]}
    if "nodes" in item.truth and nodes:
        scored = evaluate(make_graph(skeleton.nodes_array(), skeleton.edges_array(), "skeleton"),
                          make_graph(item.truth["nodes"], item.truth["edges"], item.shape))
        truth.update(chamfer=scored["chamfer"], hausdorff=scored["hausdorff"],
                     topology_exact=bool(scored["topology"]["matches"]))
    else:
        truth["topology_exact"] = all(topology[key] == item.truth[key] for key in ("components", "cycles"))
    truth["right"] = bool(truth["topology_exact"] and not truth["collapsed"]
                          and (truth["chamfer"] is None or truth["chamfer"] <= CHAMFER_RIGHT))
    return truth


def _job(args) -> list[dict]:
    item, settings = args
    cache = {}
    records = [run_one(item, "default", cache=cache)]
    auto = records[0].get("wl0")
    for setting in settings:
        if setting != "default":
            records.append(run_one(item, setting, auto, cache))
    return records


def run_study(out_dir, points: int = STUDY_POINTS, seeds=(0,), settings=tuple(SETTINGS), shapes=None,
              benchmark: bool = True, jobs: int = 1, progress: Callable[[str], None] | None = print) -> list[dict]:
    """Run the grid into OUT/runs.jsonl (resuming), then analyse it (skelcore.study_analysis)."""
    if not is_integer(jobs) or jobs < 1:
        raise ParameterError(f"study: jobs={jobs!r} must be a whole number of worker processes, at least 1")
    unknown = [s for s in settings if s not in SETTINGS]
    if unknown:
        raise ParameterError(f"settings {unknown}: unknown (choose from {', '.join(SETTINGS)})")
    out_dir = writable_folder(out_dir, "study folder")
    out_dir.mkdir(parents=True, exist_ok=True)
    runs_path = out_dir / RUNS_FILE
    done = load_runs(runs_path)
    seen = {_record_key(r) for r in done}
    inputs = list(study_inputs(points, seeds, benchmark, shapes))
    missing = sorted(set(shapes or ()) - {item.shape for item in inputs})
    if missing:
        raise ParameterError(f"shapes {missing}: unknown (synthetic: skelcore shapes; benchmark: skelcore "
                             f"bench-quality{'' if benchmark else '; --no-benchmark leaves those out'})")
    todo = [(item, [s for s in settings if f"{item.key}|{s}" not in seen
                    and (item.variant == "clean" or s in PERTURBED_SETTINGS)])
            for item in inputs]
    todo = [(item, left) for item, left in todo if left]
    if progress:
        progress(f"study: {len(done)} runs done, {sum(len(left) for _, left in todo)} to go")
    with runs_path.open("a") as sink:
        def keep(records):
            for record in records:
                if f"{record['shape']}|{record['variant']}|{record['seed']}|{record['setting']}" in seen:
                    continue
                sink.write(json.dumps(record) + "\n")
                done.append(record)
            sink.flush()
            if progress:
                last = records[0]
                progress(f"{len(done)} runs: {last['shape']} {last['variant']} seed {last['seed']}")
        if jobs > 1:
            from concurrent.futures import ProcessPoolExecutor  # not at import: the CLI reads SETTINGS on every start

            with ProcessPoolExecutor(jobs) as pool:
                for records in pool.map(_job, todo):
                    keep(records)
        else:
            for task in todo:
                keep(_job(task))
    from .study_analysis import analyse

    return analyse(done, out_dir, progress=progress)


def load_runs(path) -> list[dict]:
    """The run records of a study's runs.jsonl (none when it does not exist)."""
    path = Path(path)
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _record_key(record: dict) -> str:
    return f"{record['shape']}|{record['variant']}|{record['seed']}|{record['setting']}"
