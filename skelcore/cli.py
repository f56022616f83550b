"""The `skelcore` command line: run, batch, shapes, evaluate, report, bench, bench-quality, study.

Bad input ends with a one-line message naming the file and the problem and a non-zero exit code;
no traceback reaches the user.
"""
from __future__ import annotations

import argparse
import os
import sys
import traceback

from . import startup
from .errors import NonFiniteError, SkelError, TooLargeError
from .formats import FORMATS
from .run_flags import add_parameter_flags, negative_labels_attached, random_seed, run_options

EXIT_INPUT = 2
EXIT_INTERNAL = 3


def default_of(function, parameter: str):
    """The default of a function's parameter: a command's flag defaults to what the function it calls does."""
    import inspect

    return inspect.signature(function).parameters[parameter].default


def _point_count(text: str) -> int:
    """A number of points to make: between the fewest a run needs and the most a cloud may hold (skelcore.io)."""
    from .io import MAX_POINTS, MIN_POINTS

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid point count {text!r}: give an integer") from None
    if not MIN_POINTS <= value <= MAX_POINTS:
        raise argparse.ArgumentTypeError(f"{value} points: give between {MIN_POINTS} and {MAX_POINTS:,}")
    return value


class OneLineParser(argparse.ArgumentParser):
    """argparse's parser, whose refusal of the command line is one line (argparse prints its whole usage first)."""

    def error(self, message: str):
        """Say `message` in one line, pointing at --help, and exit with status 2 (as argparse does)."""
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The argparse parser of every `skelcore` sub-command."""
    parser = OneLineParser(prog="skelcore", description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)

    run = commands.add_parser("run", help="contract one cloud and extract its curve skeleton")
    run.add_argument("input", help=f"point cloud or mesh ({' '.join(FORMATS)})")
    run.add_argument("--out", required=True, help="output folder")
    run.add_argument("--quiet", action="store_true", help="no progress lines")
    run.add_argument("--force", action="store_true",
                     help="replace the results of an earlier run in --out (without it such a folder is refused)")
    add_parameter_flags(run)
    run.set_defaults(handler=_run)

    from .bench import BASELINE_MAX, NOISE, SIZES
    from .params import METHODS

    bench = commands.add_parser("bench", help="time whole runs per stage on noisy tori, LBC and GLSkeleton, "
                                               "against pc-skeletor's LBC, with peak memory and growth")
    bench.add_argument("--points", type=_point_count, nargs="+", default=list(SIZES), help="cloud sizes (default: %(default)s)")
    bench.add_argument("--method", choices=[*METHODS, "both"], default="both")
    bench.add_argument("--baseline-max", type=int, default=BASELINE_MAX,
                       help="time pc-skeletor's LBC up to this many points (0: never; default: %(default)s)")
    bench.add_argument("--pc-skeletor", metavar="PYTHON", default=None,
                       help="a Python interpreter with pc-skeletor installed: the baseline is then its whole LBC run "
                            "(default: this interpreter if it has pc-skeletor, else a reproduction of its solve)")
    bench.add_argument("--full-resolution", action="store_true", help="contract every point (no multi-resolution)")
    bench.add_argument("--noise", type=float, default=NOISE,
                       help="Gaussian noise of the tori, a fraction of the bounding-box diagonal (default: %(default)s)")
    bench.set_defaults(handler=_bench)

    # -- bench-quality (skelcore.quality_bench) --
    from .quality_bench import BENCH_VARIANTS, NAMED_VARIANTS, run_quality_bench
    from .solids import DEFAULT_POINTS

    quality = commands.add_parser("bench-quality",
                                  help="skeleton topology on shapes of known genus, clean and scan-like: one table")
    quality.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS), help="(default: both)")
    quality.add_argument("--shapes", nargs="+", default=None, metavar="NAME",
                         help="shapes to run (default: every solid, and the reference shapes when "
                              "../shared/reference exists or --reference is given; the everyday parts, held-out "
                              "shapes and household objects by name)")
    quality.add_argument("--parts", action="store_true",
                         help="run the everyday parts (wrench, key, nut, pipe, ...), the held-out shapes (kettle, "
                              "trophy, ring chain, ...: skelcore.parts) and the household objects (trivet, pot, "
                              "towel ring, ...: skelcore.household), not in the default set, instead of the "
                              "default shapes")
    quality.add_argument("--variants", nargs="+", choices=NAMED_VARIANTS, default=list(BENCH_VARIANTS),
                         metavar="VARIANT", help=f"of: {' '.join(NAMED_VARIANTS)} ('mesh': the shape's mesh file "
                                                 f"itself, sampled by the loader; 'two_scans', 'layered' and "
                                                 f"'scan_lines', the mesh cut into a profile scanner's lines, only "
                                                 f"when named) (default: {' '.join(BENCH_VARIANTS)})")
    quality.add_argument("--points", type=_point_count, default=DEFAULT_POINTS, help="points per shape (default: %(default)s)")
    quality.add_argument("--seeds", type=random_seed, nargs="+", default=list(default_of(run_quality_bench, "seeds")),
                         metavar="SEED", help="draws of the shapes' samples and of the variants, each a run of the "
                                              f"whole grid (default: {' '.join(map(str, default_of(run_quality_bench, 'seeds')))})")
    quality.add_argument("--workers", type=int, default=default_of(run_quality_bench, "workers"),
                         help="runs in parallel processes (default: %(default)s)")
    quality.add_argument("--reference", default=None, metavar="DIR",
                         help="folder of the reference meshes and scans (default: ../shared/reference)")
    quality.add_argument("--json", default=None, metavar="OUT", help="also write every run and the summary here")
    quality.add_argument("--out", default=None, metavar="DIR", help="keep each run's result folder here")
    quality.add_argument("--quiet", action="store_true", help="no progress lines")
    quality.set_defaults(handler=_bench_quality)

    # -- shapes (skelcore.shapes) --
    from .shapes import SHAPE_POINTS, SHAPES, write_shapes

    shapes = commands.add_parser("shapes", help="write point clouds sampled on tubes around known centrelines")
    shapes.add_argument("--out", required=True, help="output folder: NAME.ply (points) and NAME_centreline.json per shape")
    shapes.add_argument("--names", nargs="+", default=list(SHAPES), metavar="NAME",
                        help=f"shapes to write, of: {' '.join(SHAPES)} (default: all)")
    shapes.add_argument("--n", type=_point_count, default=SHAPE_POINTS, help="points per shape (default: %(default)s)")
    shapes.add_argument("--seed", type=random_seed, default=default_of(write_shapes, "seed"),
                        help="random seed (default: %(default)s)")
    shapes.add_argument("--noise", type=float, default=default_of(write_shapes, "noise"),
                        help="std of Gaussian noise, a fraction of the bounding-box diagonal (default: %(default)s)")
    shapes.add_argument("--nonuniform", type=float, default=default_of(write_shapes, "nonuniform"),
                        help="in [0, 1): sampling density falls linearly along x from 1 to 1 - this (default: %(default)s)")
    shapes.add_argument("--force", action="store_true", help="replace shape files already in --out")
    shapes.set_defaults(handler=_shapes)
    # -- evaluate (skelcore.evaluate) --
    evaluate = commands.add_parser("evaluate", help="score a skeleton against a ground-truth curve: distances and topology")
    evaluate.add_argument("skeleton", help="skeleton.json, or .ply with vertex and edge elements")
    evaluate.add_argument("truth", help="ground truth: NAME_centreline.json, skeleton .json/.ply, rig .skeleton or .tgf")
    evaluate.add_argument("--json", action="store_true", help="print the result as JSON instead of a table")
    evaluate.set_defaults(handler=_evaluate)
    # -- report (skelcore.report) --
    report = commands.add_parser("report", help="write one HTML page of the paper's figures and verdicts for run folders")
    report.add_argument("run_dirs", nargs="+", metavar="RUN_DIR", help="output folders of `skelcore run`")
    report.add_argument("--out", default="report.html", help="HTML file to write (default: %(default)s)")
    report.set_defaults(handler=_report)
    # -- batch (skelcore.batch) --
    batch = commands.add_parser("batch", help="run the pipeline over many objects: summary, comparison report, resumable, Dask")
    batch.add_argument("inputs", nargs="+", metavar="INPUT",
                       help="files, folders (their point cloud and mesh files) or quoted glob patterns ('data/**/*.ply')")
    batch.add_argument("--out", required=True,
                       help="output folder: OUT/<object>/ as `run` writes it, summary.csv, summary.json, report.html")
    batch.add_argument("--force", action="store_true", help="redo objects already done with the same parameters")
    batch.add_argument("--quiet", action="store_true", help="no progress bar")
    batch.add_argument("--no-report", action="store_true", help="skip report.html (for very large batches)")
    where = batch.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, nargs="?", const=0, default=None, metavar="N",
                       help="run on a local Dask cluster of N one-thread worker processes (no N: one per CPU core)")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="run on an existing Dask cluster (tcp://HOST:PORT); INPUTs and OUT must be at the same "
                            "path on every worker")
    add_parameter_flags(batch)
    batch.set_defaults(handler=_batch)
    # -- study (skelcore.study) --
    from .study import SETTINGS, STUDY_POINTS, run_study

    study = commands.add_parser("study", help="measure the verdict's criteria against ground truth over a grid of "
                                              "shapes, variants, seeds and settings; calibrate the thresholds")
    study.add_argument("--out", required=True, help="output folder: runs.jsonl (resumable), study.csv, study.json, "
                                                    "thresholds.json, study.html")
    study.add_argument("--points", type=_point_count, default=STUDY_POINTS, help="points per cloud (default: %(default)s)")
    study.add_argument("--seeds", type=random_seed, nargs="+", default=list(default_of(run_study, "seeds")),
                       help=f"sampling seeds (default: {' '.join(map(str, default_of(run_study, 'seeds')))})")
    study.add_argument("--settings", nargs="+", default=list(SETTINGS), metavar="SETTING",
                       help=f"parameter settings, of: {'; '.join(SETTINGS)} (default: all)")
    study.add_argument("--shapes", nargs="+", default=None, metavar="NAME", help="synthetic or benchmark shapes (default: all)")
    study.add_argument("--no-benchmark", action="store_true", help="leave out the real-shape benchmark")
    study.add_argument("--jobs", type=int, default=default_of(run_study, "jobs"),
                       help="worker processes (default: %(default)s)")
    study.set_defaults(handler=_study)
    return parser


def _run(args: argparse.Namespace) -> int:
    from .api import run
    from .results import check_output
    from .verdict import failed_line

    check_output(args.out, force=args.force)  # before the work; the earlier results go only once it succeeded
    progress = None if args.quiet else print
    result = run(args.input, run_options(args), progress=progress)
    out = result._save(args.out, args.force)  # results that appeared meanwhile are refused in the CLI's terms
    if not args.quiet:
        print(f"{result.summary()} -> {out}")
        failed = failed_line(result.verdict)
        if failed:  # what a verdict other than stable rests on, without opening metrics.json
            print(f"  {result.verdict['label']}: {failed}")
    return 0


def _bench(args: argparse.Namespace) -> int:
    from .bench import run_bench
    from .params import METHODS

    methods = METHODS if args.method == "both" else (args.method,)
    run_bench(args.points, methods=methods, full_resolution=args.full_resolution, noise=args.noise,
              baseline_max=args.baseline_max, pc_skeletor=args.pc_skeletor)
    return 0


def _bench_quality(args: argparse.Namespace) -> int:
    import time

    from pathlib import Path

    from .errors import InputError, OutputError, ParameterError
    from .quality_bench import format_table, run_quality_bench, summarise, write_json
    from .paths import writable_folder

    if args.json is not None:  # checked before the runs: a bad path would otherwise lose them at the end
        writable_folder(Path(args.json).resolve().parent, "--json")
        if Path(args.json).is_dir():
            raise OutputError(f"--json {args.json}: is a folder, not a file")
    if args.out is not None:  # else every run would fail to write there and the table say ERROR
        writable_folder(args.out, "--out")
    if args.reference is not None and not Path(args.reference).is_dir():  # else: silently no reference shapes
        raise InputError(f"--reference {args.reference}: no such folder")
    if args.parts:
        if args.shapes is not None:
            raise ParameterError("--parts and --shapes: choose one (name parts in --shapes to run some of them)")
        from .solids import EVERYDAY

        args.shapes = list(EVERYDAY)
    started = time.perf_counter()
    progress = None if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    results = run_quality_bench(methods=args.methods, shapes=args.shapes, variants=args.variants,
                                points=args.points, seeds=args.seeds, workers=args.workers,
                                reference_dir=args.reference, keep_dir=args.out, progress=progress)
    summary = summarise(results)
    print(format_table(results, summary, time.perf_counter() - started))
    if args.json:
        keys = ("methods", "shapes", "variants", "points", "seeds", "workers")
        settings = {key: getattr(args, key) for key in keys}
        print(write_json(args.json, results, summary, settings))
    return 0


def _shapes(args: argparse.Namespace) -> int:
    from .errors import OutputError
    from .paths import writable_folder
    from .shapes import write_shapes

    out = writable_folder(args.out, "--out")
    taken = [out / f"{name}{suffix}" for name in args.names for suffix in (".ply", "_centreline.json")
             if (out / f"{name}{suffix}").exists()]
    if taken and not args.force:
        raise OutputError(f"{taken[0]}: already there; choose another folder or pass --force to replace it")
    for path in write_shapes(args.out, args.names, args.n, seed=args.seed, noise=args.noise, nonuniform=args.nonuniform):
        print(path)
    return 0


def _evaluate(args: argparse.Namespace) -> int:
    import json

    from .evaluate import evaluate_files, format_report

    result = evaluate_files(args.skeleton, args.truth)
    print(json.dumps(result, indent=2) if args.json else format_report(result))
    return 0


def _report(args: argparse.Namespace) -> int:
    from .report import write_report

    print(write_report(args.run_dirs, args.out))
    return 0


def _batch(args: argparse.Namespace) -> int:
    from .batch import run_batch

    result = run_batch(args.inputs, args.out, run_options(args), workers=args.workers, scheduler=args.scheduler,
                       force=args.force, progress=not args.quiet, report=not args.no_report)
    print(result.summary_line())
    return 1 if result.failed else 0


def _study(args: argparse.Namespace) -> int:
    from .study import run_study

    run_study(args.out, points=args.points, seeds=tuple(args.seeds), settings=tuple(args.settings),
              shapes=args.shapes, benchmark=not args.no_benchmark, jobs=args.jobs)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code (0 ok, 1 some batch objects failed, 2 bad input or parameters, 130 interrupted).
    Without `argv` (a process of its own: the console script, `python -m skelcore.cli`) the process starts and
    exits without the garbage collector's futile passes over the loaded modules (skelcore.startup)."""
    own_process = argv is None
    if own_process:
        startup.begin()
    parser = build_parser()
    args = parser.parse_args(negative_labels_attached(sys.argv[1:] if argv is None else argv))
    if own_process:
        if args.command in ("run", "batch"):
            from . import pipeline  # noqa: F401 -- the run's modules, loaded before the collector runs again
        startup.loaded()
    try:
        return args.handler(args)
    except SkelError as error:
        advice = (f" (--voxel-size {error.voxel_size:g}, or raise --max-points)" if isinstance(error, TooLargeError)
                  else " (--drop-nonfinite leaves them out)" if isinstance(error, NonFiniteError) else "")
        print(f"skelcore {args.command}: error: {error}{advice}", file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        print(f"skelcore {args.command}: interrupted", file=sys.stderr)
        return 130
    except BaseException as error:  # noqa: BLE001 -- no traceback reaches the user, whatever failed
        if isinstance(error, SystemExit):
            raise
        print(f"skelcore {args.command}: error: {unexpected_words(error)}", file=sys.stderr)
        if os.environ.get("SKELCORE_TRACEBACK"):
            traceback.print_exc()
        return EXIT_INTERNAL


def unexpected_words(error: BaseException) -> str:
    """An error skelcore did not foresee, in one line of our words (no C++ names, no source paths)."""
    text = " ".join(str(error).split())
    if isinstance(error, MemoryError) or "bad_alloc" in text:
        return "ran out of memory; downsample the input (--voxel-size) or lower --max-points"
    if isinstance(error, OSError):
        where = f"{error.filename}: " if error.filename else ""
        return f"{where}{error.strerror or 'input/output error'}"
    if isinstance(error, RecursionError):
        return "the input is nested too deeply to process"
    return (f"internal error ({type(error).__name__}); please report it with the input and command "
            f"(set SKELCORE_TRACEBACK=1 to see where it happened)")


if __name__ == "__main__":
    sys.exit(main())
