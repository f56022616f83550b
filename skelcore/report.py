"""Plotly figures of the paper's stability metrics, and the self-contained HTML report of runs.

The figure builders take what skelcore.metrics produces: an IterationMetrics, or its JSON-ready dict
(an entry of metrics.json "iterations"), so the inspector and the batch report draw the same pictures.
plotly is imported inside the functions: importing skelcore never loads it.

`skelcore report RUN_DIR... --out report.html` reproduces, per run, the seed paper's figures: the
histograms of D_theta and delta_kappa across iterations (Fig. 2), the final histograms beside the
original and contracted clouds (Figs. 3-4), the curve skeleton (Fig. 5), and the convergence of the
means with the verdicts. plotly.js is embedded once, so the page opens offline.
"""
from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from .errors import InputError, ParameterError, SkelError
from .metrics import D_THETA_RANGE, DELTA_KAPPA_RANGE, IterationMetrics, StabilityThresholds, convergence, run_verdict

# key -> (title, axis label, histogram range, target)
MEASURES = {
    "d_theta": ("D_theta", "D<sub>θ</sub> = arccos(cos_sim(n<sub>k</sub>, n<sub>0</sub>)) / π", D_THETA_RANGE, 0.5),
    "delta_kappa": ("delta_kappa", "Δκ = κ<sub>k</sub> − κ<sub>0</sub>", DELTA_KAPPA_RANGE, 0.0),
}
LABEL_COLOURS = {"stable": "#2a9d3f", "not yet converged": "#e08a00", "unstable": "#d1342f"}
MAX_CLOUD_POINTS = 8000  # per cloud drawn in the report: enough to see the shape, keeps the page small
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


def histogram_figure(metrics, measure: str, iteration: int | None = None, title: str | None = None):
    """Histogram of one measure at one iteration, with its mean, median, target and significant peaks marked."""
    import plotly.graph_objects as go

    key = measure_key(measure)
    entry = _entry(metrics)
    stats = entry[key]
    name, axis_label, value_range, target = MEASURES[key]
    iteration = entry.get("iteration") if iteration is None else iteration
    edges = np.asarray(stats["histogram"]["edges"], float)
    counts = np.asarray(stats["histogram"]["counts"], float)
    figure = go.Figure(go.Bar(x=(edges[:-1] + edges[1:]) / 2, y=counts, width=np.diff(edges), name="points",
                              marker_color="#5b7fb5", marker_line_width=0, showlegend=False))
    peaks = stats["peaks"]
    figure.add_trace(go.Scatter(x=peaks["positions"], y=peaks["heights"], mode="markers", name="significant peak",
                                marker=dict(symbol="triangle-down", size=12, color="#d1342f")))
    figure.add_vline(x=target, line_dash="dash", line_color="#888888", annotation_text=f"target {target:g}",
                     annotation_position="bottom left")
    if stats["mean"] is not None:
        figure.add_vline(x=stats["mean"], line_color="#111111", annotation_text=f"mean {stats['mean']:.3f}",
                         annotation_position="top right")
        figure.add_vline(x=stats["median"], line_dash="dot", line_color="#111111")
    summary = (f"skewness {_number(stats['skewness'])}<br>excess kurtosis {_number(stats['kurtosis'])}<br>"
               f"symmetry {_number(stats['symmetry'])}<br>unimodality {_number(stats['unimodality'])}<br>"
               f"peaks {peaks['count']} · n {stats['n']}")
    figure.add_annotation(text=summary, xref="paper", yref="paper", x=0.99, y=0.80, showarrow=False, align="right",
                          xanchor="right", bgcolor="rgba(255,255,255,0.8)", font=dict(size=11))
    heading = title or (name if iteration is None else f"{name}, iteration {iteration}")
    figure.update_layout(title=heading, height=FIGURE_HEIGHT, bargap=0, margin=dict(l=50, r=20, t=50, b=50),
                         xaxis=dict(title=axis_label, range=list(value_range)), yaxis_title="points",
                         legend=dict(orientation="h", y=-0.3))
    return figure


def histograms_over_iterations_figure(iterations, measure: str, title: str | None = None):
    """Fig. 2: the histogram of one measure at every iteration, as shares of the points, one line each."""
    import plotly.graph_objects as go
    from plotly.colors import sample_colorscale

    key = measure_key(measure)
    entries = _entries(iterations)
    name, axis_label, value_range, target = MEASURES[key]
    colours = sample_colorscale("Viridis", np.linspace(0, 0.9, max(len(entries), 2)).tolist())
    figure = go.Figure()
    for entry, colour in zip(entries, colours):
        edges = np.asarray(entry[key]["histogram"]["edges"], float)
        counts = np.asarray(entry[key]["histogram"]["counts"], float)
        share = counts / max(counts.sum(), 1)
        figure.add_trace(go.Scatter(x=(edges[:-1] + edges[1:]) / 2, y=share, mode="lines", line_shape="hvh",
                                    line=dict(color=colour, width=1.6), name=f"iteration {entry['iteration']}"))
    figure.add_vline(x=target, line_dash="dash", line_color="#888888")
    figure.update_layout(title=title or f"{name} across iterations", height=FIGURE_HEIGHT,
                         margin=dict(l=50, r=20, t=50, b=50), xaxis=dict(title=axis_label, range=list(value_range)),
                         yaxis_title="share of points")
    return figure


def convergence_figure(iterations, thresholds: StabilityThresholds = StabilityThresholds(), title: str | None = None):
    """Means of D_theta (toward 0.5) and delta_kappa (toward 0) per iteration, each marker coloured by the
    iteration's verdict, the tolerance band around each target shaded."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    entries = _entries(iterations)
    trend = convergence(entries, thresholds)
    labels = [e["verdict"]["label"] for e in entries]
    figure = make_subplots(rows=2, cols=1, shared_xaxes=True, vertical_spacing=0.12,
                           subplot_titles=("mean D<sub>θ</sub> → 0.5", "mean Δκ → 0"))
    rows = (("d_theta", thresholds.d_theta_target, thresholds.d_theta_tolerance),
            ("delta_kappa", 0.0, thresholds.delta_kappa_tolerance))
    colours = [LABEL_COLOURS.get(label, "#555555") for label in labels]
    for row, (key, target, tolerance) in enumerate(rows, start=1):
        figure.add_hrect(y0=target - tolerance, y1=target + tolerance, fillcolor="#2a9d3f", opacity=0.12,
                         line_width=0, row=row, col=1)
        figure.add_hline(y=target, line_dash="dash", line_color="#888888", row=row, col=1)
        figure.add_trace(go.Scatter(x=trend["iteration"], y=trend[f"{key}_mean"], mode="lines+markers",
                                    line=dict(color="#555555"), showlegend=False,
                                    marker=dict(size=10, color=colours),
                                    text=labels, hovertemplate="iteration %{x}: %{y:.4f} (%{text})<extra></extra>"),
                         row=row, col=1)
    for label, colour in LABEL_COLOURS.items():  # legend of the verdict colours
        figure.add_trace(go.Scatter(x=[None], y=[None], mode="markers", marker=dict(size=10, color=colour), name=label))
    figure.update_yaxes(range=list(D_THETA_RANGE), row=1, col=1)
    figure.update_yaxes(range=[-0.15, 0.15], row=2, col=1)
    figure.update_xaxes(title_text="iteration", dtick=1, row=2, col=1)
    figure.update_layout(title=title or "Convergence of the means", height=FIGURE_HEIGHT + 120,
                         margin=dict(l=50, r=20, t=70, b=50), legend=dict(orientation="h", y=-0.2))
    return figure


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


def verdict_text(verdict: dict, max_reasons: int = 6) -> str:
    """Markdown: the label in bold and its reasons as a list."""
    reasons = verdict.get("reasons", [])
    lines = [f"**Verdict: {verdict.get('label', 'unknown')}**"]
    lines += [f"- {reason}" for reason in reasons[:max_reasons]]
    if len(reasons) > max_reasons:
        lines.append(f"- … and {len(reasons) - max_reasons} more")
    return "\n".join(lines)


def per_point_values(metrics: IterationMetrics, measure: str) -> np.ndarray:
    """Values of one measure for every point of the iteration (NaN where not evaluated), for colouring."""
    if not isinstance(metrics, IterationMetrics):
        raise ParameterError("per_point_values: needs an IterationMetrics (a metrics dict holds no per-point values)")
    return metrics.per_point(measure_key(measure))


def histograms_html(metrics, iteration: int | None = None) -> str:
    """A self-contained page with the two histograms of one iteration."""
    figures = [histogram_figure(metrics, key, iteration=iteration) for key in MEASURES]
    return _page("Histograms", "".join(_figure_html(figure, first=i == 0) for i, figure in enumerate(figures)))


# --- the report of run folders ------------------------------------------------------------------

def load_run(run_dir) -> dict:
    """The contents of one `skelcore run` output folder; problems raise InputError naming the folder."""
    from . import io

    folder = Path(run_dir)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a run folder (no such directory)")
    metrics = _read_json(folder, "metrics.json", required=True)
    iterations = metrics.get("iterations") if isinstance(metrics, dict) else None
    if not isinstance(iterations, list) or not iterations:
        raise InputError(f"{folder / 'metrics.json'}: no \"iterations\" list")
    for position, entry in enumerate(iterations):
        problem = _entry_problem(entry)
        if problem:
            raise InputError(f"{folder / 'metrics.json'}: iterations[{position}] {problem}")
    verdict = metrics.get("verdict")
    if not isinstance(verdict, dict) or "label" not in verdict:
        verdict = run_verdict(iterations)
    params = _read_json(folder, "params.json") or {}
    skeleton = _read_json(folder, "skeleton.json")
    notes = []
    if skeleton is not None:
        problem = _skeleton_problem(skeleton)
        if problem:
            raise InputError(f"{folder / 'skeleton.json'}: {problem}")
    else:
        notes.append("no skeleton.json")
    contracted = original = None
    if (folder / "contracted.ply").is_file():
        try:
            contracted = io.load(folder / "contracted.ply").points
        except SkelError as error:
            notes.append(f"contracted cloud not shown: {error}")
    else:
        notes.append("no contracted.ply")
    source = params.get("input") if isinstance(params, dict) else None
    if source:
        try:
            original = io.load(source, sample=params.get("sample"), voxel_size=params.get("voxel_size"),
                               seed=params.get("seed") or 0).points
        except SkelError as error:
            notes.append(f"original cloud not shown: {error}")
    else:
        notes.append("params.json names no input: original cloud not shown")
    return {"folder": folder, "name": folder.resolve().name, "metrics": metrics, "iterations": iterations,
            "verdict": verdict, "params": params, "skeleton": skeleton, "contracted": contracted,
            "original": original, "notes": notes}


def write_report(run_dirs, out_path) -> Path:
    """Write one self-contained HTML page reproducing the paper's figures for each run folder."""
    run_dirs = [run_dirs] if isinstance(run_dirs, (str, Path)) else list(run_dirs)
    if not run_dirs:
        raise ParameterError("report: no run folders given")
    runs = [load_run(folder) for folder in run_dirs]  # every folder is checked before anything is written
    out_path = Path(out_path)
    body = [f"<h1>Contraction stability report</h1><p>{len(runs)} run(s). Criteria of the seed paper: bell-shaped "
            "(unimodal, symmetric) histograms whose means move toward 0.5 (D<sub>θ</sub>) and 0 (Δκ), a contracted "
            "cloud that stays inside the original shape and keeps shrinking.</p>", _summary_table(runs)]
    first = True
    for run in runs:
        sections = [f"<h2 id='{html.escape(run['name'])}'>{html.escape(run['name'])}</h2>",
                    f"<p class='muted'>{html.escape(str(run['params'].get('input', '')))}</p>",
                    _verdict_html(run["verdict"])]
        if run["notes"]:
            sections.append("<p class='muted'>" + "; ".join(html.escape(n) for n in run["notes"]) + "</p>")
        iterations, final = run["iterations"], run["iterations"][-1]
        figures = [
            ("Convergence", [convergence_figure(iterations)]),
            ("Histograms across iterations (paper Fig. 2)",
             [histograms_over_iterations_figure(iterations, key) for key in MEASURES]),
            ("Final iteration: histograms and clouds (paper Figs. 3-4)",
             [histogram_figure(final, key) for key in MEASURES] + [cloud_figure(run["original"], run["contracted"])]),
        ]
        if run["skeleton"] is not None:
            figures.append(("Curve skeleton (paper Fig. 5)", [skeleton_figure(run["skeleton"], run["contracted"])]))
        for heading, row in figures:
            cells = []
            for figure in row:
                cells.append(f"<div class='cell'>{_figure_html(figure, first)}</div>")
                first = False
            sections.append(f"<h3>{heading}</h3><div class='row'>{''.join(cells)}</div>")
        body.append(f"<section>{''.join(sections)}</section>")
    try:
        out_path.parent.mkdir(parents=True, exist_ok=True)
        out_path.write_text(_page("Contraction stability report", "".join(body)), encoding="utf-8")
    except OSError as error:
        raise InputError(f"{out_path}: cannot write the report ({error.strerror})") from None
    return out_path


def _summary_table(runs: list[dict]) -> str:
    rows = []
    for run in runs:
        metrics, label = run["metrics"], run["verdict"]["label"]
        rows.append(f"<tr><td><a href='#{html.escape(run['name'])}'>{html.escape(run['name'])}</a></td>"
                    f"<td>{html.escape(str(metrics.get('method', '')))}</td><td>{metrics.get('n_points', '')}</td>"
                    f"<td>{run['iterations'][-1].get('iteration', len(run['iterations']) - 1)}</td>"
                    f"<td>{html.escape(str(metrics.get('termination', '')))}</td>"
                    f"<td style='color:{LABEL_COLOURS.get(label, '#000')}'><b>{html.escape(label)}</b></td></tr>")
    return ("<table><tr><th>run</th><th>method</th><th>points</th><th>last iteration</th><th>termination</th>"
            f"<th>verdict</th></tr>{''.join(rows)}</table>")


def _verdict_html(verdict: dict) -> str:
    label = verdict.get("label", "unknown")
    reasons = "".join(f"<li>{html.escape(r)}</li>" for r in verdict.get("reasons", []))
    return (f"<p>Verdict: <b style='color:{LABEL_COLOURS.get(label, '#000')}'>{html.escape(label)}</b></p>"
            f"<ul>{reasons}</ul>")


def _figure_html(figure, first: bool) -> str:
    # plotly.js goes inline with the first figure only: the page opens offline and stays one file.
    return figure.to_html(full_html=False, include_plotlyjs=bool(first), config={"displaylogo": False})


def _page(title: str, body: str) -> str:
    style = ("body{font-family:system-ui,sans-serif;margin:24px;color:#222}.row{display:flex;flex-wrap:wrap;gap:8px}"
             ".cell{flex:1 1 440px;min-width:340px}.muted{color:#666;font-size:90%}table{border-collapse:collapse}"
             "td,th{border:1px solid #ddd;padding:4px 8px;text-align:left}section{margin-top:32px}")
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
            f"<style>{style}</style></head><body>{body}</body></html>")


def _read_json(folder: Path, name: str, required: bool = False):
    path = folder / name
    if not path.is_file():
        if required:
            raise InputError(f"{folder}: no {name} (not a `skelcore run` output folder)")
        return None
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as error:
        raise InputError(f"{path}: invalid JSON (line {error.lineno}: {error.msg})") from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"{path}: cannot read ({error})") from None


def _entry_problem(entry) -> str | None:
    if not isinstance(entry, dict):
        return "is not an object"
    for key in ("d_theta", "delta_kappa"):
        stats = entry.get(key)
        if not isinstance(stats, dict):
            return f"lacks {key}"
        histogram = stats.get("histogram")
        if (not isinstance(histogram, dict) or not isinstance(histogram.get("edges"), list)
                or not isinstance(histogram.get("counts"), list)
                or len(histogram["edges"]) != len(histogram["counts"]) + 1):
            return f"{key} has no histogram with edges and counts"
        missing = [field for field in ("mean", "median", "skewness", "kurtosis", "symmetry", "unimodality", "n")
                   if field not in stats]
        if missing or not isinstance(stats.get("peaks"), dict):
            return f"{key} lacks {', '.join(missing) or 'peaks'}"
    if not isinstance(entry.get("boundedness"), dict) or not isinstance(entry.get("verdict"), dict):
        return "lacks boundedness or verdict"
    return None


def _skeleton_problem(skeleton) -> str | None:
    if not isinstance(skeleton, dict) or "nodes" not in skeleton or "edges" not in skeleton:
        return "needs \"nodes\" and \"edges\""
    try:
        nodes = np.asarray(skeleton["nodes"], float).reshape(-1, 3)
        edges = np.asarray(skeleton["edges"], np.int64).reshape(-1, 2)
    except (TypeError, ValueError):
        return "nodes must be [x, y, z] triples and edges [i, j] pairs"
    if len(edges) and (edges.min() < 0 or edges.max() >= len(nodes)):
        return f"edges refer to nodes outside [0, {len(nodes)})"
    return None


def _entry(metrics) -> dict:
    if isinstance(metrics, IterationMetrics):
        return {"iteration": metrics.iteration, **metrics.to_dict()}
    problem = _entry_problem(metrics)
    if problem:
        raise InputError(f"metrics: {problem}")
    return metrics


def _entries(iterations) -> list[dict]:
    entries = [_entry(item) for item in iterations]
    return [{"iteration": position, **entry} for position, entry in enumerate(entries)]


def _thin(points: np.ndarray) -> np.ndarray:
    points = np.asarray(points, float)
    if len(points) <= MAX_CLOUD_POINTS:
        return points
    return points[np.linspace(0, len(points) - 1, MAX_CLOUD_POINTS).astype(np.int64)]


def _number(value) -> str:
    return "–" if value is None else f"{value:.3f}"
