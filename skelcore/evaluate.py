"""Score a curve skeleton against a ground-truth curve graph: distances between the curves, and topology.

Both sides are polyline graphs, nodes (m,3) and edges (e,2). Every edge is sampled every
SAMPLE_SPACING x (the ground truth's bounding-box diagonal); a sample's distance to the other graph is
the exact point-to-segment distance to the nearest of the segments that carry its KNN nearest samples
there (isolated nodes count as zero-length segments).
- chamfer = (mean d(skeleton -> truth) + mean d(truth -> skeleton)) / 2, means over arc length;
- hausdorff = the larger of the two maxima.
Distances are fractions of the GROUND TRUTH's bounding-box diagonal (the evaluator never sees the input
cloud; for a tube shape the centreline's diagonal is shorter than the cloud's by about a tube diameter).
Topology, on the simple graph (self-loops and repeated edges dropped): components, cycles = E - V + C
(independent loops), junctions = nodes of degree >= 3, ends = nodes of degree 1.

Readers: skeleton.json / a shape's NAME_centreline.json ({"nodes": [[x,y,z],...], "edges": [[i,j],...]}),
.ply with vertex and edge elements, a rig `.skeleton` (lines `id x y z parent`, parent -1 = root) and
`.tgf` (`index x y z ...` 1-based, `#`, edges `i j ...`, `#`). Rigs are animators' skeletons: use them
for topology and as a rough position reference.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import networkx as nx
import numpy as np
from scipy.spatial import cKDTree

from .coordinates import EXTREME
from .distinct import distinct_rows
from .errors import InputError
from .normalise import binary_unit, half_extent

SAMPLE_SPACING = 1e-3  # edge sampling step, fraction of the truth's bounding-box diagonal
MAX_SAMPLES = 2_000_000  # per graph; the step grows for graphs longer than this allows
KNN = 8  # nearest samples whose segments are measured exactly
TOPOLOGY_KEYS = ("components", "cycles", "junctions", "ends")


@dataclass(frozen=True)
class CurveGraph:
    """A curve graph to score: node positions and undirected edges."""
    nodes: np.ndarray  # (m,3) float64
    edges: np.ndarray  # (e,2) int64, unique pairs i < j, no self-loops
    name: str = "graph"


def make_graph(nodes, edges, name: str = "graph") -> CurveGraph:
    """Validate arrays into a CurveGraph (self-loops and repeated edges dropped)."""
    try:
        nodes = np.asarray(nodes, dtype=np.float64)
        edges = np.asarray(edges, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name}: nodes and edges must be numbers") from None
    if nodes.ndim != 2 or nodes.shape[1] != 3 or len(nodes) == 0:
        raise InputError(f"{name}: expected nodes as a non-empty list of [x, y, z], got shape {nodes.shape}")
    if not np.isfinite(nodes).all():
        raise InputError(f"{name}: node coordinates contain NaN or Inf")
    edges = edges.reshape(-1, 2) if edges.size == 0 else edges
    if edges.ndim != 2 or edges.shape[1] != 2:
        raise InputError(f"{name}: expected edges as a list of [i, j], got shape {edges.shape}")
    if not (np.isfinite(edges).all() and (edges == np.round(edges)).all()):
        raise InputError(f"{name}: edge indices must be integers")
    edges = edges.astype(np.int64)
    bad = edges[(edges < 0) | (edges >= len(nodes))]
    if len(bad):
        raise InputError(f"{name}: an edge refers to node {bad[0]}, but the nodes are 0..{len(nodes) - 1}")
    edges = np.sort(edges, axis=1)
    edges = distinct_rows(edges[edges[:, 0] != edges[:, 1]]).reshape(-1, 2)
    return CurveGraph(nodes, edges, name)


def load_graph(path) -> CurveGraph:
    """Read a skeleton or ground truth: .json, .ply (vertex + edge elements), .skeleton or .tgf."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: file not found" if not path.exists() else f"{path}: not a regular file")
    reader = _READERS.get(path.suffix.lower())
    if reader is None:
        raise InputError(f"{path}: unknown graph format '{path.suffix or path.name}' "
                         f"(supported: {' '.join(_READERS)})")
    try:
        nodes, edges = reader(path)
    except InputError:
        raise
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"{path}: cannot read file ({_one_line(error)})") from None
    except Exception as error:  # a parser's own failure on a malformed file
        raise InputError(f"{path}: cannot parse as {path.suffix[1:].upper()} ({_one_line(error)})") from None
    return make_graph(nodes, edges, str(path))


def graph_topology(n_nodes: int, edges: np.ndarray) -> dict:
    """components, cycles (E - V + C), junctions (degree >= 3), ends (degree 1), nodes, edges."""
    graph = nx.Graph()
    graph.add_nodes_from(range(n_nodes))
    graph.add_edges_from(map(tuple, np.asarray(edges).reshape(-1, 2).tolist()))
    graph.remove_edges_from(nx.selfloop_edges(graph))
    components = nx.number_connected_components(graph)
    degree = np.array([d for _, d in graph.degree()], dtype=np.int64)
    return {
        "components": components,
        "cycles": graph.number_of_edges() - n_nodes + components,
        "junctions": int((degree >= 3).sum()),
        "ends": int((degree == 1).sum()),
        "nodes": n_nodes,
        "edges": graph.number_of_edges(),
    }


def sample_edges(nodes: np.ndarray, edges: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points every <= `spacing` along each edge, both ends included, and each isolated node once.

    Returns samples (k,3), segment (k,) the row of each sample in the segment list, and the segment
    list (s,2): the edges, then (i, i) for each isolated node.
    """
    isolated = np.setdiff1d(np.arange(len(nodes)), edges.ravel())
    segments = np.concatenate([edges, np.stack([isolated, isolated], axis=1)]).astype(np.int64)
    a, b = nodes[segments[:, 0]], nodes[segments[:, 1]]
    steps = np.maximum(1, np.ceil(np.linalg.norm(b - a, axis=1) / spacing)).astype(np.int64)
    steps[len(edges):] = 0  # an isolated node is one sample
    segment = np.repeat(np.arange(len(segments)), steps + 1)
    start = np.repeat(np.cumsum(steps + 1) - (steps + 1), steps + 1)
    t = (np.arange(len(segment)) - start) / np.maximum(steps[segment], 1)
    samples = a[segment] + t[:, None] * (b - a)[segment]
    return samples, segment, segments


def evaluate(skeleton: CurveGraph, truth: CurveGraph) -> dict:
    """Distances (fractions of the truth's bounding-box diagonal) and topology of skeleton vs truth."""
    half = half_extent(truth.nodes)
    if half <= 0:
        raise InputError(f"{truth.name}: the ground truth has no extent (all nodes at one point)")
    # Both graphs at the power of two (exact) that brings the truth's extent to about 1: the distances are
    # fractions of its diagonal, and huge or tiny coordinates then neither overflow nor underflow.
    unit = binary_unit(half)
    if max(float(np.abs(graph.nodes).max()) for graph in (skeleton, truth)) / unit >= EXTREME:
        raise InputError(f"{skeleton.name}: its nodes lie more than {EXTREME:.3g} times the truth's extent away from "
                         f"the origin of the truth's coordinates: not in the same coordinates as {truth.name}")
    diagonal = float(np.linalg.norm(np.ptp(truth.nodes / unit, axis=0)))
    sides = []
    for graph in (skeleton, truth):
        scaled = graph.nodes / unit
        lengths = np.linalg.norm(scaled[graph.edges[:, 1]] - scaled[graph.edges[:, 0]], axis=1)
        spacing = max(SAMPLE_SPACING * diagonal, lengths.sum() / MAX_SAMPLES)
        sides.append(sample_edges(scaled, graph.edges, spacing) + (scaled,))
    to_truth = _distances(sides[0][0], *sides[1])
    to_skeleton = _distances(sides[1][0], *sides[0])
    topology = {"skeleton": graph_topology(len(skeleton.nodes), skeleton.edges),
                "truth": graph_topology(len(truth.nodes), truth.edges)}
    topology["matches"] = all(topology["skeleton"][key] == topology["truth"][key] for key in TOPOLOGY_KEYS)
    return {
        "skeleton": skeleton.name,
        "truth": truth.name,
        "diagonal": diagonal * unit,
        "normalised_by": "ground truth bounding-box diagonal",
        "chamfer": float(to_truth.mean() + to_skeleton.mean()) / 2 / diagonal,
        "hausdorff": float(max(to_truth.max(), to_skeleton.max())) / diagonal,
        "skeleton_to_truth": {"mean": float(to_truth.mean()) / diagonal, "max": float(to_truth.max()) / diagonal},
        "truth_to_skeleton": {"mean": float(to_skeleton.mean()) / diagonal, "max": float(to_skeleton.max()) / diagonal},
        "topology": topology,
    }


def evaluate_files(skeleton_path, truth_path) -> dict:
    """Score a skeleton file against a ground-truth file (see `evaluate`)."""
    return evaluate(load_graph(skeleton_path), load_graph(truth_path))


def format_report(result: dict) -> str:
    """A readable table of an `evaluate` result."""
    top = result["topology"]
    lines = [
        f"skeleton   {result['skeleton']} ({top['skeleton']['nodes']} nodes, {top['skeleton']['edges']} edges)",
        f"truth      {result['truth']} ({top['truth']['nodes']} nodes, {top['truth']['edges']} edges)",
        f"distances as fractions of the truth's bounding-box diagonal ({result['diagonal']:.6g}):",
        f"  chamfer    {result['chamfer']:.5f}",
        f"  hausdorff  {result['hausdorff']:.5f}",
        f"  skeleton -> truth  mean {result['skeleton_to_truth']['mean']:.5f}  max {result['skeleton_to_truth']['max']:.5f}",
        f"  truth -> skeleton  mean {result['truth_to_skeleton']['mean']:.5f}  max {result['truth_to_skeleton']['max']:.5f}",
        f"{'topology':12s}{'skeleton':>9s}{'truth':>7s}",
    ]
    for key in TOPOLOGY_KEYS:
        mark = "" if top["skeleton"][key] == top["truth"][key] else "  differs"
        lines.append(f"  {key:10s}{top['skeleton'][key]:>9d}{top['truth'][key]:>7d}{mark}")
    lines.append(f"topology matches: {'yes' if top['matches'] else 'no'}")
    return "\n".join(lines)


def _distances(points, samples, segment, segments, nodes) -> np.ndarray:
    """Distance from each point to the graph whose edge samples (and their segment rows) are given."""
    k = min(KNN, len(samples))
    _, nearest = cKDTree(samples).query(points, k=k)
    seg = segments[segment[nearest.reshape(len(points), k)]]  # (p, k, 2)
    a, b = nodes[seg[..., 0]], nodes[seg[..., 1]]
    ab = b - a
    t = np.einsum("pkc,pkc->pk", points[:, None] - a, ab) / np.maximum(np.einsum("pkc,pkc->pk", ab, ab), 1e-300)
    foot = a + np.clip(t, 0.0, 1.0)[..., None] * ab
    return np.linalg.norm(points[:, None] - foot, axis=2).min(axis=1)


def _one_line(error: Exception) -> str:
    text = " ".join(str(error).split())
    return text[:160] or type(error).__name__


def _read_json(path: Path):
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as error:
        raise InputError(f"{path}: not valid JSON ({error.msg}, line {error.lineno})") from None
    if not isinstance(data, dict) or "nodes" not in data or "edges" not in data:
        raise InputError(f"{path}: expected a JSON object with 'nodes' and 'edges'")
    return data["nodes"], data["edges"]


def _read_ply(path: Path):
    import trimesh

    loaded = trimesh.load(path, process=False)
    if isinstance(loaded, trimesh.Trimesh):
        raise InputError(f"{path}: a mesh with faces, not a graph (a PLY skeleton needs an edge element)")
    entities = getattr(loaded, "entities", None)
    if entities is None:
        raise InputError(f"{path}: PLY file has no edge element")
    # trimesh joins PLY edges into polylines: consecutive points of each entity are the edges
    edges = [pair for entity in entities for pair in zip(entity.points[:-1], entity.points[1:])]
    return np.asarray(loaded.vertices), np.asarray(edges, dtype=np.int64).reshape(-1, 2)


def _rows(path: Path, minimum: int, what: str):
    """(line number, fields) of each non-empty, non-comment line."""
    rows = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        fields = line.split()
        if fields and not fields[0].startswith("#"):
            if len(fields) < minimum:
                raise InputError(f"{path}: line {number}: expected '{what}'")
            rows.append((number, fields))
    return rows


def _read_rig(path: Path):
    ids, coordinates, parents = [], [], []
    for number, fields in _rows(path, 5, "id x y z parent"):
        try:
            ids.append(int(fields[0]))
            coordinates.append([float(value) for value in fields[1:4]])
            parents.append(int(fields[4]))
        except ValueError:
            raise InputError(f"{path}: line {number}: expected 'id x y z parent' (integers and numbers)") from None
    if not ids:
        raise InputError(f"{path}: the file holds no joints")
    row = {joint: i for i, joint in enumerate(ids)}
    if len(row) < len(ids):
        raise InputError(f"{path}: a joint id appears twice")
    missing = [p for p in parents if p != -1 and p not in row]
    if missing:
        raise InputError(f"{path}: parent {missing[0]} is not a joint id")
    edges = [[row[joint], row[parent]] for joint, parent in zip(ids, parents) if parent != -1]
    return coordinates, edges


def _read_tgf(path: Path):
    sections: list[list[tuple[int, list[str]]]] = [[]]
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if line.strip().startswith("#"):
            sections.append([])
        elif line.split():
            sections[-1].append((number, line.split()))
    if len(sections) < 2:
        raise InputError(f"{path}: expected a '#' line between the nodes and the edges")
    ids, coordinates, edges = [], [], []
    try:
        for number, fields in sections[0]:
            ids.append(int(fields[0]))
            coordinates.append([float(value) for value in fields[1:4]])
            if len(coordinates[-1]) < 3:
                raise ValueError
    except ValueError:
        raise InputError(f"{path}: line {number}: expected 'index x y z'") from None
    row = {index: i for i, index in enumerate(ids)}
    if len(row) < len(ids):
        raise InputError(f"{path}: a node index appears twice")
    for number, fields in sections[1]:
        try:
            i, j = int(fields[0]), int(fields[1])
        except (ValueError, IndexError):
            raise InputError(f"{path}: line {number}: expected an edge 'i j'") from None
        if i not in row or j not in row:
            raise InputError(f"{path}: line {number}: edge {i} {j} refers to a node that is not listed")
        edges.append([row[i], row[j]])
    if not ids:
        raise InputError(f"{path}: the file holds no nodes")
    return coordinates, edges


_READERS = {".json": _read_json, ".ply": _read_ply, ".skeleton": _read_rig, ".tgf": _read_tgf}
