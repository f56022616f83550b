"""The files of a run: skeleton.json, skeleton.ply, contracted.ply, metrics.json and params.json, each written
atomically, and the output folder they go into."""
from __future__ import annotations

import dataclasses
import errno
import json
import os
from pathlib import Path
from typing import Callable

import numpy as np

from . import __version__, io, multires
from .errors import InputError, OutputError, SkelError
from .evidence import skeleton_evidence
from .metrics import IterationMetrics
from .options import RunOptions
from .params import default_k
from .paths import writable_folder
from .skeleton import Skeleton
from .solver import backend
from .step import TERMINATION_MESSAGES, IterationState
from .verdict import run_verdict

RESULT_FILES = ("skeleton.json", "skeleton.ply", "contracted.ply", "metrics.json", "params.json")
DONE_FILE = "done.json"  # `skelcore batch`'s marker of an object run to its end (skelcore.batch_object)
REPORT_FILE = "report.html"  # the HTML report `skelcore batch` writes beside its objects (skelcore.batch)
EARLIER_RUN_FILES = (DONE_FILE, REPORT_FILE)  # what `skelcore batch` adds to a run's folder


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
            "notes": list(cloud.notes),  # what loading and cleaning did, and a second run's reason
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
        "drop_nonfinite": options.drop_nonfinite,
        # each change made during the run, from the step it applied to on (the contraction above is the start's)
        "retuned": [f"iteration {state.iteration}: {said}" for state in states for said in state.message.split("; ")
                    if said.startswith("retuned ")],
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
    """Write the five result files together (write_together: an earlier run's results are replaced only once all
    five are written, and its batch files then removed). evidence: the final state's skeleton_evidence, when the
    caller has it already."""
    from .export import skeleton_document, write_points_ply, write_skeleton_ply

    out_dir = Path(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise InputError(f"{out_dir}: cannot create the output folder ({error.strerror})") from None
    final = states[-1]
    if evidence is None:
        evidence = skeleton_evidence(skeleton, final, cloud.points, solid_loops=cloud.solid_loops)
    summary = metrics_document(cloud, states, metrics, reduction, evidence)
    if elapsed is not None:
        summary["elapsed_seconds"] = elapsed
    # every point the run kept (cloud.points: after duplicates and cleaning) at its contracted place, in their
    # order, whatever the method (GLSkeleton's merged points once for each point they absorbed)
    contracted, skeleton = final.points[final.owner] * cloud.scale, _at_scale(skeleton, cloud.scale)
    labels = cloud.labels  # a labelled input: its labels too
    write_together(out_dir, {
        "contracted.ply": lambda path: write_points_ply(path, contracted, labels=labels),
        "skeleton.ply": lambda path: write_skeleton_ply(path, skeleton),
        # compact: its correspondence lists every input point, which an indented layout puts one per line
        # through json's pure-Python encoder (4x slower: 0.3 s instead of 0.08 s at 1M points)
        "skeleton.json": lambda path: _write_json(path, skeleton_document(skeleton), indent=None),
        "metrics.json": lambda path: _write_json(path, summary),
        "params.json": lambda path: _write_json(path, params_document(cloud, states, options, input_path, weights)),
    }, stale=(*EARLIER_RUN_FILES, *(path.name for path in out_dir.glob(".*.tmp"))))  # a crashed run's temporaries
    return summary


def _at_scale(skeleton: Skeleton, scale: float) -> Skeleton:
    """The skeleton in the file's coordinates (io.Cloud.scale: not 1 only for extreme coordinates)."""
    if scale == 1.0:
        return skeleton
    graph = skeleton.graph.copy()
    for _, attrs in graph.nodes(data=True):
        attrs["pos"] = np.asarray(attrs["pos"]) * scale
    for _, _, attrs in graph.edges(data=True):
        attrs["length"] = attrs["length"] * scale
    return dataclasses.replace(skeleton, graph=graph, radius=skeleton.radius * scale, gap=skeleton.gap * scale)


def write_atomic(path: Path, write: Callable[[Path], None]) -> None:
    """write(temporary) then rename it to `path`: a failure (a full disk) leaves the file as it was and
    raises an OutputError naming it."""
    write_together(path.parent, {path.name: write}, kept="the files written before it are kept")


def write_together(folder: Path, writers: dict[str, Callable[[Path], None]], stale: tuple[str, ...] = (),
                   kept: str = "the folder's files are as they were") -> None:
    """Each writer(temporary) beside its file, and only once every one has succeeded, each temporary renamed to
    its name in `folder` and the `stale` files removed: a failure (a full disk) replaces nothing, removes the
    temporaries and raises an OutputError naming the file (a rename that fails, rarer, leaves those renamed
    before it in place). `kept`: what the message says was kept."""
    temporaries = {name: folder / f".{name}.{os.getpid()}.tmp" for name in writers}
    name = None
    try:
        for name, write in writers.items():
            write(temporaries[name])
        for name, temporary in temporaries.items():
            os.replace(temporary, folder / name)
        for name in stale:
            (folder / name).unlink(missing_ok=True)
    except OSError as error:
        reason = "the disk is full" if error.errno in (errno.ENOSPC, errno.EDQUOT) else error.strerror or "error"
        raise OutputError(f"{folder / name}: cannot write ({reason}); {kept}") from None
    except SkelError as error:  # a writer's own message, about the temporary file
        raise OutputError(f"{str(error).replace(str(temporaries[name]), str(folder / name))}; {kept}") from None
    finally:
        for temporary in temporaries.values():
            temporary.unlink(missing_ok=True)


def check_output(out_dir, force: bool = False, *, what: str = "--out", replace: str = "pass --force") -> list[Path]:
    """The files of an earlier run in the output folder, checked before any work: a folder holding them is
    refused unless `force`, a path that is a file always (nothing is created or removed here). `what` names
    the folder and `replace` says how to replace them, in the caller's terms (the command line's by default)."""
    out_dir = writable_folder(out_dir, what)
    earlier = [out_dir / name for name in (*RESULT_FILES, *EARLIER_RUN_FILES) if (out_dir / name).exists()]
    earlier += list(out_dir.glob(".*.tmp")) if out_dir.is_dir() else []
    if earlier and not force:
        raise OutputError(f"{out_dir}: already holds the results of a run ({earlier[0].name}, ...); "
                          f"choose another folder or {replace} to replace them")
    return earlier


def prepare_output(out_dir, force: bool = False, **terms) -> Path:
    """The output folder, created, once the new results are ready to write (check_output first, before the
    work). With `force` an earlier run's files stay until the new ones are all written (write_results: then
    they are replaced, a batch's files beside them removed, other files stay), so a run or a write that fails
    leaves the earlier results as they were. `terms`: check_output's."""
    check_output(out_dir, force, **terms)  # the path as given: Path("") would be the working folder
    out_dir = Path(out_dir)
    try:
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
