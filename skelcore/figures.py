"""Plotly figures of the paper's stability metrics: histograms (one iteration, and across iterations),
the convergence of the means, the clouds and the skeleton, and figures comparing runs.

The builders take what skelcore.metrics produces: an IterationMetrics, or its JSON-ready dict (an entry of
metrics.json "iterations"), so the inspector and the HTML report (skelcore.report) draw the same pictures.
plotly is imported inside the functions: importing skelcore never loads it.
"""
from __future__ import annotations

import html

import numpy as np

from .errors import ParameterError
from .metrics import D_THETA_RANGE, DELTA_KAPPA_RANGE, IterationMetrics
from .metric_entries import metrics_entries, metrics_entry
from .verdict import StabilityThresholds, convergence

# key -> (title, axis label, histogram range, target)
MEASURES = {
    "d_theta": ("D_theta", "D<sub>θ</sub> = arccos(cos_sim(n<sub>k</sub>, n<sub>0</sub>)) / π", D_THETA_RANGE,
                StabilityThresholds.d_theta_target),
    "delta_kappa": ("delta_kappa", "Δκ = κ<sub>k</sub> − κ<sub>0</sub>", DELTA_KAPPA_RANGE,
                    StabilityThresholds.delta_kappa_target),
}
LABEL_COLOURS = {"stable": "#2a9d3f", "not yet converged": "#e08a00", "unstable": "#d1342f"}
MAX_CLOUD_POINTS = 4000  # per cloud drawn in the report: enough to see the shape, about 90 kB of page each
FIGURE_HEIGHT = 340


def measure_key(measure: str) -> str:
    """'D_theta' / 'd_theta' / 'delta_kappa' -> the metrics key."""
    key = str(measure).lower()
    if key not in MEASURES:
        raise ParameterError(f"measure={measure!r}: must be 'd_theta' or 'delta_kappa'")
    return key


def empty_figure(title: str = ""):
    """A blank figure with a title, for a panel that has nothing to show yet."""
    import plotly.graph_objects as go

    figure = go.Figure()
    figure.add_annotation(text="no data yet", showarrow=False, x=0.5, y=0.5, xref="paper", yref="paper")
    figure.update_layout(title=title, height=FIGURE_HEIGHT, xaxis_visible=False, yaxis_visible=False,
                         margin=dict(l=40, r=20, t=40, b=40))
    return figure


def histogram_figure(metrics, measure: str, iteration: int | None = None, title: str | None = None,
                     fit: bool = False, of_points: int | None = None):
    """Histogram of one measure at one iteration, with its mean, median, target and significant peaks marked
    (lines named in the legend, so no two labels overlap).

    fit=True (an IterationMetrics only: it holds the values) spans the x axis over the values and the target
    rather than the measure's whole range, rebinned into as many bins, so an early iteration whose values
    all sit near 0 is not one bar; peaks are marked only on the full-range histogram the verdict counts.
    of_points: the input's point count, said beside n where the metrics judged a sample of it."""
    import plotly.graph_objects as go

    key = measure_key(measure)
    entry = metrics_entry(metrics)
    stats = entry[key]
    name, axis_label, value_range, target = MEASURES[key]
    iteration = entry.get("iteration") if iteration is None else iteration
    edges = np.asarray(stats["histogram"]["edges"], float)
    counts = np.asarray(stats["histogram"]["counts"], float)
    peaks = stats["peaks"]
    if fit and isinstance(metrics, IterationMetrics):
        values = getattr(metrics, key)
        edges = fitted_edges(values, value_range, target, len(counts))
        counts = np.histogram(values[np.isfinite(values)], bins=edges)[0].astype(float)
        shown_range = [edges[0], edges[-1]]
    else:  # the verdict's own bins, the view zoomed onto those that hold points (a delta_kappa within 0.06 of 0)
        filled = edges[np.r_[counts > 0, False] | np.r_[False, counts > 0]]
        shown_range = list(fitted_edges(filled, value_range, target, len(counts))[[0, -1]])
    figure = go.Figure(go.Bar(x=(edges[:-1] + edges[1:]) / 2, y=counts, width=np.diff(edges), name="points",
                              marker_color="#5b7fb5", marker_line_width=0, showlegend=False))
    if not fit:
        figure.add_trace(go.Scatter(x=peaks["positions"], y=peaks["heights"], mode="markers",
                                    name="significant peak", marker=dict(symbol="triangle-down", size=12,
                                                                         color="#d1342f")))
    top = max(float(counts.max(initial=0)), 1.0) * 1.05
    marks = [(target, f"target {target:g}", dict(dash="dash", color="#d1342f", width=2))]
    if stats["mean"] is not None:
        marks += [(stats["mean"], f"mean {stats['mean']:.3f}", dict(color="#111111", width=2)),
                  (stats["median"], f"median {stats['median']:.3f}", dict(dash="dot", color="#111111", width=1.5))]
    for x, label, line in marks:
        figure.add_trace(go.Scatter(x=[x, x], y=[0, top], mode="lines", name=label, line=line, hoverinfo="name"))
    # n counts the points with a value: not those collapsed to a point (undefined), nor those GLSkeleton merged
    # into others, nor those left out of the sample a large cloud is judged on (`of_points`: the input's count)
    judged = stats["n"] + stats.get("n_undefined", 0)
    total = of_points if isinstance(of_points, (int, np.integer)) and of_points > judged else judged
    counted = f"n {stats['n']:,}" + (f" of {total:,}" if total > stats["n"] else "")
    summary = (f"skew {_number(stats['skewness'])} · symmetry {_number(stats['symmetry'])} · "
               f"peaks {peaks['count']} · {counted}")
    heading = title or (name if iteration is None else f"{name}, iteration {iteration}")
    figure.update_layout(title=dict(text=heading, subtitle=dict(text=summary)), height=FIGURE_HEIGHT, bargap=0,
                         margin=dict(l=50, r=20, t=60, b=95), xaxis=dict(title=axis_label, range=shown_range),
                         yaxis=dict(title="points", range=[0, top]),
                         legend=dict(orientation="h", y=-0.35, yanchor="top", x=0, font=dict(size=11)))
    return figure


def fitted_edges(values: np.ndarray, value_range: tuple[float, float], target: float, bins: int,
                 least: float = 0.1) -> np.ndarray:
    """`bins` + 1 bin edges spanning the finite values and the target (at least `least` of value_range
    wide), padded by a bin, inside value_range."""
    full = value_range[1] - value_range[0]
    finite = np.asarray(values, float)
    finite = finite[np.isfinite(finite)]
    low = min(float(finite.min()), target) if len(finite) else value_range[0]
    high = max(float(finite.max()), target) if len(finite) else value_range[1]
    widen = max(0.0, least * full - (high - low)) / 2
    low, high = low - widen, high + widen
    pad = (high - low) / bins
    low, high = max(value_range[0], low - pad), min(value_range[1], high + pad)
    return np.linspace(low, high, bins + 1)


def histograms_over_iterations_figure(iterations, measure: str, title: str | None = None):
    """Fig. 2: the histogram of one measure at every iteration, as shares of the points, one line each."""
    import plotly.graph_objects as go
    from plotly.colors import sample_colorscale

    key = measure_key(measure)
    entries = metrics_entries(iterations)
    name, axis_label, value_range, target = MEASURES[key]
    colours = sample_colorscale("Viridis", np.linspace(0, 0.9, max(len(entries), 2)).tolist())
    figure = go.Figure()
    for entry, colour in zip(entries, colours):
        figure.add_trace(_share_trace(entry, key, line=dict(color=colour, width=1.6),
                                      name=f"iteration {entry['iteration']}"))
    figure.add_vline(x=target, line_dash="dash", line_color="#888888")
    figure.update_layout(title=title or f"{name} across iterations", height=FIGURE_HEIGHT,
                         margin=dict(l=50, r=20, t=50, b=50), xaxis=dict(title=axis_label, range=list(value_range)),
                         yaxis_title="share of points")
    return figure


def convergence_figure(iterations, thresholds: StabilityThresholds = StabilityThresholds(), title: str | None = None,
                       shown: int | None = None):
    """Means of D_theta (toward 0.5) and delta_kappa (toward 0) per iteration, each marker coloured by the
    iteration's verdict, the tolerance band around each target shaded; `shown`: an iteration marked by a dotted
    line (the one a viewer shows, when it is not the last)."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    entries = metrics_entries(iterations)
    trend = convergence(entries, thresholds)
    labels = [e["verdict"]["label"] for e in entries]
    figure = make_subplots(rows=2, cols=1, shared_xaxes=True, vertical_spacing=0.12,
                           subplot_titles=(f"mean D<sub>θ</sub> → {thresholds.d_theta_target:g}",
                                           f"mean Δκ → {thresholds.delta_kappa_target:g}"))
    rows = (("d_theta", thresholds.d_theta_target, thresholds.d_theta_tolerance),
            ("delta_kappa", thresholds.delta_kappa_target, thresholds.delta_kappa_tolerance))
    colours = [LABEL_COLOURS.get(label, "#555555") for label in labels]
    _target_bands(figure, rows)
    for row, (key, _, _) in enumerate(rows, start=1):
        figure.add_trace(go.Scatter(x=trend["iteration"], y=trend[f"{key}_mean"], mode="lines+markers",
                                    line=dict(color="#555555"), showlegend=False,
                                    marker=dict(size=10, color=colours),
                                    text=labels, hovertemplate="iteration %{x}: %{y:.4f} (%{text})<extra></extra>"),
                         row=row, col=1)
    _verdict_legend(figure)
    if shown is not None:
        figure.add_vline(x=shown, line_dash="dot", line_color="#111111", line_width=1.5)
    figure.update_yaxes(range=list(D_THETA_RANGE), row=1, col=1)
    figure.update_yaxes(range=[-0.15, 0.15], row=2, col=1)
    figure.update_xaxes(title_text="iteration", dtick=1, row=2, col=1)
    figure.update_layout(title=title or "Convergence of the means", height=FIGURE_HEIGHT + 120,
                         margin=dict(l=50, r=20, t=70, b=50), legend=dict(orientation="h", y=-0.2))
    return figure


def _target_bands(figure, rows) -> None:
    """Each row's target (dashed) and its tolerance band (shaded), rows as (key, target, tolerance) from the top.
    They go on before the data, so plotly must be told to keep them on subplots that have none yet."""
    for row, (_, target, tolerance) in enumerate(rows, start=1):
        figure.add_hrect(y0=target - tolerance, y1=target + tolerance, fillcolor="#2a9d3f", opacity=0.12,
                         line_width=0, row=row, col=1, exclude_empty_subplots=False)
        figure.add_hline(y=target, line_dash="dash", line_color="#888888", row=row, col=1,
                         exclude_empty_subplots=False)


def cloud_figure(original: np.ndarray | None, contracted: np.ndarray | None, title: str = "Original and contracted"):
    """Figs. 3-4: the original cloud (grey) and the contracted one (red), subsampled to MAX_CLOUD_POINTS each."""
    import plotly.graph_objects as go

    figure = go.Figure()
    for points, name, colour, size, opacity in ((original, "original", "#9a9a9a", 1.5, 0.35),
                                                (contracted, "contracted", "#d1342f", 2.0, 0.9)):
        if points is None:
            continue
        points = _thin(points)
        figure.add_trace(go.Scatter3d(x=points[:, 0], y=points[:, 1], z=points[:, 2], mode="markers", name=name,
                                      marker=dict(size=size, color=colour, opacity=opacity)))
    figure.update_layout(title=title, height=FIGURE_HEIGHT + 100, margin=dict(l=0, r=0, t=40, b=0),
                         scene=dict(aspectmode="data"), legend=dict(orientation="h"))
    return figure


def skeleton_figure(skeleton: dict, contracted: np.ndarray | None = None, title: str = "Curve skeleton"):
    """Fig. 5: skeleton edges, nodes coloured by degree (end, path, junction), over the faint contracted cloud."""
    import plotly.graph_objects as go

    nodes = np.asarray(skeleton["nodes"], float).reshape(-1, 3)
    edges = np.asarray(skeleton["edges"], np.int64).reshape(-1, 2)
    degree = np.bincount(edges.ravel(), minlength=len(nodes))
    figure = go.Figure()
    if contracted is not None:
        points = _thin(contracted)
        figure.add_trace(go.Scatter3d(x=points[:, 0], y=points[:, 1], z=points[:, 2], mode="markers", name="contracted",
                                      marker=dict(size=1.5, color="#9a9a9a", opacity=0.25)))
    segments = np.full((len(edges) * 3, 3), np.nan)  # NaN rows break the line between edges
    segments[0::3], segments[1::3] = nodes[edges[:, 0]], nodes[edges[:, 1]]
    figure.add_trace(go.Scatter3d(x=segments[:, 0], y=segments[:, 1], z=segments[:, 2], mode="lines", name="edges",
                                  line=dict(color="#282828", width=5)))
    for name, mask, colour in (("end", degree == 1, "#1e6eff"), ("path", degree == 2, "#282828"),
                               ("junction", degree >= 3, "#ff9600")):
        if mask.any():
            figure.add_trace(go.Scatter3d(x=nodes[mask, 0], y=nodes[mask, 1], z=nodes[mask, 2], mode="markers",
                                          name=name, marker=dict(size=4 if name == "path" else 6, color=colour)))
    figure.update_layout(title=title, height=FIGURE_HEIGHT + 100, margin=dict(l=0, r=0, t=40, b=0),
                         scene=dict(aspectmode="data"), legend=dict(orientation="h"))
    return figure


# --- comparison across runs: each takes load_run dicts (only "name", "iterations" and "verdict" are used) ---------

def final_means_figure(runs, thresholds: StabilityThresholds = StabilityThresholds(),
                       title: str = "Final means against their targets"):
    """One marker per run at its last iteration's (mean D_theta, mean delta_kappa), coloured by the run's verdict;
    the targets (0.5, 0) are marked and the tolerance box around them shaded."""
    import plotly.graph_objects as go

    t = thresholds
    figure = go.Figure()
    figure.add_shape(type="rect", x0=t.d_theta_target - t.d_theta_tolerance, x1=t.d_theta_target + t.d_theta_tolerance,
                     y0=-t.delta_kappa_tolerance, y1=t.delta_kappa_tolerance, fillcolor="#2a9d3f", opacity=0.12,
                     line_width=0)
    figure.add_vline(x=t.d_theta_target, line_dash="dash", line_color="#888888",
                     annotation_text=f"D<sub>θ</sub> target {t.d_theta_target:g}")
    figure.add_hline(y=0.0, line_dash="dash", line_color="#888888", annotation_text="Δκ target 0")
    for label, group in _by_verdict(runs).items():
        finals = [run["iterations"][-1] for run in group]
        figure.add_trace(go.Scatter(
            x=[entry["d_theta"]["mean"] for entry in finals], y=[entry["delta_kappa"]["mean"] for entry in finals],
            mode="markers+text" if len(runs) <= 20 else "markers", name=label, textposition="top center",
            text=[run["name"] for run in group], marker=dict(size=10, color=verdict_colour(label)),
            hovertemplate="%{text}: D<sub>θ</sub> %{x:.4f}, Δκ %{y:.4f}<extra>" + html.escape(label) + "</extra>"))
    figure.update_layout(title=title, height=FIGURE_HEIGHT + 120, margin=dict(l=50, r=20, t=50, b=50),
                         xaxis_title="final mean D<sub>θ</sub>", yaxis_title="final mean Δκ", showlegend=True,
                         legend=dict(orientation="h", y=-0.2))
    return figure


def convergence_comparison_figure(runs, thresholds: StabilityThresholds = StabilityThresholds(),
                                  title: str = "Convergence of the means, all objects", colours=None):
    """The means of D_theta and delta_kappa per iteration, one line per run on shared axes, coloured by verdict
    (or by `colours`, one per run, with the runs named in the legend)."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    figure = make_subplots(rows=2, cols=1, shared_xaxes=True, vertical_spacing=0.12,
                           subplot_titles=(f"mean D<sub>θ</sub> → {thresholds.d_theta_target:g}",
                                           f"mean Δκ → {thresholds.delta_kappa_target:g}"))
    rows = (("d_theta", thresholds.d_theta_target, thresholds.d_theta_tolerance),
            ("delta_kappa", thresholds.delta_kappa_target, thresholds.delta_kappa_tolerance))
    _target_bands(figure, rows)
    for number, run in enumerate(runs):
        trend = convergence(run["iterations"], thresholds)
        colour = colours[number] if colours else verdict_colour(run["verdict"]["label"])
        for row, (key, _, _) in enumerate(rows, start=1):
            figure.add_trace(go.Scatter(x=trend["iteration"], y=trend[f"{key}_mean"], mode="lines+markers",
                                        name=run["name"], showlegend=bool(colours) and row == 1, opacity=0.75,
                                        line=dict(color=colour, width=1.5), marker=dict(size=4, color=colour),
                                        hovertemplate="iteration %{x}: %{y:.4f}"),
                             row=row, col=1)
    if not colours:
        _verdict_legend(figure)
    figure.update_xaxes(title_text="iteration", row=2, col=1)
    figure.update_layout(title=title, height=FIGURE_HEIGHT + 120, margin=dict(l=50, r=20, t=70, b=50),
                         legend=dict(orientation="h", y=-0.2))
    return figure


def final_histograms_figure(runs, measure: str, title: str | None = None, colours=None):
    """The last iteration's histogram of one measure for every run, overlaid as shares of the points and
    coloured by verdict (paper Figs. 3-4 across objects), or by `colours`, one per run, named in the legend."""
    import plotly.graph_objects as go

    key = measure_key(measure)
    name, axis_label, value_range, target = MEASURES[key]
    figure = go.Figure()
    for number, run in enumerate(runs):
        colour = colours[number] if colours else verdict_colour(run["verdict"]["label"])
        figure.add_trace(_share_trace(run["iterations"][-1], key, name=run["name"], showlegend=bool(colours),
                                      opacity=0.7 if not colours else 1.0, line=dict(color=colour, width=1.8)))
    figure.add_vline(x=target, line_dash="dash", line_color="#888888", annotation_text=f"target {target:g}")
    if not colours:
        _verdict_legend(figure)
    figure.update_layout(title=title or f"Final {name} histograms, all objects", height=FIGURE_HEIGHT,
                         margin=dict(l=50, r=20, t=50, b=50), xaxis=dict(title=axis_label, range=list(value_range)),
                         yaxis_title="share of points", legend=dict(orientation="h", y=-0.3))
    return figure


def verdict_text(verdict: dict, max_reasons: int = 6) -> str:
    """Markdown: the label in bold and its reasons as a list."""
    reasons = verdict.get("reasons", [])
    label, iteration = verdict.get("label"), verdict.get("iteration")
    lines = [f"**Verdict on iteration {iteration}: {label}**" if label and iteration is not None
             else f"**Verdict: {label or 'none'}**"]
    lines += [f"- {reason}" for reason in reasons[:max_reasons]]
    if len(reasons) > max_reasons:
        lines.append(f"- … and {len(reasons) - max_reasons} more")
    return "\n".join(lines)


def per_point_values(metrics: IterationMetrics, measure: str) -> np.ndarray:
    """Values of one measure for every point of the iteration (NaN where not evaluated), for colouring."""
    if not isinstance(metrics, IterationMetrics):
        raise ParameterError("per_point_values: needs an IterationMetrics (a metrics dict holds no per-point values)")
    return metrics.per_point(measure_key(measure))


def _thin(points: np.ndarray) -> np.ndarray:
    """At most MAX_CLOUD_POINTS evenly spread rows, as float32: half the page bytes, no visible difference."""
    points = np.asarray(points, float)
    if len(points) > MAX_CLOUD_POINTS:
        points = points[np.linspace(0, len(points) - 1, MAX_CLOUD_POINTS).astype(np.int64)]
    return points.astype(np.float32)


def _share_trace(entry: dict, key: str, **style):
    """One histogram of a metrics entry as a step line of shares of the points."""
    import plotly.graph_objects as go

    edges = np.asarray(entry[key]["histogram"]["edges"], float)
    counts = np.asarray(entry[key]["histogram"]["counts"], float)
    return go.Scatter(x=(edges[:-1] + edges[1:]) / 2, y=counts / max(counts.sum(), 1), mode="lines",
                      line_shape="hvh", **style)


def _by_verdict(runs) -> dict[str, list[dict]]:
    groups: dict[str, list[dict]] = {label: [] for label in LABEL_COLOURS}
    for run in runs:
        groups.setdefault(run["verdict"]["label"] or "no verdict", []).append(run)
    return {label: group for label, group in groups.items() if group}


def verdict_colour(label: str) -> str:
    """The colour of a verdict label (grey for none or unknown)."""
    return LABEL_COLOURS.get(label, "#555555")


def _verdict_legend(figure) -> None:
    """Legend entries for the verdict colours (the traces themselves stay out of the legend)."""
    import plotly.graph_objects as go

    for label, colour in LABEL_COLOURS.items():
        figure.add_trace(go.Scatter(x=[None], y=[None], mode="markers", marker=dict(size=10, color=colour), name=label))


def _number(value) -> str:
    return "–" if value is None else f"{value:.3f}"
