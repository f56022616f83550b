"""The flags of one run on the command line (contraction, skeleton, sampling, cleaning, labels), shared by
`skelcore run` and `skelcore batch`, and the RunOptions they make."""
from __future__ import annotations

import argparse
import re

from .errors import SkelError
from .params import DEFAULT_K_RULE, METHODS, SEED, CleaningParams, ContractionParams


def add_parameter_flags(parser: argparse.ArgumentParser) -> None:
    """The contraction and skeleton flags shared by `run`, `batch` and `bench`."""
    from .io import MAX_POINTS
    from .skeleton import SkeletonParams
    from .surface_sampling import SURFACE_POINTS

    defaults = ContractionParams()
    group = parser.add_argument_group("contraction parameters")
    group.add_argument("--method", choices=METHODS, default=defaults.method,
                       help="lbc: Cao et al. 2010; glskeleton: Wen et al. 2024 with in-loop point reduction "
                            "(default: %(default)s)")
    group.add_argument("--k", type=int, default=None,
                       help=f"neighbours per one-ring (default: {DEFAULT_K_RULE})")
    group.add_argument("--wl0", type=float, default=None,
                       help="initial contraction weight W_L0 (default: 1 / (5 * mean one-ring edge length))")
    group.add_argument("--wh0", type=float, default=defaults.wh0,
                       help="initial attraction weight W_H0 (default: %(default)s)")
    group.add_argument("--sl", type=float, default=defaults.sl,
                       help="W_L amplification per iteration s_L (default: %(default)s)")
    group.add_argument("--wl-max", type=float, default=defaults.wl_max, help="cap on W_L (default: %(default)s)")
    group.add_argument("--max-iterations", type=int, default=defaults.max_iterations,
                       help="most contraction iterations (default: %(default)s)")
    group.add_argument("--termination", type=float, default=defaults.termination,
                       help="stop when the one-ring size ratio falls by less than this (default: %(default)s)")
    group.add_argument("--curve-share", type=float, default=defaults.curve_share,
                       help="the ring-ratio rule stops a run only once this share of the cloud is curve-like "
                            "(0: cloudcontr's rule alone) (default: %(default)s)")
    group.add_argument("--hold-curves", action=argparse.BooleanOptionalAction, default=defaults.hold_curves,
                       help="points that the first step brought to a thin part's axis keep that step's W_L, and "
                            "handles of the input thinner than a skeleton ball stay in place (shown on their axis), "
                            "so small handles and limbs' ends are not shortened away while bulkier parts contract "
                            "(--no-hold-curves: W_L rises everywhere, as in cloudcontr) (default: %(default)s)")
    group.add_argument("--hold-inside", action=argparse.BooleanOptionalAction, default=None,
                       help="points a step would take out of the original solid go to the nearest point of its medial "
                            "surface instead, which keeps loops that contraction closes (a bore longer than wide), "
                            "with spurs (default: off, and tried by itself when the skeleton keeps fewer loops than "
                            "the solid has: a closed mesh's genus, or those a closed point cloud's inside test "
                            "reads; either flag decides instead)")
    group.add_argument("--balance-density", action=argparse.BooleanOptionalAction, default=defaults.balance_density,
                       help="weight each point's attraction by the surface area it stands for, so that a sparsely "
                            "sampled part contracts at the pace of a densely sampled one (--no-balance-density: every "
                            "point weighs the same, as in cloudcontr) (default: %(default)s)")
    group.add_argument("--drop-jumps", action=argparse.BooleanOptionalAction, default=defaults.drop_jumps,
                       help="drop the one-ring edges whose middle has no input point within the local sampling's "
                            "reach, so that rings do not join parts across empty space (--no-drop-jumps: "
                            "cloudcontr's one-rings) (default: %(default)s)")
    group.add_argument("--gl-merge", type=float, default=defaults.gl_merge,
                       help="glskeleton: a point absorbs its nearest ring neighbour when its merge score is below "
                            "this times its squared ring size (default: %(default)s)")
    group.add_argument("--gl-covariance", type=float, default=defaults.gl_covariance,
                       help="glskeleton: stop when the cloud's covariance score changes by less than this "
                            "(default: %(default)s)")
    group.add_argument("--gl-merge-share", type=float, default=defaults.gl_merge_share,
                       help="glskeleton: the largest share of points that may qualify to absorb a neighbour in one "
                            "step, the best merge scores; of them the curve-like ones merge (1: no cap) "
                            "(default: %(default)s)")
    group.add_argument("--sample-radius", type=float, default=SkeletonParams.sample_radius,
                       help="skeleton sample radius, a fraction of the object's bounding-box diagonal, far strays "
                            "left out (default: %(default)s)")
    group.add_argument("--seed", type=random_seed, default=SEED,
                       help="seed for every random choice (default: %(default)s)")
    group.add_argument("--sample", type=int, default=None,
                       help="for a mesh input: sample this many points evenly over its surface instead of its "
                            "vertices; 0: its vertices (default: its vertices where they cover its surface, else as "
                            f"many points as it has vertices, at least {SURFACE_POINTS}, drawn evenly)")
    group.add_argument("--voxel-size", type=float, default=None,
                       help="downsample the input to one point per voxel of this size")
    group.add_argument("--max-points", type=int, default=MAX_POINTS,
                       help="largest cloud accepted (default: %(default)s)")
    group.add_argument("--drop-nonfinite", action="store_true",
                       help="leave out points with NaN or Inf coordinates (a depth camera's organised cloud holds them "
                            "for pixels without depth) instead of refusing the file")
    group.add_argument("--no-denoise", action="store_true",
                       help="keep the points where they are (by default each is projected once onto the PCA plane "
                            "of its neighbours where they have one, which removes sampling noise; a large cloud's "
                            "voxel centroids too)")
    group.add_argument("--no-outlier-removal", action="store_true",
                       help="keep points far from their neighbours (removed by default: statistical outliers)")
    group.add_argument("--no-stray-removal", action="store_true",
                       help="keep small pieces apart from the object (removed by default: pieces under "
                            f"{CleaningParams.min_piece_share * 100:g}%% of the points)")
    group.add_argument("--labels", metavar="FILE|PROPERTY", default=None,
                       help="per-point integer labels: a file (.txt .csv .labels: one per line in the input's point "
                            "order; .npy), a vertex property of a PLY input (default: the PLY's label, class, "
                            "scalar_label, ... property when present) or a point dimension of a LAS or LAZ input "
                            "(classification, or an extra dimension such as a tree id)")
    group.add_argument("--label-weight", metavar="LABEL=W", action="append", default=[], type=label_weight,
                       help="contraction weight of the points labelled LABEL (a multiplier of W_L on their Laplacian "
                            "rows, as pc-skeletor's semantic LBC); repeat for several labels; unnamed labels keep 1")
    from .multires import POINT_BUDGET

    group.add_argument("--point-budget", type=int, default=POINT_BUDGET,
                       help="larger clouds are contracted as voxel centroids of about this many points, every input "
                            "point carried along (multi-resolution; 0: never, as --full-resolution; default: "
                            "%(default)s)")
    group.add_argument("--full-resolution", action="store_true",
                       help="contract every input point, whatever the cloud's size or density (no multi-resolution, "
                            "dense parts not thinned)")


def contraction_params(args: argparse.Namespace) -> ContractionParams:
    """The ContractionParams of the parsed contraction flags, validated."""
    return ContractionParams(method=args.method, k=args.k, wl0=args.wl0, wh0=args.wh0, sl=args.sl, wl_max=args.wl_max,
                             max_iterations=args.max_iterations, termination=args.termination,
                             curve_share=args.curve_share,
                             hold_curves=args.hold_curves, hold_inside=bool(args.hold_inside),
                             balance_density=args.balance_density,
                             drop_jumps=args.drop_jumps, gl_merge=args.gl_merge, gl_covariance=args.gl_covariance,
                             gl_merge_share=args.gl_merge_share).validated()


def run_options(args: argparse.Namespace):
    """The RunOptions (contraction, skeleton, sampling, labels) of the parsed flags."""
    from .options import RunOptions

    cleaning = CleaningParams(remove_outliers=not args.no_outlier_removal, remove_stray=not args.no_stray_removal,
                              denoise=not args.no_denoise)
    return RunOptions(params=contraction_params(args), sample_radius=args.sample_radius, seed=args.seed,
                      sample=args.sample, voxel_size=args.voxel_size, max_points=args.max_points, cleaning=cleaning,
                      labels=args.labels, label_weights=tuple(sorted(dict(args.label_weight).items())),
                      point_budget=None if args.full_resolution else args.point_budget,
                      drop_nonfinite=args.drop_nonfinite, hold_retry=args.hold_inside is None)


def random_seed(text: str) -> int:
    """A random seed: an integer >= 0 (numpy refuses negative ones)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid seed {text!r}: give an integer >= 0") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"invalid seed {value}: give an integer >= 0")
    return value


def negative_labels_attached(argv: list[str]) -> list[str]:
    """argv with `--label-weight -5=2` written as `--label-weight=-5=2`: argparse reads a value that starts with a
    dash and is no plain negative number as an option, so it would stop at "expected one argument"."""
    joined = []
    for token in argv:
        if joined and joined[-1] == "--label-weight" and re.match(r"-\d", token):
            joined[-1] = f"--label-weight={token}"
        else:
            joined.append(token)
    return joined


def label_weight(text: str) -> tuple[int, float]:
    """A --label-weight value, LABEL=W, as (label, weight), or argparse's refusal in the labels' words."""
    from .labels import parse_label_weight

    try:
        return parse_label_weight(text)
    except SkelError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
