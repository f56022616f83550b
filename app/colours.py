"""The view's colours and their key: the point layers', the skeleton's edges and node kinds', the pinned run's, the
maps that colour points by a quantity, and the Legend that names them."""
from __future__ import annotations

import numpy as np

from skelcore.metrics import D_THETA_RANGE, DELTA_KAPPA_RANGE
from skelcore.verdict import StabilityThresholds

POINT_LAYERS = ("original", "contracted", "removed")
# original: light enough that the dark skeleton inside it reads through the points in front of it
LAYER_COLOURS = {"original": (175, 175, 175), "contracted": (220, 40, 40),
                 "removed": (140, 70, 220)}  # removed: input points a GLSkeleton reduction absorbed
EDGE_COLOUR = (20, 20, 20)
PROVISIONAL_EDGE_COLOUR = (120, 120, 120)
GHOST_COLOUR = (30, 160, 80)  # the pinned run's skeleton: a hue no other layer or node kind uses
# Nodes of the skeleton graph by degree: an end (1), a path node (2), a junction (3+), isolated (0). They are lit
# balls, whose shading and the view's tone mapping render a colour duller and shifted (drawn pure orange, a junction
# looked ochre), so each kind has the colour it is drawn with and the look it takes, which the Legend's swatch shows
# (a ball's median colour as headless Chromium renders viser's toon shading; test_app_browser measures it).
NODE_COLOURS = {"end": (30, 110, 255), "path node": (40, 40, 40), "junction": (255, 60, 0),
                "isolated": (160, 60, 200)}
NODE_LOOKS = {"end": (77, 147, 199), "path node": (77, 77, 77), "junction": (207, 109, 8),
              "isolated": (173, 107, 185)}

# Per-point colouring over each quantity's full range, so colours stay comparable across iterations:
# a diverging map whose centre, the quantity's target, is dark, so the best points stand out on the
# white background; blue below the target, red above.
COLOUR_RANGES = {"D_theta": D_THETA_RANGE, "delta_kappa": DELTA_KAPPA_RANGE}
TARGETS = {"D_theta": StabilityThresholds.d_theta_target, "delta_kappa": StabilityThresholds.delta_kappa_target}
_STOPS = np.array([[5, 90, 200], [90, 165, 225], [40, 40, 40], [245, 140, 60], [205, 10, 30]], float)
_NAMES = {"D_theta": "D<sub>&theta;</sub>", "delta_kappa": "&delta;&kappa;"}


def colour_values(values: np.ndarray, quantity: str) -> np.ndarray:
    """(m,) values -> (m,3) uint8 colours on the quantity's diverging map (NaN: the original's grey)."""
    low, high = COLOUR_RANGES[quantity]
    target = TARGETS[quantity]
    values = np.asarray(values, float)
    # piecewise linear: low -> 0, target -> 0.5, high -> 1 (the target sits mid-map even off-centre)
    t = np.interp(values, [low, target, high], [0.0, 0.5, 1.0]) * (len(_STOPS) - 1)
    positions = np.arange(len(_STOPS))
    colours = np.column_stack([np.interp(t, positions, _STOPS[:, c]) for c in range(3)])
    colours[~np.isfinite(values)] = LAYER_COLOURS["original"]
    return colours.astype(np.uint8)


def legend_html(quantity: str | None, note: str = "", caveat: str = "", pinned: bool = False,
                extra: str = "", skeleton: bool = True, layers=POINT_LAYERS, original_coloured: bool = False,
                points_coloured: bool = False) -> str:
    """The key of the 3-D view: the point `layers` drawn, skeleton nodes (when the skeleton is shown) and, when
    colouring, the colour bar with its target (`caveat`: a line on why the skeleton is provisional, not drawn yet or
    may not follow the shape, "" when it needs none; `extra`: more HTML, e.g. the label colours; `original_coloured`:
    the original points are coloured too; `points_coloured`: by a quantity or by labels, so the nodes are hidden)."""
    def dot(colour, text):
        return f"<span style='color:rgb{tuple(colour)}'>&#9679;</span>&nbsp;{text}"

    coloured = {"contracted"} | ({"original"} if original_coloured else set()) if quantity is not None else set()
    lines = [" ".join(dot(LAYER_COLOURS[layer], layer) for layer in POINT_LAYERS
                      if layer in layers and layer not in coloured)]
    if skeleton and points_coloured:
        lines.append("skeleton: its edges (the nodes are hidden while the points are coloured)")
    elif skeleton:
        lines.append(" ".join(dot(NODE_LOOKS[kind], kind) for kind in ("end", "junction", "path node")))
    if caveat:
        lines.append(f"<i>{caveat}</i>")
    if pinned:  # drawn as rods: a bar, not a dot
        lines.append(f"<span style='color:rgb{tuple(GHOST_COLOUR)}'>&#9644;</span>&nbsp;pinned run's skeleton")
    if quantity is not None:
        low, high = COLOUR_RANGES[quantity]
        target = TARGETS[quantity]
        gradient = ", ".join(f"rgb({r:.0f},{g:.0f},{b:.0f})" for r, g, b in _STOPS)
        lines.append(f"{' and '.join(sorted(coloured))} coloured by {_NAMES[quantity]} (target {target:g}, dark)"
                     f"<div style='height:10px;background:linear-gradient(to right, {gradient})'></div>"
                     f"<div style='display:flex;justify-content:space-between'><span>{low:.2f}</span>"
                     f"<span><b>{target:g}</b></span><span>{high:.2f}</span></div>")
    if note:
        lines.append(f"<i>{note}</i>")
    if extra:
        lines.append(extra)
    return f"<div style='font-size:0.8em;line-height:1.5;padding:0 0.4em'>{'<br>'.join(lines)}</div>"
