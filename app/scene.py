"""The 3-D scene: original cloud, contracted points of the shown iteration, curve-skeleton graph, the
pinned run's skeleton as a ghost.

Positions go out as float32, relative to the scene's origin (skelcore.display.display_origin), and only what
changed is sent. viser draws points opaque, so a layer's opacity is the share of its points drawn (a fixed
random order, so the same points stay) with their colour faded toward the background: a dense original thinned
this way lets the contracted points and the skeleton inside show through. Clouds above `display_cap` points
are drawn from at most that many (display only: the engine keeps every point). Dense clouds start thinned
(`auto_opacity`), and an original starts with points small enough for its surface not to hide them
(skelcore.display.see_through_size). Cameras clip at the cloud's scale (skelcore.display.clipping_planes).
"""
from __future__ import annotations

import contextlib
import functools
import math
import threading

import numpy as np
import trimesh
import viser

from skelcore.display import DEFAULT_UP, UP_AXES, clipping_planes, display_origin, framing_camera, turned_up

from .colours import EDGE_COLOUR, GHOST_COLOUR, LAYER_COLOURS, NODE_COLOURS, POINT_LAYERS, PROVISIONAL_EDGE_COLOUR
from .layout import NARROWEST_CANVAS

BACKGROUND = np.array([255, 255, 255], float)
EDGE_THICKNESS = 0.6  # skeleton edges, x the node radius: about as wide as an original point
# the pinned run's edges, x the node radius: wider than the current ones, so where the two skeletons coincide the
# current nodes sit on a green rod instead of the pinned edges hiding under the current ones; while the points are
# coloured (no nodes drawn), a little wider than the current edges only, so that the rods do not cover the points
GHOST_THICKNESS = 1.4
GHOST_THICKNESS_COLOURED = 0.8
DISPLAY_CAP = 250_000
DENSE_POINTS = 20_000  # an original above this many points starts thinned to about this many
POINT_SIZES = {"original": 0.005, "contracted": 0.007, "removed": 0.006}  # diameters at size 1, of the diagonal
INITIAL_DIRECTION = (-0.7, 0.7, -0.5)  # the first view looks down on the object from aside (up +Z)
FRAME_FILL = 0.8  # a framed view: the object's projected bounding box spans this share of the binding side
# Pixels the Legend panel covers at the 3-D view's foot (two or three lines, its margin included): a framed view
# leaves them free. The first view, before a browser says its canvas size, leaves them of the smallest window's
# canvas (layout.NARROWEST_CANVAS: 720 pixels high), so a tall object clears the Legend there and sits a little
# high in a taller one.
LEGEND_HEIGHT = 130


def legend_share(image_height: int | None) -> float:
    """The share of a canvas `image_height` pixels high that the Legend covers (of the smallest one if unknown)."""
    return min(LEGEND_HEIGHT / (image_height or NARROWEST_CANVAS[1]), 0.5)


def auto_opacity(count: int) -> float:
    """Opacity (share drawn) that thins a dense original to about DENSE_POINTS points, in steps of 0.05."""
    if count <= DENSE_POINTS:
        return 1.0
    return max(0.05, math.floor(20 * DENSE_POINTS / count) / 20)


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
        self.sizes = {"original": 1.0, "contracted": 1.0, "skeleton": 1.0, "removed": 1.0}  # x the defaults
        self.opacity = {"original": 1.0, "contracted": 1.0, "skeleton": 1.0, "removed": 1.0}
        self.diagonal = 1.0
        self.origin = np.zeros(3)  # display_origin of the original: where the scene's 0 sits in its coordinates
        self._source = None  # the array the original cloud was drawn from
        self._points: dict[str, np.ndarray | None] = dict.fromkeys(POINT_LAYERS)  # what each layer shows
        self._colours: dict[str, np.ndarray | None] = dict.fromkeys(POINT_LAYERS)  # per point, or plain
        self._handles: dict[str, viser.PointCloudHandle | None] = dict.fromkeys(POINT_LAYERS)
        self._keys: dict[str, object] = dict.fromkeys(POINT_LAYERS)
        self._colours_key = None
        self._edges = self._nodes = self._label = self._ghost = None
        self._skeleton = None  # (nodes, edges, degrees, provisional) last drawn
        self._picture_scale = 1.0  # point sizes while a picture is taken (app.export.point_scale)
        self._orders: dict[int, np.ndarray] = {}
        self._lock = threading.RLock()
        sphere = trimesh.creation.icosphere(subdivisions=1)
        self._sphere = (np.asarray(sphere.vertices, np.float32), np.asarray(sphere.faces, np.uint32))

    # -- sizes in world units, from the bounding-box diagonal of the loaded cloud
    def _point_size(self, layer: str) -> float:
        return self.sizes[layer] * self.diagonal * POINT_SIZES[layer] * self._picture_scale

    def _node_radius(self) -> float:
        return self.sizes["skeleton"] * self.diagonal * 0.011

    def rows(self, count: int, layer: str = "contracted") -> np.ndarray | None:
        """Rows drawn of a `count`-point layer (None: all): a prefix of a fixed random order, so the same
        points stay drawn across iterations and opacity changes."""
        drawn = min(self.display_cap, max(1, math.ceil(self.opacity[layer] * count)))
        if drawn >= count:
            return None
        if count not in self._orders:
            self._orders[count] = np.random.default_rng(0).permutation(count)
        return np.sort(self._orders[count][:drawn])

    def notice(self, count: int) -> str:
        rows = self.rows(count, "contracted")
        if rows is None:
            return ""
        return f"Showing {len(rows):,} of {count:,} contracted points in the view (the run keeps them all)."

    @_locked
    def load(self, original: np.ndarray) -> None:
        """A new run: clear the skeleton; the original cloud is sent again only when it changed."""
        self._clear_skeleton()
        if original is self._source:
            return
        self._source = original
        low, high = original.min(axis=0), original.max(axis=0)
        self.diagonal = float(np.linalg.norm(high - low)) or 1.0
        self.origin = display_origin(original)
        self._orders.clear()
        for layer in POINT_LAYERS:
            self._remove(layer)
        self._colours_key = None
        self._points["original"] = original
        self._draw("original")

    def _remove(self, layer: str) -> None:
        if self._handles[layer] is not None:
            self._handles[layer].remove()
        self._handles[layer] = self._points[layer] = self._colours[layer] = self._keys[layer] = None

    def _shown_colours(self, layer: str, rows) -> np.ndarray:
        colours = self._colours[layer]
        if colours is None:
            colours = np.asarray(LAYER_COLOURS[layer], float)[None, :]
        elif rows is not None:
            colours = colours[rows]
        fade = 0.35 + 0.65 * self.opacity[layer]  # a thinned layer also recedes
        shown = np.asarray(colours, float) * fade + BACKGROUND * (1 - fade)
        shown = shown.astype(np.uint8)
        return shown[0] if len(shown) == 1 and self._colours[layer] is None else shown

    def _draw(self, layer: str, colours_only: bool = False) -> None:
        points = self._points[layer]
        if points is None or len(points) == 0:
            self._remove(layer)
            return
        rows = self.rows(len(points), layer)
        colours = self._shown_colours(layer, rows)
        handle = self._handles[layer]
        if colours_only and handle is not None:
            handle.colors = np.broadcast_to(colours, (len(handle.points), 3)).astype(np.uint8)
            return
        shown = self._local(points if rows is None else points[rows])
        if handle is None or len(handle.points) != len(shown):
            if handle is not None:
                handle.remove()
            self._handles[layer] = self.scene.add_point_cloud(
                f"/{layer}", points=shown, colors=colours, precision="float32",
                point_size=self._point_size(layer), point_shape="circle", visible=self.visible[layer])
        else:
            handle.points = shown
            handle.colors = np.broadcast_to(colours, (len(shown), 3)).astype(np.uint8)

    @_locked
    def show_points(self, key, points: np.ndarray) -> None:
        """Contracted points of one state (`key` names it: the same key is not sent again)."""
        if key == self._keys["contracted"]:
            return
        self._points["contracted"], self._colours["contracted"] = points, None
        self._colours_key = None
        self._draw("contracted")
        self._keys["contracted"] = key
        self._follow_colouring()

    @_locked
    def show_removed(self, key, points: np.ndarray) -> None:
        """Input points absorbed by state `key`, drawn at their original places (none: nothing drawn)."""
        if key == self._keys["removed"]:
            return
        self._points["removed"] = points
        self._draw("removed")
        self._keys["removed"] = key

    @_locked
    def set_colours(self, key, colours: np.ndarray | None, quantity: str | None = None,
                    original_colours: np.ndarray | None = None) -> None:
        """Per-point colours of `quantity` for the contracted points (None: plain), and optionally for the
        original positions, if the contracted points still show state `key`."""
        colours_key = None if colours is None else (key, quantity, original_colours is not None)
        if key != self._keys["contracted"] or colours_key == self._colours_key:
            return
        self._colours["contracted"] = colours
        self._draw("contracted", colours_only=True)
        if original_colours is not None or self._colours["original"] is not None:
            self._colours["original"] = original_colours
            self._draw("original", colours_only=True)
        self._colours_key = colours_key
        self._follow_colouring()

    @property
    def coloured(self) -> bool:
        return self._colours_key is not None

    @property
    def colour_quantity(self) -> str | None:
        """What the contracted points are coloured by ("D_theta", "delta_kappa", "label"), None when plain."""
        return None if self._colours_key is None else self._colours_key[1]

    def _nodes_visible(self) -> bool:
        return self.visible["skeleton"] and not self.coloured

    def _ghost_thickness(self) -> float:
        return (GHOST_THICKNESS_COLOURED if self.coloured else GHOST_THICKNESS) * self._node_radius()

    def _follow_colouring(self) -> None:
        """Nodes and the pinned run's edges as the colouring has them: nodes hidden, the pinned edges thinner."""
        if self._nodes is not None and self._nodes.visible != self._nodes_visible():
            self._nodes.visible = self._nodes_visible()
        if self._ghost is not None and self._ghost.thickness != self._ghost_thickness():
            self._ghost.thickness = self._ghost_thickness()

    def drawn_colours(self, layer: str) -> np.ndarray | None:
        handle = self._handles[layer]
        return None if handle is None else np.broadcast_to(handle.colors, (len(handle.points), 3))

    def drawn_points(self, layer: str) -> np.ndarray | None:
        """The points a layer draws, in the cloud's coordinates."""
        handle = self._handles[layer]
        if handle is None:
            return None
        return handle.points + self.origin if self.origin.any() else handle.points

    def _local(self, positions: np.ndarray) -> np.ndarray:
        """Positions as the scene takes them: float32, from its origin."""
        return (positions - self.origin if self.origin.any() else positions).astype(np.float32)

    @_locked
    def show_skeleton(self, nodes: np.ndarray, edges: np.ndarray, degrees: np.ndarray,
                      provisional: bool = False) -> None:
        """Edges as line segments, nodes as spheres coloured by degree (end, path, junction); a provisional
        skeleton is drawn grey and labelled so. While the points are coloured the nodes are hidden: they would
        cover the contracted points along the skeleton, and their colours would read as the points' own."""
        self._clear_skeleton()
        self._skeleton = (nodes, edges, degrees, provisional)
        visible = self.visible["skeleton"]
        opacity = self.opacity["skeleton"]
        if len(edges):
            segments = self._local(nodes[edges])  # (e,2,3)
            self._edges = self.scene.add_line_segments(
                "/skeleton/edges", points=segments, colors=PROVISIONAL_EDGE_COLOUR if provisional else EDGE_COLOUR,
                thickness=EDGE_THICKNESS * self._node_radius(), visible=visible)
        if len(nodes):
            colours = np.empty((len(nodes), 3), np.uint8)
            colours[:] = NODE_COLOURS["path node"]
            colours[degrees == 0] = NODE_COLOURS["isolated"]
            colours[degrees == 1] = NODE_COLOURS["end"]
            colours[degrees >= 3] = NODE_COLOURS["junction"]
            scales = np.where(degrees == 2, 1.0, 1.8).astype(np.float32)  # ends and junctions stand out
            vertices, faces = self._sphere
            self._nodes = self.scene.add_batched_meshes_simple(
                "/skeleton/nodes", vertices=vertices * self._node_radius(), faces=faces,
                batched_wxyzs=np.tile(np.array([1.0, 0, 0, 0], np.float32), (len(nodes), 1)),
                batched_positions=self._local(nodes), batched_scales=scales, batched_colors=colours,
                material="toon3", cast_shadow=False, receive_shadow=False, visible=self._nodes_visible(),
                opacity=None if opacity >= 1 else opacity)
            if provisional:
                top = nodes[np.argmax(nodes[:, 2])]
                self._label = self.scene.add_label("/skeleton/provisional", "provisional skeleton",
                                                   position=self._local(top), visible=visible)

    @_locked
    def clear_skeleton(self) -> None:
        self._clear_skeleton()

    @contextlib.contextmanager
    def picture(self, point_scale: float = 1.0):
        """The scene as a picture shows it: without the provisional skeleton's 3-D label, drawn at a fixed size on
        screen (small in a large picture); the picture says it in its own words, at its own scale. Points are drawn
        `point_scale` times their size meanwhile (app.export.point_scale), layers drawn anew too."""
        with self._lock:
            if self._label is not None:
                self._label.visible = False
            self._scale_points(point_scale)
        try:
            yield
        finally:
            with self._lock:
                if self._label is not None:
                    self._label.visible = self.visible["skeleton"]
                self._scale_points(1.0)

    def _scale_points(self, scale: float) -> None:
        if scale == self._picture_scale:
            return
        self._picture_scale = scale
        for layer in POINT_LAYERS:
            if self._handles[layer] is not None:
                self._handles[layer].point_size = self._point_size(layer)

    def _clear_skeleton(self) -> None:
        for handle in (self._edges, self._nodes, self._label):
            if handle is not None:
                handle.remove()
        self._edges = self._nodes = self._label = self._skeleton = None

    @_locked
    def show_ghost(self, nodes: np.ndarray | None, edges: np.ndarray | None) -> None:
        """The pinned run's skeleton edges, wider than the current run's, or nothing (None)."""
        if self._ghost is not None:
            self._ghost.remove()
            self._ghost = None
        if nodes is not None and len(edges):
            self._ghost = self.scene.add_line_segments(
                "/pinned/skeleton", points=self._local(nodes[edges]), colors=GHOST_COLOUR,
                thickness=self._ghost_thickness())

    @property
    def skeleton_drawn(self) -> bool:
        return self._skeleton is not None

    @_locked
    def set_visible(self, layer: str, visible: bool) -> None:
        self.visible[layer] = visible
        handles = [self._edges, self._label] if layer == "skeleton" else [self._handles[layer]]
        for handle in handles:
            if handle is not None:
                handle.visible = visible
        self._follow_colouring()

    @_locked
    def set_size(self, layer: str, factor: float) -> None:
        self.sizes[layer] = factor
        if layer in POINT_LAYERS:
            if self._handles[layer] is not None:
                self._handles[layer].point_size = self._point_size(layer)
        else:  # the skeleton, the pinned one with it
            if self._nodes is not None:
                self._nodes.vertices = self._sphere[0] * self._node_radius()
            if self._edges is not None:
                self._edges.thickness = EDGE_THICKNESS * self._node_radius()
            if self._ghost is not None:
                self._ghost.thickness = self._ghost_thickness()

    @_locked
    def set_opacity(self, layer: str, opacity: float) -> None:
        self.opacity[layer] = opacity
        if layer in POINT_LAYERS:
            self._draw(layer)
        elif self._skeleton is not None:
            self.show_skeleton(*self._skeleton)



def frame_camera(camera, points: np.ndarray, aspect: float = NARROWEST_CANVAS[0] / NARROWEST_CANVAS[1],
                 up=UP_AXES[DEFAULT_UP]) -> None:
    """Point a camera (the server's initial one: a browser's canvas shape is not known yet, and sits between
    two panels, so taller than wide: the narrowest, layout.NARROWEST_CANVAS) at the whole cloud `points` (the
    original: the scene's origin is its display_origin), from above and aside, `up` up."""
    framing = framing_camera(points - display_origin(points), turned_up(INITIAL_DIRECTION, up), camera.fov, aspect,
                             FRAME_FILL, up=up, bottom=legend_share(None))
    camera.up = up
    camera.near, camera.far = clipping_planes(points)
    camera.position = framing.position
    camera.look_at = framing.look_at  # after the position: moving the position drags look_at along


def fit_client_camera(camera, points: np.ndarray, origin: np.ndarray, direction=None) -> None:
    """Frame `points` in a browser's `camera` (the scene's `origin` is the original cloud's display_origin),
    keeping its viewing direction or looking along `direction`, above the legend's share of its canvas."""
    direction = camera.look_at - camera.position if direction is None else direction
    framing = framing_camera(points - origin, direction, camera.fov, camera.aspect or 1.0, FRAME_FILL,
                             up=camera.up_direction, bottom=legend_share(camera.image_height))
    camera.near, camera.far = clipping_planes(points)
    camera.position = framing.position
    camera.look_at = framing.look_at  # after the position: moving the position drags look_at along
