"""How curve-like a contracted cloud is, at the scale the skeleton samples it.

A point is curve-like when its neighbourhood within the skeleton's sample radius is a segment, not a
patch of sheet or a blob: the PCA spread across the curve (sqrt of the middle eigenvalue) is at most
CURVE_RATIO times the spread along it (sqrt of the largest). At that ratio a ball of the sample radius
sees a cross-section under about a quarter of its diameter, thin enough that one skeleton sample covers
it. The share of curve-like points tells whether a contraction has reached curves (share near 1) or
stopped at a sheet.

`skeleton_scale_share` is the one curve-likeness every figure reports (metrics.json, the verdict, the
inspector): the share at the skeleton's default sample radius, a fraction of the INPUT cloud's diagonal.

`thin_parts` finds the points a first contraction step has already brought to the axis of a thin part (a handle,
a limb): the points whose W_L the contraction may hold (skelcore.step.hold_curves).

`thin_tubes` finds, on the input itself, the handles thinner than the skeleton or the contraction resolves:
where the input's cross-section across the part is a hollow curve within one sample radius of its centre, or
within the reach of the one-rings' neighbourhoods where the input is sparser, the skeleton draws the part as a
curve through those centroids (recentred nodes) whatever the contraction does, so contraction there can only do
harm: a few points around, such a tube's one-rings (the PCA plane of k neighbours) lie flat over it, so the
first steps barely contract it, and later ones shorten it shut as a curve-shortening flow while the bulk beside
it contracts (skelcore.step.anchored keeps it in place, and each state shows it on its axis). The cross-section
tells them from a sheet or a bulky part (their cross-section runs on past the radius) and from a crease, a strip
or a twig one point wide (their cross-section has points at its centre). Only thin parts that close a loop of
the input are kept: a limb or a tail ends, and the hold above keeps its end.
"""
from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix, csr_array
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from . import density
from .distinct import distinct_rows
from .normalise import SAMPLE_RADIUS

CURVE_RATIO = 0.25  # spread across / spread along, at most, for a curve-like neighbourhood
PROBES = 2000  # points whose neighbourhoods are measured (a fixed random subset; all when fewer)
MIN_NEIGHBOURS = 8  # probes within the radius needed to judge; fewer: spread too thin to be a curve there
NEAREST_INPUT = 30  # input points that judge whether a contracted point is surrounded (cloudcontr's k)
SURROUNDED = 0.5  # length of the mean unit direction to them, below which they lie on all sides
MIN_CURVE_RADII = 2.0  # a thin part spans at least this many sample radii: two skeleton edges
HOLLOW = 1 / 3  # a closed cross-section's points lie at least this share of their mean distance from its centre,
STRAY = 0.1  # all but at most this share of them (noise scatters a few of a wall's points inwards)


def probe_ids(count: int, seed: int = 0) -> np.ndarray:
    """The ids of the probes among `count` points: a fixed random subset of PROBES, all when fewer."""
    rng = np.random.default_rng(seed)
    return np.sort(rng.choice(count, PROBES, replace=False)) if count > PROBES else np.arange(count)


def curve_likeness(points: np.ndarray, radius: float, seed: int = 0, among_all: bool = False,
                   tree: cKDTree | None = None, radii: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(probe ids, spread ratio across/along of each probe's neighbourhood, and with `among_all` its direction
    along (unit, (p, 3); NaN without)). The neighbourhood is the probes within `radius`, or with `among_all` every
    point within it (`tree`: a cKDTree over `points`, when the caller has one; `radii`: each probe's own radius
    instead, (p,) for the probes of probe_ids); the ratio is NaN where it has fewer than MIN_NEIGHBOURS."""
    probes = probe_ids(len(points), seed)
    sample = points[probes]
    probe_tree = cKDTree(sample)
    members = points if among_all else sample
    others = (cKDTree(points) if tree is None else tree) if among_all else probe_tree
    rows, cols = _within(probe_tree, others, np.full(len(probes), radius) if radii is None else radii)
    if not among_all:  # each probe with every probe within radius, itself included
        rows, cols = np.concatenate([rows, np.arange(len(sample))]), np.concatenate([cols, np.arange(len(sample))])
    counts = np.bincount(rows, minlength=len(sample)).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.stack([np.bincount(rows, members[cols, axis], len(sample)) for axis in range(3)], 1) / counts[:, None]
        offset = members[cols] - mean[rows]
        covariance = np.stack([np.bincount(rows, offset[:, i] * offset[:, j], len(sample))
                               for i in range(3) for j in range(3)], 1).reshape(-1, 3, 3) / counts[:, None, None]
    covariance[counts == 0] = 0.0
    if among_all:
        eigen, vectors = np.linalg.eigh(covariance)  # ascending
    else:  # the figures every run reports: the eigenvalues alone
        eigen, vectors = np.linalg.eigvalsh(covariance), np.full((len(sample), 3, 3), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.sqrt(np.maximum(eigen[:, 1], 0) / eigen[:, 2])
    ratio[(counts < MIN_NEIGHBOURS) | ~(eigen[:, 2] > 0)] = np.nan
    return probes, ratio, vectors[:, :, 2]


def curve_like_points(points: np.ndarray, radius: float, seed: int = 0, at: np.ndarray | None = None) -> np.ndarray:
    """(n,) whether each point is curve-like, or (len(at),) each of the points of ids `at`: the judgement of its
    nearest probe (the probes are an even random subset, so a point's nearest probe lies within a probe spacing and
    sees the same neighbourhood)."""
    probes, ratio, _ = curve_likeness(points, radius, seed)
    return _nearest_probe(points, probes, ratio <= CURVE_RATIO, at)


def _nearest_probe(points: np.ndarray, probes: np.ndarray, judged: np.ndarray, at: np.ndarray | None = None
                   ) -> np.ndarray:
    """The judgement of the nearest probe of each point (of ids `at`; None: all)."""
    if len(probes) == len(points):  # every point is a probe, in order
        return judged if at is None else judged[at]
    _, nearest = cKDTree(points[probes]).query(points if at is None else points[at], workers=-1)
    return judged[nearest]


def curve_share(points: np.ndarray, radius: float, seed: int = 0) -> float:
    """The share of measured points whose neighbourhood is curve-like (see the module); a point too isolated
    to be judged counts as not curve-like."""
    _, ratio, _ = curve_likeness(points, radius, seed)
    return float((ratio <= CURVE_RATIO).mean()) if len(ratio) else 0.0


def skeleton_scale_share(points: np.ndarray, diagonal: float, seed: int = 0) -> float:
    """curve_share of `points` at the skeleton's default sample radius, taken as that fraction of `diagonal`,
    the input cloud's object diagonal (skelcore.normalise.object_diagonal): the scale at which the skeleton
    samples the contracted cloud."""
    return curve_share(points, SAMPLE_RADIUS * diagonal, seed)


def thin_parts(contracted: np.ndarray, original: np.ndarray, radius: float) -> np.ndarray:
    """(n,) whether each contracted point lies on the axis of a thin part of the input, judged after the first
    contraction step. Such a point is
    - curve-like at `radius` (one step made it so: the part's cross-section is a few ring spacings),
    - surrounded by the input: the unit directions from it to its NEAREST_INPUT nearest input points average to
      a vector shorter than SURROUNDED, as around a tube's axis, and not one-sided, as on the rim of an open
      scan or the edge of a sheet, which also contract to curves first,
    - in a piece of such points (within `radius` of each other) spanning at least MIN_CURVE_RADII radii: shorter
      pieces are bumps the skeleton could not draw as a curve anyway."""
    thin = np.zeros(len(contracted), dtype=bool)
    candidates = np.flatnonzero(curve_like_points(contracted, radius))
    if len(candidates) == 0:
        return thin
    _, nearest = cKDTree(original).query(contracted[candidates], min(NEAREST_INPUT, len(original)), workers=-1)
    directions = original[nearest.reshape(len(candidates), -1)] - contracted[candidates, None]
    directions /= np.maximum(np.linalg.norm(directions, axis=2, keepdims=True), 1e-300)
    candidates = candidates[np.linalg.norm(directions.mean(axis=1), axis=1) < SURROUNDED]
    if len(candidates) == 0:
        return thin
    long_enough, _ = _long_pieces(contracted[candidates], radius)
    thin[candidates[long_enough]] = True
    return thin


def _long_pieces(positions: np.ndarray, radius: float, reach: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(whether each position lies in a piece spanning at least MIN_CURVE_RADII radii, its piece): pieces are the
    positions joined by steps within `radius` (or within the larger `reach` (m,) of a step's two ends), their span
    the longest side of their bounding box."""
    tree = cKDTree(positions)
    joins = np.full(len(positions), radius) if reach is None else reach
    pairs = tree.sparse_distance_matrix(tree, float(joins.max(initial=radius)), output_type="coo_matrix")
    near = pairs.data <= np.maximum(joins[pairs.row], joins[pairs.col])
    count, piece = connected_components(
        coo_matrix((pairs.data[near], (pairs.row[near], pairs.col[near])), shape=pairs.shape), directed=False)
    low, high = np.full((count, 3), np.inf), np.full((count, 3), -np.inf)
    np.minimum.at(low, piece, positions)
    np.maximum.at(high, piece, positions)
    return (high - low).max(axis=1)[piece] >= MIN_CURVE_RADII * radius, piece


def thin_tubes(points: np.ndarray, radius: float, edges: np.ndarray, k: int) -> np.ndarray:
    """(n, 3) for each input point on a handle thinner than the skeleton or the contraction resolves (module
    docstring), the nearest point of its axis; NaN for the others. Judged at the probes (curve_likeness), each at
    its own scale: `radius`, or where the input is sparser, the reach of its one-ring's neighbourhood (the distance
    to its `k`-th nearest input point, the run's k), capped at MIN_CURVE_RADII radii (a part is drawn as a curve
    only when it is longer than that). A tube within that reach is one the one-rings' PCA planes lie flat over,
    so the contraction cannot draw it whatever the skeleton's radius; and the judgement sees the same number of
    points, at least k, on a sparse part as on a dense one (a fixed radius counts fewer there, too few to judge).
    The direction along a probe's part is the principal direction of the input within its scale, and its
    cross-section the input within twice the scale and within half of it of the plane through the probe across
    that direction. The part is thin where that cross-section holds at least MIN_NEIGHBOURS points, lies within
    the scale of its centre and is hollow (at most a share STRAY of its points nearer the centre than HOLLOW
    of their mean distance to it). A point is thin when most probes judged within their scale of it are, and its
    axis is its nearest probe's, the line along the direction through the centroid. Thin pieces (points within
    their scale of each other) spanning less than MIN_CURVE_RADII radii are left out, a bump the skeleton could
    not draw as a curve; and so are those that close no loop of the input (`_closing_loops`, over its surface
    `edges` (e, 2)): a limb or a tail ends, and the hold (thin_parts) keeps its end.

    A part far denser than the rest (skelcore.density: a small object beside a large one, a patch a scanner
    dwelt on) is judged on a copy thinned to the density cap, each of its points taking the anchor of its nearest
    point kept: every probe there would see all of its points, and the work and memory grew as their square."""
    kept = density.capped(points, radius / density.CELLS_PER_RADIUS)
    if kept is None:
        return _thin_tubes_judged(points, radius, edges, k)
    representative = np.empty(len(points), dtype=np.int64)
    representative[kept] = np.arange(len(kept))
    dropped = np.setdiff1d(np.arange(len(points)), kept)
    representative[dropped] = cKDTree(points[kept]).query(points[dropped], workers=-1)[1]
    joined = representative[edges]
    joined = distinct_rows(np.sort(joined[joined[:, 0] != joined[:, 1]], axis=1))
    return _thin_tubes_judged(points[kept], radius, joined, k)[representative]


def _thin_tubes_judged(points: np.ndarray, radius: float, edges: np.ndarray, k: int) -> np.ndarray:
    """thin_tubes on a cloud without over-dense parts."""
    anchors = np.full(points.shape, np.nan)
    tree = cKDTree(points)
    probes = probe_ids(len(points))
    reach = tree.query(points[probes], min(k, len(points)), workers=-1)[0].reshape(len(probes), -1)[:, -1]
    scale = np.clip(reach, radius, MIN_CURVE_RADII * radius)
    _, ratio, along = curve_likeness(points, radius, among_all=True, tree=tree, radii=scale)
    judged = np.flatnonzero(np.isfinite(ratio))
    surface = coo_matrix((np.ones(2 * len(edges)), (edges.ravel(), edges[:, ::-1].ravel())), shape=(len(points),) * 2)
    centroids, closed, told = _cross_sections(tree, surface.tocsr(), points[probes[judged]], along[judged],
                                              scale[judged])
    # a cross-section too thinly sampled to tell has no say (a sparse wire's probes flicker between the two)
    judged, centroids, closed = judged[told], centroids[told], closed[told]
    if not closed.any():
        return anchors
    thin, centroid, axis = np.zeros(len(probes), dtype=bool), np.zeros((len(probes), 3)), np.zeros((len(probes), 3))
    thin[judged], centroid[judged], axis[judged] = closed, centroids, along[judged]
    # each point by the probes judged within their scale of it: where a part is near the limit the judgement
    # flickers from probe to probe, and a flickering part is not anchored (its pieces would be fragments)
    nearest = np.arange(len(points)) if len(probes) == len(points) \
        else cKDTree(points[probes]).query(points, workers=-1)[1]
    rows, cols = _within(cKDTree(points[probes[judged]]), tree, scale[judged])
    ayes = np.bincount(cols, thin[judged][rows], len(points))
    members = np.flatnonzero(ayes > 0.5 * np.bincount(cols, minlength=len(points)))
    point_scale = scale[nearest]
    long_enough, piece = _long_pieces(points[members], radius, point_scale[members])
    members, piece = members[long_enough], piece[long_enough]
    owner = nearest[members]
    along_axis = np.einsum("ij,ij->i", points[members] - centroid[owner], axis[owner])
    onto = centroid[owner] + along_axis[:, None] * axis[owner]
    closing = _closing_loops(onto, piece, points, edges, radius, point_scale)[piece]
    anchors[members[closing]] = onto[closing]
    return anchors


def _within(near: cKDTree, far: cKDTree, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols): the pairs of a point of `near` and one of `far` within that near point's radius (`radii`)."""
    pairs = near.sparse_distance_matrix(far, float(radii.max(initial=0.0)), output_type="coo_matrix")
    keep = pairs.data <= radii[pairs.row]
    return pairs.row[keep], pairs.col[keep]


def _closing_loops(axis: np.ndarray, piece: np.ndarray, points: np.ndarray, edges: np.ndarray, radius: float,
                   reach: np.ndarray) -> np.ndarray:
    """For each piece (ids `piece` of its points' `axis` positions): whether it closes a loop of the input, as a
    handle does: the rest of the input touches both its ends, and one piece of the rest touches both. A limb's
    root touches the body and its tip, if anything of it is left, only a piece of the rest of its own. A piece
    stands for the input within `reach` (n,) of its axis, each input point's scale (thin_tubes; the tube the
    skeleton draws as it); its ends are the ends of its axis's longest shortest path (positions within `radius`
    joined), and the rest touches an end where a surface edge (`edges`, of those no longer than the scale of
    either end) crosses into the piece nearer that end."""
    count = int(piece.max()) + 1 if len(piece) else 0
    closes = np.zeros(count, dtype=bool)
    if count == 0:
        return closes
    distance, nearest = cKDTree(axis).query(points, distance_upper_bound=float(reach.max()), workers=-1)
    label = np.where(distance <= reach, piece[np.minimum(nearest, len(axis) - 1)], -1)
    # the surface joined at the skeleton's scale: a long ring edge can reach past a thin piece along its tube
    edges = edges[np.linalg.norm(points[edges[:, 0]] - points[edges[:, 1]], axis=1) <= reach[edges].max(axis=1)]
    inside = label[edges] >= 0
    rest = edges[~inside.any(axis=1)]
    _, component = connected_components(
        coo_matrix((np.ones(len(rest)), (rest[:, 0], rest[:, 1])), shape=(len(points), len(points))), directed=False)
    across = inside[:, 0] != inside[:, 1]
    crossing, crossing_inside = edges[across], inside[across]
    contact_piece = label[np.where(crossing_inside[:, 0], crossing[:, 0], crossing[:, 1])]
    contact = np.where(crossing_inside[:, 0], crossing[:, 1], crossing[:, 0])
    tree = cKDTree(axis)
    graph = tree.sparse_distance_matrix(tree, radius, output_type="coo_matrix").tocsr()
    for index in np.unique(piece):  # a handful of pieces
        own = np.flatnonzero(piece == index)
        ends = axis[own[list(_far_ends(graph[own][:, own]))]]
        touches = contact[contact_piece == index]
        # each contact goes to the end it is nearer
        nearer_second = (np.linalg.norm(points[touches] - ends[1], axis=1)
                         < np.linalg.norm(points[touches] - ends[0], axis=1))
        closes[index] = bool(set(component[touches[nearer_second]].tolist())
                             & set(component[touches[~nearer_second]].tolist()))
    return closes


def _far_ends(graph) -> tuple[int, int]:
    """The ends of the longest shortest path of the graph's largest connected piece, found by two sweeps of
    Dijkstra. An axis position can stray from the rest of its piece's (a member's probe near a handle's root
    takes an axis tilted into the body); swept from there, both ends were that one position."""
    _, piece = connected_components(graph, directed=False)
    first = int(np.argmax(piece == np.argmax(np.bincount(piece))))
    start = int(np.argmax(np.nan_to_num(dijkstra(graph, indices=first), posinf=-1)))
    return start, int(np.argmax(np.nan_to_num(dijkstra(graph, indices=start), posinf=-1)))


def _cross_sections(tree: cKDTree, surface, probes: np.ndarray, along: np.ndarray, scale: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each probe (m, 3) with its unit direction along and its scale (m,): the centroid of the input's
    cross-section there (the input: the points of `tree`), whether that cross-section is a hollow one within the
    scale of its centre (the circle's through it, `_circle_centres`: thin_tubes), and whether it holds the
    MIN_NEIGHBOURS points that tell. The cross-section is the piece of the slab that the input's surface edges
    (`surface`, a symmetric CSR adjacency) join to the probe: where a handle stands close to the body, the slab
    also cuts the body's surface beside it, which is no part of the handle's wall (on a sparse cloud the scale,
    and with it the slab, reaches the body along most of a small handle)."""
    points = tree.data
    pair_rows, pair_cols = _within(cKDTree(probes), tree, 2 * scale)
    offset = points[pair_cols] - probes[pair_rows]
    axial = np.einsum("ij,ij->i", offset, along[pair_rows])
    in_slab = np.flatnonzero(np.abs(axial) <= 0.5 * scale[pair_rows])
    section = in_slab[_piece_through_probe(surface, pair_rows[in_slab], pair_cols[in_slab],
                                           np.linalg.norm(offset[in_slab], axis=1))]
    rows = pair_rows[section]
    across = offset[section] - axial[section, None] * along[rows]
    count = np.bincount(rows, minlength=len(probes))
    with np.errstate(invalid="ignore", divide="ignore"):
        centroid = np.stack([np.bincount(rows, across[:, axis], len(probes)) for axis in range(3)], 1) / count[:, None]
    told = count >= MIN_NEIGHBOURS  # fewer: too thinly sampled to tell a cross-section
    across -= centroid[rows]
    shift = _circle_centres(across, rows, along, told)
    distance = np.linalg.norm(across - shift[rows], axis=1)
    closed = told.copy()
    closed[rows[distance > scale[rows]]] = False
    # hollow: on a closed wall every point lies about their mean distance from the centre; an open arc, a crease
    # or a strip has points at its centre (a strip a sixth of them within HOLLOW of the mean, a twig most), while
    # noise scatters only a few of a wall's points inwards
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.bincount(rows, distance, len(probes)) / count
        inner = np.bincount(rows, distance < HOLLOW * mean[rows], len(probes)) / count
    return probes + centroid, closed & (inner <= STRAY), told


def _circle_centres(across: np.ndarray, rows: np.ndarray, along: np.ndarray, fitted: np.ndarray) -> np.ndarray:
    """(m, 3) for each probe, the centre of the circle through its cross-section's points `across` (their offsets
    from its centroid, of probe `rows`), from that centroid: Kasa's algebraic fit (least squares of
    x^2 + y^2 = 2 a x + 2 b y + c) in the plane across `along`, for the probes `fitted`; 0 for the rest and where
    the fit has no single answer (points on one line) or the points do not lie all round the circle's centre (a
    gap of half a turn or more between two of them, seen from it). A few points around a tube fall unevenly round
    it and pull their centroid to one side, where the nearest then read as inside the tube; the circle's centre
    stays on its axis."""
    if not len(rows):
        return np.zeros((len(along), 3))
    first = np.cross(along, np.eye(3)[np.argmin(np.abs(along), axis=1)])
    first /= np.linalg.norm(first, axis=1, keepdims=True)
    second = np.cross(along, first)
    x, y = np.einsum("ij,ij->i", across, first[rows]), np.einsum("ij,ij->i", across, second[rows])
    terms = np.stack([2 * x, 2 * y, np.ones_like(x)], axis=1)
    normal = np.zeros((len(along), 3, 3))
    np.add.at(normal, rows, terms[:, :, None] * terms[:, None, :])
    right = np.zeros((len(along), 3))
    np.add.at(right, rows, terms * (x * x + y * y)[:, None])
    solvable = fitted & (np.abs(np.linalg.det(normal)) > 1e-12 * np.abs(normal).max(axis=(1, 2)) ** 3)
    solution = np.zeros((len(along), 3))
    solution[solvable] = np.linalg.solve(normal[solvable], right[solvable][:, :, None])[:, :, 0]
    # only a centre the points lie all round (no gap of half a turn between them, seen from it): an open arc (a
    # tube seen from one side) has a circle too, and its points would all read as on a wall around it
    angle = np.arctan2(y - solution[rows, 1], x - solution[rows, 0])
    order = np.lexsort((angle, rows))
    sorted_rows, sorted_angle = rows[order], angle[order]
    start = np.flatnonzero(np.r_[True, sorted_rows[1:] != sorted_rows[:-1]])
    gaps = np.diff(np.r_[sorted_angle, 0.0])
    last = np.r_[start[1:], len(order)] - 1
    gaps[last] = sorted_angle[start] + 2 * np.pi - sorted_angle[last]  # round from the last to the first
    widest = np.zeros(len(along))
    np.maximum.at(widest, sorted_rows, gaps)
    solution[widest >= np.pi] = 0.0
    return solution[:, :1] * first + solution[:, 1:2] * second


def _piece_through_probe(surface, rows: np.ndarray, cols: np.ndarray, to_probe: np.ndarray) -> np.ndarray:
    """Which of the slab entries (probe `rows`, point `cols`; `to_probe` each point's distance to its probe) lie in
    the piece of their probe's slab that the input's surface edges (`surface`: a symmetric (n, n) CSR adjacency)
    join to the point nearest the probe."""
    if not len(rows):
        return np.zeros(0, dtype=bool)
    # every entry (probe, a) against every (probe, b) with an edge a-b: b looked up in its probe's row of a
    # (probes, points) table of entry numbers (a binary search within one probe's slab)
    n, probes = surface.shape[0], int(rows.max()) + 1
    counts = np.diff(surface.indptr)[cols]
    entry = np.repeat(np.arange(len(rows)), counts)
    slots = np.arange(counts.sum()) + np.repeat(surface.indptr[cols] - np.cumsum(counts) + counts, counts)
    table = csr_array((np.arange(1, len(rows) + 1), (rows, cols)), shape=(probes, n))
    other = np.asarray(table[rows[entry], surface.indices[slots]]).ravel() - 1
    found = other > entry  # each link once
    links = coo_matrix((np.ones(int(found.sum())), (entry[found], other[found])), shape=(len(rows),) * 2)
    _, piece = connected_components(links, directed=False)
    # each probe's piece is that of its entry nearest the probe (the first such entry on a tie)
    nearest = np.full(probes, np.inf)
    np.minimum.at(nearest, rows, to_probe)
    at_nearest = np.flatnonzero(to_probe == nearest[rows])
    first = np.full(probes, len(rows) - 1)
    np.minimum.at(first, rows[at_nearest], at_nearest)
    return piece == piece[first][rows]
