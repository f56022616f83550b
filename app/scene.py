"""The 3-D scene: original cloud, contracted points of the shown iteration, curve-skeleton graph.

Positions go out as float32, and only what changed is sent: the original once per load, the
contracted points and their colours as prop updates of one handle, the (small) skeleton per
iteration. Clouds above `display_cap` points are drawn from a fixed random subset (display only:
the engine keeps every point).
"""
from __future__ import annotations

import functools
import threading

import numpy as np
import trimesh
import viser

from skelcore.metrics import D_THETA_RANGE, DELTA_KAPPA_RANGE

ORIGINAL_COLOUR = (150, 150, 150)
CONTRACTED_COLOUR = (220, 40, 40)
REMOVED_COLOUR = (140, 70, 220)  # input points a GLSkeleton reduction absorbed, at their original place
EDGE_COLOUR = (20, 20, 20)
# nodes of the skeleton graph by degree: an end (1), a path node (2), a junction (3+), isolated (0)
END_COLOUR = (30, 110, 255)
PATH_COLOUR = (40, 40, 40)
JUNCTION_COLOUR = (255, 140, 0)
ISOLATED_COLOUR = (160, 60, 200)
DISPLAY_CAP = 250_000

# Per-point colouring over each quantity's full range, so colours stay comparable across iterations.
COLOUR_RANGES = {"D_theta": D_THETA_RANGE, "delta_kappa": DELTA_KAPPA_RANGE}
_STOPS = {  # samples of matplotlib's viridis (sequential) and ColorBrewer's RdBu reversed (diverging at 0)
    "D_theta": np.array([[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]], float),
    "delta_kappa": np.array([[33, 102, 172], [146, 197, 222], [247, 247, 247], [244, 165, 130], [178, 24, 43]], float),
}


def colour_values(values: np.ndarray, quantity: str) -> np.ndarray:
    """(m,) values -> (m,3) uint8 colours on the quantity's colour ramp (NaN: grey)."""
    low, high = COLOUR_RANGES[quantity]
    stops = _STOPS[quantity]
    t = np.clip((np.asarray(values, float) - low) / (high - low), 0.0, 1.0) * (len(stops) - 1)
    positions = np.arange(len(stops))
    colours = np.column_stack([np.interp(t, positions, stops[:, c]) for c in range(3)])
    colours[~np.isfinite(values)] = ORIGINAL_COLOUR
    return colours.astype(np.uint8)


def legend_html(quantity: str) -> str:
    """A horizontal colour bar with its range, for gui.add_html."""
    low, high = COLOUR_RANGES[quantity]
    gradient = ", ".join(f"rgb({r:.0f},{g:.0f},{b:.0f})" for r, g, b in _STOPS[quantity])
    label = {"D_theta": "D<sub>&theta;</sub>", "delta_kappa": "&delta;&kappa;"}[quantity]
    return (f'<div style="font-size:0.8em;padding:0 0.5em">{label} colour scale'
            f'<div style="height:10px;background:linear-gradient(to right, {gradient})"></div>'
            f'<div style="display:flex;justify-content:space-between"><span>{low:.2f}</span>'
            f'<span>{(low + high) / 2:.2f}</span><span>{high:.2f}</span></div></div>')


def _locked(method):
    """The engine thread draws points, the analysis thread the rest: one at a time."""
    @functools.wraps(method)
    def locked(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)
    return locked


class SceneView:
    def __init__(self, scene: viser.SceneApi, display_cap: int = DISPLAY_CAP):
        self.scene = scene
        self.display_cap = display_cap
        self.visible = {"original": True, "contracted": True, "skeleton": True, "removed": True}
        self.sizes = {"original": 1.0, "contracted": 1.0, "skeleton": 1.0}  # multiples of the defaults
        self.diagonal = 1.0
        self.centre = np.zeros(3)
        self._source = None  # the array the original cloud was drawn from
        self._original = None
        self._contracted = None
        self._removed = None
        self._removed_key = None
        self._edges = None
        self._nodes = None
        self._contracted_key = None
        self._colours_key = None
        self._subsets: dict[int, np.ndarray | None] = {}
        self._lock = threading.RLock()
        sphere = trimesh.creation.icosphere(subdivisions=1)
        self._sphere = (np.asarray(sphere.vertices, np.float32), np.asarray(sphere.faces, np.uint32))

    # -- sizes in world units, from the bounding-box diagonal of the loaded cloud
    def _point_size(self, layer: str) -> float:
        return self.sizes[layer] * self.diagonal * (0.005 if layer == "original" else 0.007)

    def _node_radius(self) -> float:
        return self.sizes["skeleton"] * self.diagonal * 0.011

    def subset(self, count: int) -> np.ndarray | None:
        """Rows drawn for a cloud of `count` points (None: all), the same rows every iteration."""
        if count <= self.display_cap:
            return None
        if count not in self._subsets:
            rows = np.random.default_rng(0).choice(count, self.display_cap, replace=False)
            self._subsets[count] = np.sort(rows)
        return self._subsets[count]

    def notice(self, count: int) -> str:
        if count <= self.display_cap:
            return ""
        return f"showing {self.display_cap:,} of {count:,} points (display only; the engine uses all)"

    @_locked
    def load(self, original: np.ndarray) -> None:
        """A new run: clear the skeleton; the original cloud is sent again only when it changed."""
        if original is self._source:
            self._clear_skeleton()
            return
        self._source = original
        low, high = original.min(axis=0), original.max(axis=0)
        self.diagonal = float(np.linalg.norm(high - low)) or 1.0
        self.centre = (low + high) / 2
        self._subsets.clear()
        for handle in (self._original, self._contracted, self._removed, self._edges, self._nodes):
            if handle is not None:
                handle.remove()
        self._contracted = self._removed = self._edges = self._nodes = None
        self._contracted_key = self._colours_key = self._removed_key = None
        rows = self.subset(len(original))
        shown = original if rows is None else original[rows]
        self._original = self.scene.add_point_cloud(
            "/original", points=shown.astype(np.float32), colors=ORIGINAL_COLOUR, precision="float32",
            point_size=self._point_size("original"), point_shape="circle", visible=self.visible["original"])

    @_locked
    def show_points(self, key, points: np.ndarray) -> None:
        """Contracted points of one state (`key` names it: the same key is not sent again)."""
        if key == self._contracted_key:
            return
        rows = self.subset(len(points))
        shown = (points if rows is None else points[rows]).astype(np.float32)
        handle = self._contracted
        if handle is None or len(handle.points) != len(shown):
            if handle is not None:
                handle.remove()
            self._contracted = self.scene.add_point_cloud(
                "/contracted", points=shown, colors=CONTRACTED_COLOUR, precision="float32",
                point_size=self._point_size("contracted"), point_shape="circle",
                visible=self.visible["contracted"])
            self._colours_key = None
        else:
            handle.points = shown
        self._contracted_key = key

    @_locked
    def show_removed(self, key, points: np.ndarray) -> None:
        """Input points absorbed by state `key`, drawn at their original places (none: nothing drawn)."""
        if key == self._removed_key:
            return
        if self._removed is not None:
            self._removed.remove()
            self._removed = None
        if len(points):
            rows = self.subset(len(points))
            shown = (points if rows is None else points[rows]).astype(np.float32)
            self._removed = self.scene.add_point_cloud(
                "/removed", points=shown, colors=REMOVED_COLOUR, precision="float32",
                point_size=self._point_size("original") * 1.2, point_shape="circle", visible=self.visible["removed"])
        self._removed_key = key

    @_locked
    def set_colours(self, key, colours: np.ndarray | None, quantity: str | None = None) -> None:
        """Per-point colours of `quantity` for the contracted points (None: plain red), if they still
        show state `key`."""
        handle = self._contracted
        colours_key = None if colours is None else (key, quantity)
        if handle is None or key != self._contracted_key or colours_key == self._colours_key:
            return
        if colours is not None:
            rows = self.subset(len(colours))
            colours = colours if rows is None else colours[rows]
        handle.colors = np.asarray(CONTRACTED_COLOUR if colours is None else colours, np.uint8)
        self._colours_key = colours_key

    @_locked
    def show_skeleton(self, nodes: np.ndarray, edges: np.ndarray, degrees: np.ndarray) -> None:
        """Edges as line segments, nodes as spheres coloured by degree (end, path, junction)."""
        self._clear_skeleton()
        visible = self.visible["skeleton"]
        if len(edges):
            segments = nodes[edges].astype(np.float32)  # (e,2,3)
            self._edges = self.scene.add_line_segments(
                "/skeleton/edges", points=segments, colors=EDGE_COLOUR,
                thickness=0.3 * self._node_radius(), visible=visible)
        if len(nodes):
            colours = np.empty((len(nodes), 3), np.uint8)
            colours[:] = PATH_COLOUR
            colours[degrees == 0] = ISOLATED_COLOUR
            colours[degrees == 1] = END_COLOUR
            colours[degrees >= 3] = JUNCTION_COLOUR
            scales = np.where(degrees == 2, 1.0, 1.8).astype(np.float32)  # ends and junctions stand out
            vertices, faces = self._sphere
            self._nodes = self.scene.add_batched_meshes_simple(
                "/skeleton/nodes", vertices=vertices * self._node_radius(), faces=faces,
                batched_wxyzs=np.tile(np.array([1.0, 0, 0, 0], np.float32), (len(nodes), 1)),
                batched_positions=nodes.astype(np.float32), batched_scales=scales, batched_colors=colours,
                material="toon3", cast_shadow=False, receive_shadow=False, visible=visible)

    @_locked
    def clear_skeleton(self) -> None:
        self._clear_skeleton()

    def _clear_skeleton(self) -> None:
        for handle in (self._edges, self._nodes):
            if handle is not None:
                handle.remove()
        self._edges = self._nodes = None

    @_locked
    def set_visible(self, layer: str, visible: bool) -> None:
        self.visible[layer] = visible
        handles = {"original": [self._original], "contracted": [self._contracted],
                   "skeleton": [self._edges, self._nodes], "removed": [self._removed]}[layer]
        for handle in handles:
            if handle is not None:
                handle.visible = visible

    @_locked
    def set_size(self, layer: str, factor: float) -> None:
        self.sizes[layer] = factor
        if layer == "original" and self._original is not None:
            self._original.point_size = self._point_size("original")
        elif layer == "contracted" and self._contracted is not None:
            self._contracted.point_size = self._point_size("contracted")
        elif layer == "skeleton" and self._nodes is not None:
            self._nodes.vertices = self._sphere[0] * self._node_radius()
            if self._edges is not None:
                self._edges.thickness = 0.3 * self._node_radius()

    def frame_camera(self, camera) -> None:
        """Point a camera (a client's, or the server's initial one) at the whole cloud."""
        camera.position = self.centre + self.diagonal * np.array([0.7, -0.7, 0.5])
        camera.look_at = self.centre  # after the position: moving the position drags look_at along
