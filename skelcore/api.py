"""The Python API: load a cloud, skeletonize it in one call, step a contraction by hand, open the inspector.

    import skelcore
    result = skelcore.skeletonize("assets/y_branch.ply")
    result.save("out/")          # the files of `skelcore run`

`skeletonize` runs the same pipeline as `skelcore run` (which calls it): load, contract to the end, the
paper's metrics of every iteration, the curve skeleton of the last one.
"""
from __future__ import annotations

import dataclasses
import functools
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Generator

import numpy as np

from . import io, multires, pipeline
from .contraction import IterationState
from .contraction import contract as _contract
from .errors import ParameterError, SkelError
from .evidence import skeleton_evidence
from .labels import as_labels, check_label_weights
from .metrics import IterationMetrics
from .options import RunOptions
from .params import CleaningParams, ContractionParams, check_flag
from .paths import as_path
from .results import prepare_output, write_results
from .skeleton import Skeleton
from .verdict import run_verdict

INSPECTOR_ENTRY_POINTS = "skelcore.inspector"  # where the app registers its opener (pyproject.toml)
_PARAM_NAMES = tuple(field.name for field in dataclasses.fields(ContractionParams))


def load(path, *, labels=None, sample: int | None = None, voxel_size: float | None = None,
         max_points: int = io.MAX_POINTS, seed: int = RunOptions.seed, drop_nonfinite: bool = False) -> io.Cloud:
    """Read a point cloud or mesh file (.ply .pcd .xyz .pts .txt .off .obj .stl .glb) into a validated Cloud.

    `cloud.points` is an (n,3) float64 array (duplicates removed, noted in `cloud.notes`); `cloud.labels`
    holds per-point integer labels when the file is a PLY with a label property (label, class,
    scalar_label, ...) or when `labels` names a label file, a PLY property or is an array.
    sample: for a mesh, this many points drawn evenly over its surface; 0: its vertices; None (default): its
    vertices where they cover its surface, else points drawn evenly, said in `cloud.notes` (a CAD model's flat
    faces hold no vertex: skelcore.surface_sampling). voxel_size: one point per voxel.
    drop_nonfinite: leave out points with NaN or Inf coordinates (noted) instead of refusing the file.
    Bad input raises skelcore.errors.InputError with a one-line message.
    """
    return io.load(path, labels=labels, sample=sample, voxel_size=voxel_size, max_points=max_points, seed=seed,
                   drop_nonfinite=drop_nonfinite)


@dataclass
class Result:
    """A finished skeletonization: the cloud, every iteration state, the skeleton, the metrics, the verdict."""
    cloud: io.Cloud  # the points contracted, after duplicate removal and cleaning (cloud.points, .labels, .notes)
    states: list[IterationState]  # iteration 0 (the input) to the last; states[-1].termination says why it ended
    skeleton: Skeleton  # the curve skeleton of the last state
    metrics: list[IterationMetrics]  # the paper's metrics of each state (D_theta, delta_kappa, boundedness)
    options: RunOptions  # every parameter of the run
    weights: np.ndarray | None = None  # the per-point contraction weights (None: all 1)
    elapsed: float | None = None  # seconds the run took (None: not timed)
    input_path: str | None = None  # the file it came from, if any
    reduction: multires.Reduction | None = None  # the multi-resolution reduction (None: every point contracted)
    evidence: dict | None = field(default=None, repr=False)  # the skeleton checks' evidence, when the run made it

    @property
    def graph(self):
        """The skeleton as a networkx.Graph: nodes 0..m-1 with 'pos' (3,) and 'point_count', edges with 'length'."""
        return self.skeleton.graph

    @property
    def nodes(self) -> np.ndarray:
        """(m,3) skeleton node positions, in the input's coordinates."""
        return self.skeleton.nodes_array()

    @property
    def edges(self) -> np.ndarray:
        """(e,2) skeleton edges as pairs of node indices."""
        return self.skeleton.edges_array()

    @property
    def correspondence(self) -> np.ndarray:
        """(n,) the skeleton node of every input point."""
        return self.skeleton.correspondence

    @property
    def contracted(self) -> np.ndarray:
        """The contracted points of the last state (GLSkeleton: fewer than the input; see states[-1].owner).
        contracted.ply holds `contracted[states[-1].owner]`: a row per point of `cloud`."""
        return self.states[-1].points

    @functools.cached_property
    def verdict(self) -> dict:
        """The run's stability verdict on its last iteration, skeleton checks included (as `skelcore run` writes
        it): {'label': 'stable' | 'not yet converged' | 'unstable', 'iteration', 'criteria', 'reasons', ...}."""
        return run_verdict(self.metrics, self._evidence)

    @functools.cached_property
    def _evidence(self) -> dict:
        """The skeleton checks' evidence (skelcore.evidence.skeleton_evidence), which the verdict and every file
        written read: the run's, or computed once (its complex is a quarter of a 10k-point run)."""
        if self.evidence is not None:
            return self.evidence
        return skeleton_evidence(self.skeleton, self.states[-1], self.cloud.points, solid_loops=self.cloud.solid_loops)

    @property
    def topology(self) -> dict:
        """The skeleton's components, cycles, junctions and ends."""
        return self.skeleton.topology()

    def save(self, out_dir, *, force: bool = False) -> Path:
        """Write the files of `skelcore run` into `out_dir` (created if needed): skeleton.json, skeleton.ply,
        contracted.ply, metrics.json, params.json. Returns the folder. A folder that holds the results of a run
        already is refused (an OutputError), as by `skelcore run`; force=True replaces them (other files stay),
        as `skelcore run --force` does."""
        check_flag("force", force)
        return self._save(out_dir, force, what="folder", replace="save with force=True")

    def save_skeleton(self, path) -> Path:
        """Write the skeleton alone to the file `path`, in the format its name ends in: .json (as skeleton.json),
        .ply (vertex and edge elements), .obj (polylines, one per chain between ends and junctions) or .graphml
        (node positions as x, y, z). Returns the path."""
        from .export import write_skeleton_file

        return write_skeleton_file(path, self.skeleton)

    def _save(self, out_dir, force: bool, **terms) -> Path:
        """`save`, whose refusal of earlier results names the folder and the way to replace them in `terms`
        (results.check_output's: `skelcore run` says --out and --force)."""
        out_dir = prepare_output(out_dir, force, **terms)
        write_results(out_dir, self.cloud, self.states, self.skeleton, self.metrics, self.options,
                      input_path=self.input_path, elapsed=self.elapsed, weights=self.weights,
                      reduction=self.reduction, evidence=self._evidence)
        return out_dir

    def report(self, path) -> Path:
        """Write the HTML page of `skelcore report` for this run (the paper's figures, verdict, clouds, skeleton)."""
        from .export import write_points_ply
        from .report import write_report

        path = as_path(path, "path")
        with tempfile.TemporaryDirectory(prefix="skelcore-report-") as tmp:
            folder = Path(tmp) / (Path(self.cloud.name).stem or "cloud")
            source = self.input_path
            if source is None:  # an array: the report reads the original cloud back from a file
                source = write_points_ply(Path(tmp) / "input.ply", self.cloud.points)
            write_results(folder, self.cloud, self.states, self.skeleton, self.metrics, self.options,
                          input_path=source, elapsed=self.elapsed, weights=self.weights, evidence=self._evidence)
            return write_report([folder], path)

    def summary(self) -> str:
        """One line: iterations, termination, skeleton size and topology, verdict."""
        topology, final = self.topology, self.states[-1]
        return (f"{Path(self.cloud.name).name}: {final.iteration} iterations ({final.termination}), skeleton "
                f"{self.graph.number_of_nodes()} nodes, {topology['cycles']} cycles, {topology['junctions']} "
                f"junctions, {topology['ends']} ends; verdict {self.verdict['label']}"
                + ("" if self.elapsed is None else f"; {self.elapsed:.1f} s"))

    def __repr__(self) -> str:
        return f"<skelcore.Result {self.summary()}>"


def skeletonize(points_or_path, method: str = ContractionParams.method, *, weights=None, labels=None,
                label_weights=None, cleaning: CleaningParams | bool = True,
                sample_radius: float = RunOptions.sample_radius, seed: int = RunOptions.seed, sample: int | None = None,
                voxel_size: float | None = None, max_points: int = io.MAX_POINTS, drop_nonfinite: bool = False,
                point_budget: int | None = RunOptions.point_budget, progress: Callable[[str], None] | None = None,
                **params) -> Result:
    """Contract a cloud into its curve skeleton and judge the contraction; the pipeline of `skelcore run`.

    points_or_path: an (n,3) array, a Cloud (from `load`), an open3d or trimesh point cloud or triangle mesh
      (a mesh is judged as a mesh file is: drawn over when its vertices do not stand for its surface), or a
      file path.
    method: "lbc" (Cao et al. 2010) or "glskeleton" (Wen et al. 2024).
    weights: (n,) positive per-point contraction weights (a multiplier of W_L per point: point i's
      Laplacian row becomes W_L w_i L_i): one per point of an array or a file (the rows loading keeps take
      theirs: a repeated point its first row's; refused when a mesh's points are drawn anew), one per point of
      a Cloud given.
    labels: per-point integer labels: an (n,) array, a label file or a PLY vertex property name; a PLY
      input's label property is read without asking. label_weights: {label: weight}; unnamed labels keep 1.
      Give `weights` or `label_weights`, not both.
    cleaning: statistical outliers and stray pieces are removed and the points projected onto their local
      planes before contraction (True, the default, as `skelcore run`), or not (False), or as a
      CleaningParams says. `result.cloud` holds the points contracted
      (its `notes` say what was removed); the skeleton's correspondence, the states and `result.weights`
      follow those points.
    sample_radius: the skeleton's ball radius, a fraction of the object's bounding-box diagonal
        (points far outside the bulk of the cloud left out).
    sample: for a mesh file or mesh object, as in `load` (default: its vertices where they cover its surface).
    drop_nonfinite: leave out points with NaN or Inf coordinates instead of refusing the input.
    point_budget: a larger cloud is contracted as voxel centroids of about this many points, and one within it
      with a part many times denser than the surface around it with that part thinned, every point carried along
      (skelcore.multires); 0 or None: every point contracted (`skelcore run --full-resolution`).
    **params: contraction parameters (skelcore.ContractionParams fields: k, wl0, wh0, sl, wl_max,
      max_iterations, termination, ...); unset ones take their defaults. hold_inside unset (or None): a cloud
      whose skeleton keeps fewer loops than its solid has (a closed mesh's genus, or those a closed point cloud's
      inside test reads, skelcore.cloud_topology) is contracted again holding its points inside (its notes say
      so); True or False, it decides.
    progress: called with one line per iteration (e.g. print).
    """
    if params.get("hold_inside", True) is None:  # unset, said as None
        del params["hold_inside"]
    options = RunOptions(
        params=contraction_params(method, params), sample_radius=sample_radius, seed=seed, sample=sample,
        voxel_size=voxel_size, max_points=max_points, cleaning=cleaning_params(cleaning),
        labels=str(labels) if isinstance(labels, (str, Path)) else None,
        label_weights=tuple(sorted(check_label_weights(label_weights).items())), drop_nonfinite=drop_nonfinite,
        point_budget=point_budget, hold_retry=params.get("hold_inside") is None)
    if isinstance(labels, (str, Path)) and isinstance(points_or_path, (str, Path)):
        labels = None  # read by the load, through options.labels
    return run(points_or_path, options, progress=progress, labels=labels, weights=weights)


def run(points_or_path, options: RunOptions = RunOptions(), *, labels=None, weights=None,
        progress: Callable[[str], None] | None = None) -> Result:
    """`skeletonize` with its options gathered in a skelcore.options.RunOptions (what `skelcore run` calls).
    labels: an (n,) array of labels (a label file or property goes in options.labels)."""
    started = time.perf_counter()
    if not isinstance(options, RunOptions):
        raise ParameterError(f"parameter options={options!r}: must be a RunOptions")
    options.validated()  # here too: an array's run drops the sampling options below
    if progress is not None and not callable(progress):
        raise ParameterError(f"parameter progress={progress!r}: must be a function of one line (such as print)")
    input_path = str(points_or_path) if isinstance(points_or_path, (str, Path)) else None
    if input_path is None:
        cloud = as_cloud(points_or_path, labels, options.drop_nonfinite, options.sample, options.voxel_size,
                         options.max_points)
        points_or_path, labels, weights = cloud, None, io.weights_of(points_or_path, cloud, weights)
        options = dataclasses.replace(options, sample=None, voxel_size=None, labels=None)  # for files only
    computed = pipeline.compute(points_or_path, options, progress, labels=labels, weights=weights)
    return Result(computed.cloud, computed.states, computed.skeleton, computed.metrics, options, computed.weights,
                  time.perf_counter() - started, input_path, computed.reduction, computed.evidence)


def cleaning_params(cleaning: CleaningParams | bool) -> CleaningParams:
    """CleaningParams from True (the defaults), False (no cleaning) or a CleaningParams."""
    if isinstance(cleaning, CleaningParams):
        return cleaning.validated()
    if cleaning is True:
        return CleaningParams()
    if cleaning is False:
        return CleaningParams(remove_outliers=False, remove_stray=False, denoise=False)
    raise ParameterError(f"parameter cleaning={cleaning!r}: must be True, False or a CleaningParams")


def contraction_params(method: str, params: dict) -> ContractionParams:
    """ContractionParams from keyword arguments, with a clear error for a name that is not a parameter."""
    unknown = sorted(set(params) - set(_PARAM_NAMES))
    if unknown:
        raise ParameterError(f"unknown parameter {', '.join(unknown)} (contraction parameters: "
                             f"{', '.join(_PARAM_NAMES)})")
    return ContractionParams(method=method, **params).validated()


def as_cloud(points_or_cloud, labels=None, drop_nonfinite: bool = False, sample: int | None = None,
             voxel_size: float | None = None, max_points: int = io.MAX_POINTS) -> io.Cloud:
    """A Cloud from an (n,3) array or an open3d/trimesh cloud or mesh (checked as a loaded file is) or a Cloud;
    `labels` replace its labels. An array with repeated points loses the repeats (and their labels), as a file
    does; with `drop_nonfinite` its NaN or Inf rows are left out (else refused). sample: for a mesh, as in
    `load` (ignored for points); voxel_size, max_points: as in `load` (not for a Cloud, loaded already)."""
    if isinstance(points_or_cloud, io.Cloud):
        cloud = io.checked(points_or_cloud, drop_nonfinite)  # a Cloud made by hand is checked as an array is
        if labels is None:
            return cloud
        return dataclasses.replace(cloud, labels=as_labels(labels, len(cloud.points), "labels"))
    if isinstance(labels, (str, Path)):
        raise ParameterError("parameter labels: for an array input, give the labels as an array")
    points, faces, name = library_geometry(points_or_cloud)
    return io.validate(points, faces, name=name, labels=labels, drop_nonfinite=drop_nonfinite,
                       sample=None if faces is None else sample, voxel_size=voxel_size, max_points=max_points)


def library_geometry(value) -> tuple:
    """(points, faces or None, name) of an open3d or trimesh point cloud or triangle mesh, read by the attributes
    those libraries give them (neither is imported); anything else is taken as an array of points."""
    kind = type(value).__name__
    if isinstance(value, np.ndarray) or not hasattr(value, "vertices") and not hasattr(value, "points"):
        return value, None, "array"
    if hasattr(value, "vertices") and hasattr(value, "faces"):  # trimesh.Trimesh
        return np.asarray(value.vertices), np.asarray(value.faces), kind
    if hasattr(value, "vertices") and hasattr(value, "triangles"):  # open3d.geometry.TriangleMesh
        return np.asarray(value.vertices), np.asarray(value.triangles), kind
    # open3d.geometry.PointCloud (.points), trimesh.PointCloud (.vertices)
    return np.asarray(value.points if hasattr(value, "points") else value.vertices), None, kind


def contract(points, method: str | None = None, *, weights=None, params: ContractionParams | None = None,
             **changes) -> Generator[IterationState, ContractionParams | None, None]:
    """The contraction as a generator, for stepping by hand: it yields the input state (iteration 0), then
    one IterationState per solve (`.points`, `.iteration`, `.wl`, `.wh`, `.ring_ratio`, `.termination` on
    the last). `generator.send(params)` with a ContractionParams retunes the following steps.

        for state in skelcore.contract(points, max_iterations=3):
            print(state.iteration, state.ring_ratio)

    points: an (n,3) array or a Cloud; weights: per-point contraction weights, as in `skeletonize`; params: a
    whole ContractionParams (default: the defaults); method and **changes: parameters by name on top of it."""
    if params is not None and not isinstance(params, ContractionParams):
        raise ParameterError(f"parameter params={params!r}: must be a ContractionParams (parameters by name go as "
                             "keywords: contract(points, k=8))")
    cloud = as_cloud(points)
    merged = {**(params or ContractionParams()).to_dict(), **changes}
    if method is not None:
        merged["method"] = method
    weights = io.weights_of(points, cloud, weights)
    return _contract(cloud.points, contraction_params(merged.pop("method"), merged), weights)


def _inspector():
    """The function that opens the inspector, which the inspector's package registers under the entry point group
    INSPECTOR_ENTRY_POINTS: the engine never imports the app, the app plugs into it."""
    from importlib.metadata import entry_points

    for entry in entry_points(group=INSPECTOR_ENTRY_POINTS):
        return entry.load()
    raise SkelError("inspect: no inspector is installed (reinstall skelcore: `pip install -e .` registers it)")


def inspect(points_or_result, port: int | None = None, *, host: str | None = None, labels=None,
            label_weights=None, weights=None, **params):
    """Open the inspector (a viser web app) on an array, a Cloud, a file path or a finished Result.

    Returns an `app.handle.InspectorHandle`: `.url`, `.stop()`; in Jupyter, a cell that ends with the handle
    shows the inspector inline (an iframe). A Result opens at its last iteration, with its parameters and
    weights (one contracted at reduced resolution runs again from iteration 0, reduced the same way: its
    states carry every input point, but skeletons are made from the reduced cloud's); an array starts at
    iteration 0. port: None or 0 takes a free port; host: None serves this machine only (the inspector's
    default). **params: contraction parameters, as in `skeletonize`. The server runs in background threads until
    `.stop()`.
    """
    open_inspector = _inspector()
    served = {"port": port or 0, **({} if host is None else {"host": host})}
    if isinstance(points_or_result, Result):
        if labels is not None or label_weights is not None or weights is not None or params:
            raise ParameterError("inspect: a Result opens with its own parameters and weights")
        result = points_or_result
        # the parameters its states ran with: a closed solid's run held inside again (skelcore.pipeline) differs
        # from the options it was asked with
        return open_inspector(result.cloud, result.states[-1].params, **served,
                              sample_radius=result.options.sample_radius,
                              label_weights=dict(result.options.label_weights),
                              history=None if result.reduction is not None else result.states,
                              point_budget=result.options.point_budget,
                              weights=None if result.options.label_weights else result.weights)
    params = contraction_params(params.pop("method", ContractionParams.method), params)
    if isinstance(points_or_result, (str, Path)):
        cloud = io.load(points_or_result, labels=labels)
    else:
        cloud = as_cloud(points_or_result, labels)
    weights = io.weights_of(points_or_result, cloud, weights)
    return open_inspector(cloud, params, **served, label_weights=check_label_weights(label_weights),
                          weights=weights)
