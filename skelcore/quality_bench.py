"""`skelcore bench-quality`: the curve skeleton's topology on shapes of known genus, clean and scan-like.

Every shape of `skelcore.solids` (each sampled to the same number of points) in every variant of
`skelcore.perturb` goes through the whole pipeline (`run_pipeline`, as `skelcore run` does) for each method;
the variant MESH gives the pipeline a shape's mesh file itself, which the loader samples to as many points and
whose genus it reads (io.Cloud.solid_loops), and SCAN_LINES cuts that mesh into a profile scanner's lines
(skelcore.perturb.scan_lines; like MESH, run on the shapes that have a mesh). A run that closed a loop through the
solid (the mesh's genus, or the loops a closed cloud's inside test reads: skelcore.cloud_topology) is tried again
holding its points inside (skelcore.medial).
A run is exact when its skeleton's cycle rank and component count equal the shape's. A perturbed run has
collapsed when its skeleton keeps fewer than half the nodes of the same shape's clean run. A run that fails
is recorded with its error and the benchmark goes on. Each seed draws the shapes' samples and the variants
anew: one draw decides a few runs either way, so several seeds tell a method's rate from its luck.
"""
from __future__ import annotations

import json
import tempfile
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .errors import ParameterError
from .params import METHODS
from .perturb import MORE_VARIANTS, SCAN_LINES, VARIANTS, perturb, scan_lines
from .solids import DEFAULT_POINTS, benchmark_shapes

COLLAPSE_SHARE = 0.5  # a perturbed run keeps at least this share of its clean run's skeleton nodes
CLEAN = "clean"
MESH = "mesh"  # the shape's mesh file, not a cloud: no variant of perturb's (shapes without a mesh skip it)
BENCH_VARIANTS = (*VARIANTS, MESH)  # the default grid
NAMED_VARIANTS = (*BENCH_VARIANTS, *MORE_VARIANTS, SCAN_LINES)  # ... and those run when named


@dataclass
class CaseResult:
    """One run of the benchmark: a shape in one variant through one method, and what its skeleton came out as."""

    shape: str
    variant: str
    method: str
    expected: dict  # cycles, components, ends (None where unknown)
    n_points: int
    seed: int = 0  # of the shape's sampling and the variant's draw
    topology: dict | None = None  # cycles, components, junctions, ends of the skeleton
    nodes: int | None = None
    iterations: int | None = None
    termination: str | None = None
    seconds: float = 0.0
    error: str | None = None

    @property
    def exact(self) -> bool:
        """The skeleton's cycle rank and component count equal the shape's."""
        return self.topology is not None and all(self.topology[key] == self.expected[key]
                                                 for key in ("cycles", "components"))


def run_case(points, method: str, *, name: str, seed: int = 0, keep_dir=None) -> dict:
    """One run of the pipeline on `points`: an (n,3) array, or (vertices, faces, count), a mesh given as its file
    with `count` points drawn over it by the loader; the skeleton's topology, node count and time, or the
    error."""
    from .export import write_points_ply
    from .params import ContractionParams
    from .options import RunOptions
    from .pipeline import run_pipeline

    started = time.perf_counter()
    try:
        mesh = isinstance(points, tuple)
        options = RunOptions(params=ContractionParams(method=method), seed=seed, sample=points[2] if mesh else None)
        with tempfile.TemporaryDirectory(prefix="skelcore-quality-") as scratch:
            source = Path(scratch) / f"{name}.ply"
            if mesh:
                import trimesh

                trimesh.Trimesh(points[0], points[1], process=False).export(source)
            else:
                write_points_ply(source, points)
            out = Path(keep_dir) / f"{name}_{method}" if keep_dir is not None else Path(scratch) / "run"
            result = run_pipeline(source, out, options)
        final = result.states[-1]
        return {"topology": result.skeleton.topology(), "nodes": result.skeleton.graph.number_of_nodes(),
                "iterations": final.iteration, "termination": final.termination,
                "seconds": time.perf_counter() - started}
    except Exception as error:  # the benchmark records any failure and goes on
        where = traceback.extract_tb(error.__traceback__)[-1]
        message = " ".join(str(error).split())[:200] or type(error).__name__
        return {"error": f"{type(error).__name__}: {message} ({Path(where.filename).name}:{where.lineno})",
                "seconds": time.perf_counter() - started}


def run_quality_bench(*, methods=METHODS, shapes: list[str] | None = None, variants=BENCH_VARIANTS,
                      points: int = DEFAULT_POINTS, seeds=(0,), workers: int = 1, reference_dir=None,
                      keep_dir=None, progress: Callable[[str], None] | None = None) -> list[CaseResult]:
    """Run every seed x shape x variant x method; results in that order."""
    unknown = [v for v in variants if v not in NAMED_VARIANTS] + [m for m in methods if m not in METHODS]
    if unknown:
        raise ParameterError(f"bench-quality: unknown variant or method {unknown[0]!r} "
                             f"(variants: {', '.join(NAMED_VARIANTS)}; methods: {', '.join(METHODS)})")
    if int(points) != points or points < 100:
        raise ParameterError(f"bench-quality: points={points!r} must be an integer >= 100")
    if int(workers) != workers or workers < 1:
        raise ParameterError(f"bench-quality: workers={workers!r} must be an integer >= 1")
    if not seeds or any(int(seed) != seed or seed < 0 for seed in seeds):
        raise ParameterError(f"bench-quality: seeds={list(seeds)!r} must be integers >= 0")
    cases: list[tuple[CaseResult, np.ndarray]] = []
    for seed in dict.fromkeys(int(seed) for seed in seeds):
        for shape in benchmark_shapes(reference_dir, points=points, seed=seed, names=shapes):
            expected = {"cycles": shape.cycles, "components": shape.components, "ends": shape.ends}
            for variant in variants:
                if variant in (MESH, SCAN_LINES) and shape.mesh is None:  # a scan: no mesh to give or to cut
                    continue
                if variant == MESH:
                    cloud, count = (*shape.mesh, len(shape.points)), len(shape.points)
                elif variant == SCAN_LINES:
                    cloud = scan_lines(*shape.mesh, seed=seed)
                    count = len(cloud)
                else:
                    cloud = perturb(shape.points, variant, seed=seed, normals=shape.normals, loops=shape.cycles > 0)
                    count = len(cloud)
                for method in methods:
                    cases.append((CaseResult(shape.name, variant, method, expected, count, seed), cloud))
    several = len({case.seed for case, _ in cases}) > 1
    keep = Path(keep_dir) if keep_dir is not None else None

    def finish(case: CaseResult, outcome: dict) -> None:
        for key, value in outcome.items():
            setattr(case, key, value)
        if progress is not None:
            got = "error" if case.error else _triple(case.topology)
            drawn = f" seed {case.seed}" if several else ""
            progress(f"{case.shape} {case.variant}{drawn} {case.method}: {got} ({case.seconds:.1f} s)")

    def arguments(case: CaseResult) -> dict:
        name = f"{case.shape}_{case.variant}" + (f"_seed{case.seed}" if several else "")
        return {"name": name, "seed": case.seed, "keep_dir": keep}

    if workers == 1:
        for case, cloud in cases:
            finish(case, run_case(cloud, case.method, **arguments(case)))
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            pending = {pool.submit(run_case, cloud, case.method, **arguments(case)): case for case, cloud in cases}
            for future in as_completed(pending):
                try:
                    outcome = future.result()
                except Exception as error:  # a worker process that died takes only its cases with it
                    outcome = {"error": f"{type(error).__name__}: worker failed ({error})"}
                finish(pending[future], outcome)
    return [case for case, _ in cases]


# --- the table ----------------------------------------------------------------------------------------

def summarise(results: list[CaseResult]) -> dict:
    """Per method: share exact on clean and on perturbed clouds (in all, by variant and by seed), collapses, loops
    lost on clean, time. A perturbed run is checked against the clean run of its shape, method and seed."""
    clean_nodes = {(r.shape, r.method, r.seed): r.nodes for r in results if r.variant == CLEAN and r.nodes is not None}
    several = len({r.seed for r in results}) > 1
    summary = {}
    for method in dict.fromkeys(r.method for r in results):
        mine = [r for r in results if r.method == method]
        clean = [r for r in mine if r.variant == CLEAN]
        perturbed = [r for r in mine if r.variant not in (CLEAN, MESH)]
        meshes = [r for r in mine if r.variant == MESH]
        checked = [r for r in perturbed if (r.shape, method, r.seed) in clean_nodes]
        collapsed = [r for r in checked
                     if r.nodes is None or r.nodes < COLLAPSE_SHARE * clean_nodes[(r.shape, method, r.seed)]]
        seed_of = (lambda r: f" seed {r.seed}") if several else (lambda r: "")
        summary[method] = {
            "clean_exact": sum(r.exact for r in clean), "clean_runs": len(clean),
            "perturbed_exact": sum(r.exact for r in perturbed), "perturbed_runs": len(perturbed),
            "mesh_exact": sum(r.exact for r in meshes), "mesh_runs": len(meshes),
            "by_variant": {v: [sum(r.exact for r in mine if r.variant == v), sum(r.variant == v for r in mine)]
                           for v in dict.fromkeys(r.variant for r in mine)},
            "perturbed_by_seed": {str(seed): [sum(r.exact for r in perturbed if r.seed == seed),
                                              sum(r.seed == seed for r in perturbed)]
                                  for seed in dict.fromkeys(r.seed for r in mine)},
            "no_collapse": len(checked) - len(collapsed), "collapse_checked": len(checked),
            "collapsed": [f"{r.shape}/{r.variant}{seed_of(r)}" for r in collapsed],
            "clean_loops_lost": [f"{r.shape}{seed_of(r)}" for r in clean
                                 if r.topology is not None and r.topology["cycles"] < r.expected["cycles"]],
            "errors": sum(r.error is not None for r in mine),
            "seconds": sum(r.seconds for r in mine),
        }
    return summary


def format_table(results: list[CaseResult], summary: dict, total_seconds: float) -> str:
    """One table: a row per shape and variant, per method its cycles/components/ends, nodes, exact, time."""
    methods = list(summary)
    several = len({r.seed for r in results}) > 1
    seed_head, seed_rule = (f" {'seed':>4}", f" {'':>4}") if several else ("", "")
    head = f"{'shape':<15} {'variant':<11}{seed_head} {'points':>6} {'expected':>10}"
    rule = f"{'':<15} {'':<11}{seed_rule} {'':>6} {'cyc/cc/end':>10}"
    for method in methods:
        head += f" | {method:<29}"
        rule += f" | {'cyc/cc/end':>10} {'nodes':>5} {'exact':>5} {'s':>5}"
    lines = [head, rule, "-" * len(rule)]
    # cyc: independent cycles (E - V + C), cc: connected components, end: degree-1 nodes (? where unknown)
    by_key = {(r.shape, r.variant, r.seed, r.method): r for r in results}
    rows = dict.fromkeys((r.shape, r.variant, r.seed) for r in results)
    for shape, variant, seed in rows:
        first = next(r for r in results if (r.shape, r.variant, r.seed) == (shape, variant, seed))
        drawn = f" {seed:>4}" if several else ""
        line = f"{shape:<15} {variant:<11}{drawn} {first.n_points:>6} {_triple(first.expected):>10}"
        for method in methods:
            r = by_key.get((shape, variant, seed, method))
            if r is None:
                line += f" | {'':<29}"
            elif r.error is not None:
                line += f" | {'ERROR':>10} {'-':>5} {'no':>5} {r.seconds:>5.1f}"
            else:
                line += (f" | {_triple(r.topology):>10} {r.nodes:>5} {'yes' if r.exact else 'no':>5} "
                         f"{r.seconds:>5.1f}")
        lines.append(line)
    lines.append("")
    for method, s in summary.items():
        on_meshes = f", on mesh files {_share(s['mesh_exact'], s['mesh_runs'])}" if s["mesh_runs"] else ""
        lines.append(f"{method}: exact (cycles and components) on clean clouds "
                     f"{_share(s['clean_exact'], s['clean_runs'])}, on perturbed "
                     f"{_share(s['perturbed_exact'], s['perturbed_runs'])}{on_meshes}; no collapse (>= {COLLAPSE_SHARE:.0%} of "
                     f"the clean run's nodes) {_share(s['no_collapse'], s['collapse_checked'])}; "
                     f"{s['errors']} errors; {s['seconds']:.0f} s")
        lines.append("  exact by variant: " + ", ".join(f"{v} {e}/{n}" for v, (e, n) in s["by_variant"].items()))
        if several:
            lines.append("  exact perturbed by seed: " + ", ".join(f"{seed} {e}/{n}" for seed, (e, n)
                                                                  in s["perturbed_by_seed"].items()))
        if s["clean_loops_lost"]:
            lines.append(f"  loops lost on clean clouds: {', '.join(s['clean_loops_lost'])}")
        if s["collapsed"]:
            lines.append(f"  collapsed: {', '.join(s['collapsed'])}")
    errors = [r for r in results if r.error is not None]
    for r in errors:
        lines.append(f"error: {r.shape} {r.variant}{f' seed {r.seed}' if several else ''} {r.method}: {r.error}")
    lines.append(f"total {total_seconds:.0f} s for {len(results)} runs")
    return "\n".join(lines)


def write_json(path, results: list[CaseResult], summary: dict, settings: dict) -> Path:
    """Every run (with its exactness), the summary and the settings as one JSON document at `path`."""
    path = Path(path)
    rows = [{**asdict(r), "exact": r.exact} for r in results]
    path.write_text(json.dumps({"settings": settings, "summary": summary, "runs": rows}, indent=1))
    return path


def _triple(topology: dict | None) -> str:
    if topology is None:
        return "-"
    ends = topology.get("ends")
    return f"{topology['cycles']}/{topology['components']}/{'?' if ends is None else ends}"


def _share(part: int, whole: int) -> str:
    return f"{part}/{whole} ({100 * part / whole:.0f}%)" if whole else "n/a"
