"""Writers for curve skeletons (JSON, PLY with vertex + edge elements, OBJ polylines, GraphML) and for the
contracted points (binary PLY). Coordinates are written as given: the skeleton is in the user's coordinates.
Writers take the destination first, like write_points_ply(path, points); `skelcore run` writes skeleton.json
and skeleton.ply (skelcore.results), and `write_skeleton_file` (Result.save_skeleton) one file in the format its
suffix names."""
from __future__ import annotations

import json
from pathlib import Path

import networkx as nx
import numpy as np

from .errors import InputError, ParameterError, SkelError
from .skeleton import Skeleton


def skeleton_document(skeleton: Skeleton, correspondence: bool = True) -> dict:
    """The content of skeleton.json: nodes, edges, per-node degree and point_count, topology, the sample
    radius in the input's units (`radius`), and the node of every input point when `correspondence`."""
    data = {
        "nodes": skeleton.nodes_array().tolist(),
        "edges": skeleton.edges_array().tolist(),
        "degree": skeleton.degrees().tolist(),
        "point_count": [int(skeleton.graph.nodes[i]["point_count"]) for i in range(skeleton.graph.number_of_nodes())],
        "topology": skeleton.topology(),
        "radius": skeleton.radius,
    }
    if correspondence:
        data["correspondence"] = skeleton.correspondence.tolist()
    return data


def write_skeleton_json(path, skeleton: Skeleton, correspondence: bool = True) -> Path:
    """Write skeleton.json (see skeleton_document)."""
    return _write(path, lambda f: json.dump(skeleton_document(skeleton, correspondence), f, allow_nan=False), "w")


def write_skeleton_ply(path, skeleton: Skeleton) -> Path:
    """ASCII PLY: `vertex` (x, y, z, degree, point_count) and `edge` (vertex1, vertex2) elements."""
    nodes, edges, degrees = skeleton.nodes_array(), skeleton.edges_array(), skeleton.degrees()
    counts = [skeleton.graph.nodes[i]["point_count"] for i in range(len(nodes))]
    header = [
        "ply", "format ascii 1.0", "comment skelcore curve skeleton",
        f"element vertex {len(nodes)}", "property double x", "property double y", "property double z",
        "property int degree", "property int point_count",
        f"element edge {len(edges)}", "property int vertex1", "property int vertex2", "end_header",
    ]
    lines = header + [f"{x!r} {y!r} {z!r} {d} {c}" for (x, y, z), d, c in zip(nodes.tolist(), degrees, counts)]
    lines += [f"{a} {b}" for a, b in edges.tolist()]
    return _write(path, lambda f: f.write("\n".join(lines) + "\n"), "w")


def write_skeleton_obj(path, skeleton: Skeleton) -> Path:
    """Wavefront OBJ: `v` per node, one `l` polyline per chain between nodes of degree other than 2 (a
    closed loop repeats its first vertex), `p` for isolated nodes. Indices are 1-based."""
    lines = ["# skelcore curve skeleton"]
    lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in skeleton.nodes_array().tolist()]
    lines += ["l " + " ".join(str(i + 1) for i in chain) for chain in polylines(skeleton.graph)]
    lines += [f"p {i + 1}" for i in sorted(nx.isolates(skeleton.graph))]
    return _write(path, lambda f: f.write("\n".join(lines) + "\n"), "w")


def write_skeleton_graphml(path, skeleton: Skeleton) -> Path:
    """GraphML (networkx): node attributes x, y, z, point_count; edge attribute length."""
    graph = nx.Graph()
    for node, attrs in skeleton.graph.nodes(data=True):
        x, y, z = (float(c) for c in attrs["pos"])
        graph.add_node(node, x=x, y=y, z=z, point_count=int(attrs["point_count"]))
    graph.add_edges_from((a, b, {"length": float(d["length"])}) for a, b, d in skeleton.graph.edges(data=True))
    return _write(path, lambda f: nx.write_graphml(graph, f), "wb")


def write_points_ply(path, points, dtype=np.float64, labels=None) -> Path:
    """Binary little-endian PLY of (n,3) points, float64 (`double`) or float32 (`float`) xyz, and with
    `labels` (n,) an int `label` vertex property (read back by skelcore.io.load)."""
    points = np.asarray(points)
    if points.ndim != 2 or points.shape[1] != 3:
        raise InputError(f"{path}: points to write must be an (n, 3) array, got shape {points.shape}")
    kind = {np.dtype(np.float64): "double", np.dtype(np.float32): "float"}.get(np.dtype(dtype))
    if kind is None:
        raise InputError(f"{path}: dtype must be float32 or float64, got {np.dtype(dtype)}")
    fields = [(axis, np.dtype(dtype).newbyteorder("<")) for axis in "xyz"]
    if labels is not None:
        labels = np.asarray(labels)
        if labels.shape != (len(points),):
            raise InputError(f"{path}: {labels.size} labels for {len(points)} points")
        fields.append(("label", np.dtype("<i4")))
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(points)}\n"
              f"property {kind} x\nproperty {kind} y\nproperty {kind} z\n"
              + ("property int label\n" if labels is not None else "") + "end_header\n")
    rows = np.empty(len(points), dtype=fields)
    rows["x"], rows["y"], rows["z"] = points.T
    if labels is not None:
        rows["label"] = labels
    body = rows.tobytes()
    return _write(path, lambda f: f.write(header.encode("ascii") + body), "wb")


SKELETON_FORMATS = {".json": write_skeleton_json, ".ply": write_skeleton_ply, ".obj": write_skeleton_obj,
                    ".graphml": write_skeleton_graphml}


def write_skeleton_file(path, skeleton: Skeleton) -> Path:
    """The skeleton written to `path` in the format its suffix names (SKELETON_FORMATS); a ParameterError for
    another suffix."""
    writer = SKELETON_FORMATS.get(Path(path).suffix.lower())
    if writer is None:
        raise ParameterError(f"{path}: a skeleton file's name ends in {', '.join(SKELETON_FORMATS)}")
    return writer(path, skeleton)


def polylines(graph: nx.Graph) -> list[list[int]]:
    """Split the graph into chains whose inner nodes have degree 2; a chain that closes on itself ends with
    its first node. Every edge lies on exactly one chain."""
    seen: set[frozenset] = set()
    chains = []

    def walk(start: int, first: int) -> list[int]:
        chain = [start, first]
        seen.add(frozenset((start, first)))
        while graph.degree(chain[-1]) == 2 and chain[-1] != start:
            nxt = next(w for w in graph[chain[-1]] if frozenset((chain[-1], w)) not in seen)
            seen.add(frozenset((chain[-1], nxt)))
            chain.append(nxt)
        return chain

    starts = [n for n in sorted(graph) if graph.degree(n) != 2]
    starts += sorted(graph)  # then the loops made only of degree-2 nodes
    for start in starts:
        for first in sorted(graph[start]):
            if frozenset((start, first)) not in seen:
                chains.append(walk(start, first))
    return chains


def _write(path, write, mode: str) -> Path:
    path = Path(path)
    try:
        with open(path, mode, **({"encoding": "utf-8"} if mode == "w" else {})) as f:
            write(f)
    except OSError as error:
        raise SkelError(f"{path}: cannot write ({error.strerror or error})") from None
    return path
