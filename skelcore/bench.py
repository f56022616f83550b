"""`skelcore bench`: the whole `skelcore run` per stage, LBC and GLSkeleton side by side, on noisy tori of
growing size, against a pc-skeletor-style LBC, with peak memory and the fitted growth exponent.

Each run is a fresh process (`skelcore run` as a user of an installed package starts it, its bytecode written
first: interpreter, imports, PLY load, cleaning, multi-resolution above its budget, contraction, skeleton,
metrics, the verdict's evidence, writing), timed by wall clock from its
launch to its exit, its CPU time and peak resident memory read by the process itself. Runs are interleaved
size by size, so the ratios printed come from one bench run on the same machine state; on a shared machine
only those ratios mean much. A stage's seconds are the run's own wall clock: the metrics and the verdict's
evidence are computed on helper threads beside the contraction and the skeleton (skelcore.pipeline.compute), so
their stages count only the time the run still waits for them. Each run's share of work around the solve is
printed twice: L's sparsity-pattern set-up (`pattern`), the metrics and evidence waited for and the skeleton;
and that with the one-rings (`rings`: k nearest neighbours and their Delaunay fans) and each step's Laplacian
values and normal matrix (`laplacian`) added.

The pc-skeletor baseline is pc-skeletor's own whole LBC run when an interpreter with pc-skeletor installed is
given (`--pc-skeletor PYTHON`, or the current one if it imports `pc_skeletor`): a fresh process that imports it,
reads the PLY with open3d, runs `LBC(...).extract_skeleton()` held to as many iterations as our LBC run made,
`extract_topology()` and `save()`, as its README shows. Without it the baseline is a reproduction of its LBC
solve only (the normal equations built with scipy and solved with scipy.sparse.linalg.spsolve, COLAMD, once per
coordinate) on our own one-rings and Laplacian, which stand in for its robust_laplacian; loading, the
per-iteration Laplacian and the skeleton are then not counted, so the ratio is a lower bound. SuperLU's fill
makes either impractical past --baseline-max points.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from . import startup
from .errors import ParameterError
from .params import METHODS, is_integer, is_real

SIZES = (10_000, 30_000, 100_000, 300_000, 1_000_000)
BASELINE_MAX = 30_000  # pc-skeletor's SuperLU solve is timed up to this size (minutes per run above it)
NOISE = 0.002  # Gaussian noise of the bench tori, a fraction of the bounding-box diagonal
# in run order; "solid loops" reads a closed cloud's loops and "hold inside" is a second run when one was lost
STAGES = ("load", "clean", "reduce", "contract", "skeleton", "carry", "metrics", "evidence", "solid loops",
          "hold inside", "write")


def run_bench(sizes=SIZES, *, methods=METHODS, baseline_max: int = BASELINE_MAX,
              full_resolution: bool = False, noise: float = NOISE, pc_skeletor: str | None = None,
              out=print) -> list[dict]:
    """Time every (size, method) and the baseline; print the table, the ratios and the growth exponents.
    `pc_skeletor`: a Python interpreter with pc-skeletor installed (module docstring); None looks for it in
    the current one."""
    from .solver import backend

    if not is_integer(baseline_max) or baseline_max < 0:
        raise ParameterError(f"bench: baseline_max={baseline_max!r} must be a whole number of points >= 0 (0: never)")
    if not is_real(noise) or not 0 <= noise <= 1:  # a fraction of the diagonal: past 1 the tori are gone
        raise ParameterError(f"bench: noise={noise!r} must be a fraction of the diagonal in [0, 1]")

    peer = _pc_skeletor_interpreter(pc_skeletor)
    compiled = compile_package()
    baseline = "pc-skeletor's whole LBC run" if peer else "a reproduction of pc-skeletor's LBC solve"
    out(f"skelcore bench: torus (noise {noise:g}), whole `skelcore run` per process, solver {backend()}"
        + (", full resolution" if full_resolution else "") + f"; baseline: {baseline}"
        + ("" if compiled else "; skelcore's bytecode could not be written, so each run compiles its modules"))
    rows = []
    with tempfile.TemporaryDirectory(prefix="skelcore-bench-") as tmp:
        for n in sizes:
            cloud = _write_torus(Path(tmp), n, noise)
            for method in methods:
                rows.append(_child(n, ["run", str(cloud), method, str(Path(tmp) / f"{method}-{n}"),
                                       str(full_resolution)]))
                _print_run(rows[-1], out)
            lbc = next((row for row in rows if row["n"] == n and row["method"] == "lbc"), None)
            if n <= baseline_max and lbc is not None:
                if peer:
                    rows.append(_peer_child(n, peer, cloud, lbc["iterations"], Path(tmp) / f"pc-skeletor-{n}"))
                    stages = " | ".join(f"{key} {value:.2f}" for key, value in rows[-1]["stages"].items())
                    out(f"  pc-skeletor LBC, whole run, {lbc['iterations']} iterations: {rows[-1]['total']:.2f} s "
                        f"(CPU {rows[-1]['cpu']:.2f} s), peak {rows[-1]['peak_mb']:.0f} MB; {stages}")
                else:
                    rows.append(_child(n, ["baseline", str(cloud), str(lbc["iterations"])]))
                    out(f"  pc-skeletor LBC solve, {lbc['iterations']} iterations: {rows[-1]['total']:.2f} s "
                        f"(CPU {rows[-1]['cpu']:.2f} s), peak {rows[-1]['peak_mb']:.0f} MB")
    _print_summary(rows, sizes, methods, out)
    return rows


def compile_package() -> bool:
    """Write skelcore's bytecode (__pycache__) before the timed runs, as installing a package does; True when
    it is there. Without it every run would compile the modules from source (about 0.1 s of CPU): in a
    working copy run with PYTHONDONTWRITEBYTECODE set, no run ever writes it, while pc-skeletor's installed
    modules have theirs. False when the package's folder is read-only."""
    import compileall
    import io
    from contextlib import redirect_stdout

    with redirect_stdout(io.StringIO()):  # compileall names what it cannot write
        return bool(compileall.compile_dir(Path(__file__).parent, quiet=1, workers=1))


def _print_run(row: dict, out) -> None:
    stages = " | ".join(f"{stage} {row['stages'][stage]:.2f}" for stage in STAGES if stage in row["stages"])
    inner = " | ".join(f"{key} {value:.2f}" for key, value in row["contraction"].items())
    reduced = f", contracted {row['contracted_points']:,}" if row["contracted_points"] != row["n_input"] else ""
    out(f"{row['method']:>10} n={row['n']:,} ({row['n_input']:,} after cleaning{reduced}): whole {row['total']:.2f} s "
        f"(CPU {row['cpu']:.2f} s), peak {row['peak_mb']:.0f} MB, "
        f"{row['iterations']} iterations; {row['topology']}")
    out(f"{'':>12}stages: {stages}")
    out(f"{'':>12}inside contract: {inner}; share of the run in L's sparsity-pattern set-up, metrics (with the "
        f"evidence) and skeleton {row['overhead_share']:.0%}, with the one-rings and each step's Laplacian values "
        f"too {row['overhead_share_broad']:.0%}")


def _print_summary(rows: list[dict], sizes, methods, out) -> None:
    out("\nside by side (seconds of the whole run; ratios from this one bench run)")
    out(f"{'n':>10} " + " ".join(f"{m:>11}" for m in methods)
        + "  pc-skeletor  lbc/gls (time)  speed-up vs pc-skeletor")
    for n in sizes:
        runs = {row["method"]: row for row in rows if row["n"] == n and row["method"] in methods}
        base = next((row for row in rows if row["n"] == n and row["method"] == "baseline"), None)
        line = f"{n:>10,} " + " ".join(f"{runs[m]['total']:>11.2f}" if m in runs else f"{'':>11}" for m in methods)
        line += f"  {base['total']:>11.2f}" if base else f"  {'-':>11}"
        if "lbc" in runs and "glskeleton" in runs:
            line += f"  {runs['lbc']['total'] / runs['glskeleton']['total']:>15.2f}x"
        if base:
            line += "  " + ", ".join(f"{m} {base['total'] / runs[m]['total']:.1f}x "
                                     f"(CPU {base['cpu'] / runs[m]['cpu']:.1f}x)" for m in methods if m in runs)
        out(line)
    for method in methods:
        timed = sorted((row["n"], row["total"]) for row in rows if row["method"] == method)
        large = [pair for pair in timed if pair[0] >= 100_000]
        cpu = sorted((row["n"], row["cpu"]) for row in rows if row["method"] == method)
        large_cpu = [pair for pair in cpu if pair[0] >= 100_000]
        for label, pairs, cpu_pairs in (("all sizes", timed, cpu), ("from 100k", large, large_cpu)):
            if len(pairs) >= 2:
                out(f"{method}: whole run grows as n^{_exponent(pairs):.2f} (CPU n^{_exponent(cpu_pairs):.2f}; "
                    f"{label}, least squares on log-log)")


def _exponent(pairs) -> float:
    import numpy as np

    return float(np.polyfit(np.log([p[0] for p in pairs]), np.log([p[1] for p in pairs]), 1)[0])


def _write_torus(folder: Path, n: int, noise: float) -> Path:
    from .export import write_points_ply
    from .shapes import make_shape

    path = folder / f"torus-{n}.ply"
    write_points_ply(path, make_shape("torus", n, seed=0, noise=noise).points)
    return path


def _child(n: int, args: list[str]) -> dict:
    """Run one measurement in a fresh Python process; its last output line is the JSON result. `n`: the size
    asked for (cleaning may remove a few points)."""
    command = [sys.executable, "-m", "skelcore.bench", *args]
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, env=os.environ.copy())
    if done.returncode != 0:
        raise RuntimeError(f"bench child failed: {' '.join(args)}: {done.stderr.strip().splitlines()[-1:]}")
    result = json.loads(done.stdout.strip().splitlines()[-1])
    result["total"] = time.perf_counter() - started  # interpreter start and imports included
    result["n_input"], result["n"] = result["n"], n
    return result


# pc-skeletor's whole LBC run as its README shows it, in the peer's interpreter; its last line is the JSON result.
_PEER_RUN = """
import json, resource, sys, time
started = time.perf_counter()
import open3d as o3d
from pc_skeletor import LBC
path, iterations, out_dir = sys.argv[1], int(sys.argv[2]), sys.argv[3]
lbc = LBC(point_cloud=o3d.io.read_point_cloud(path), max_iteration_steps=iterations, down_sample=-1)
loaded = time.perf_counter()
lbc.extract_skeleton()
contracted = time.perf_counter()
lbc.extract_topology()
skeleton = time.perf_counter()
lbc.save(out_dir)
usage = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"stages": {"start and load": loaded - started, "contract": contracted - loaded,
                             "skeleton": skeleton - contracted, "write": time.perf_counter() - skeleton},
                  "peak_mb": usage.ru_maxrss / 1024.0, "cpu": usage.ru_utime + usage.ru_stime}))
"""


def _pc_skeletor_interpreter(python: str | None) -> str | None:
    """The interpreter to run pc-skeletor in: `python` (checked), else the current one if it has it, else None."""
    if python is None:
        import importlib.util

        return sys.executable if importlib.util.find_spec("pc_skeletor") else None
    from .errors import ParameterError

    try:
        probe = subprocess.run([python, "-c", "import pc_skeletor"], capture_output=True, text=True)
    except OSError as error:
        raise ParameterError(f"bench: --pc-skeletor {python} cannot be started ({error.strerror})") from None
    if probe.returncode != 0:
        last = (probe.stderr.strip().splitlines() or ["no message"])[-1]
        raise ParameterError(f"bench: --pc-skeletor {python} cannot import pc_skeletor ({last})")
    return python


def _peer_child(n: int, python: str, cloud: Path, iterations: int, out_dir: Path) -> dict:
    """pc-skeletor's whole run in a fresh process of `python`, timed like ours from launch to exit."""
    started = time.perf_counter()
    done = subprocess.run([python, "-c", _PEER_RUN, str(cloud), str(iterations), str(out_dir)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"pc-skeletor run failed on {n:,} points: {done.stderr.strip().splitlines()[-1:]}")
    result = json.loads(done.stdout.strip().splitlines()[-1])
    result.update(total=time.perf_counter() - started, n=n, method="baseline", iterations=iterations)
    return result


def _measure_run(cloud: str, method: str, out_dir: str, full_resolution: str) -> dict:
    """In the child: the whole pipeline as `skelcore run` does it, process start and exit included (with
    skelcore.cli.main's start-up and exit, skelcore.startup)."""
    from .params import ContractionParams
    from .options import RunOptions
    from .pipeline import run_pipeline

    startup.loaded()
    options = RunOptions(params=ContractionParams(method=method),
                         point_budget=None if full_resolution == "True" else RunOptions().point_budget)
    result = run_pipeline(cloud, out_dir, options)
    contraction: dict[str, float] = {}
    for state in result.states:
        for key, value in state.timings.items():
            contraction[key] = contraction.get(key, 0.0) + value
    # the verdict's skeleton evidence is part of judging the run, so it counts with the metrics
    overhead = (result.stages.get("metrics", 0) + result.stages.get("evidence", 0) + result.stages.get("skeleton", 0)
                + contraction.get("pattern", 0))
    broad = overhead + contraction.get("rings", 0) + contraction.get("laplacian", 0)
    topology = result.skeleton.topology()
    multires = result.metrics.get("multiresolution") or {}
    return {"n": len(result.cloud.points), "method": method, "iterations": result.states[-1].iteration,
            "stages": result.stages, "contraction": contraction, "overhead_share": overhead / _since_start(),
            "overhead_share_broad": broad / _since_start(),
            "contracted_points": multires.get("contracted_points", len(result.cloud.points)),
            "topology": f"{topology['cycles']} cycles, {topology['junctions']} junctions, {topology['ends']} ends"}


def _measure_baseline(cloud: str, iterations: str) -> dict:
    """In the child: pc-skeletor's LBC solve (module docstring) for the given number of iterations."""
    import numpy as np
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from . import io
    from .params import ContractionParams
    from .step import grown, schedule, start_run

    startup.loaded()
    points = io.load(cloud).points
    params = ContractionParams()
    run = start_run(points, params)
    current, sizes = run.unit, run.sizes0
    for iteration in range(1, int(iterations) + 1):
        wl, wh = schedule(params, run.auto_wl0, grown(1.0, params.sl, iteration - 1), run.sizes0, sizes)
        laplacian = run.builder.laplacian(current)
        system = sp.vstack([wl * laplacian, sp.diags(wh)]).tocsc()
        normal = (system.T @ system).tocsc()
        rhs = system.T @ np.vstack([np.zeros_like(current), wh[:, None] * current])
        current = np.column_stack([spla.spsolve(normal, rhs[:, axis], permc_spec="COLAMD") for axis in range(3)])
        sizes = run.rings.sizes(current)
    return {"n": len(points), "method": "baseline", "iterations": int(iterations)}


def _since_start() -> float:
    return time.perf_counter() - _STARTED


def _usage() -> tuple[float, float]:
    """Peak resident memory (MB) and CPU seconds (user + system, all threads) of this process."""
    import resource

    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_maxrss / 1024.0, usage.ru_utime + usage.ru_stime  # Linux reports KiB


_STARTED = time.perf_counter()

if __name__ == "__main__":
    startup.begin()
    kind, *arguments = sys.argv[1:]
    measure = {"run": _measure_run, "baseline": _measure_baseline}[kind]
    row = measure(*arguments)
    row["peak_mb"], row["cpu"] = _usage()
    print(json.dumps(row))
