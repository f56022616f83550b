"""The HTML page of `skelcore study`: predictive power of each statistic, the verdict's confusion tables, the
calibrated thresholds, what each criterion contributes, and how D_theta behaves under each normal convention."""
from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from .metrics import NORMAL_CONVENTIONS

COLOURS = {"outward": "#1f6fb4", "tracked": "#d1342f"}


def auc_figure(summary: dict):
    """ROC AUC of every last-iteration statistic for right vs wrong skeletons, 95% interval, per convention."""
    import plotly.graph_objects as go

    figure = go.Figure()
    for convention in NORMAL_CONVENTIONS:
        aucs = {k: v for k, v in summary["conventions"][convention]["auc"].items() if v is not None}
        names = list(aucs)
        # A statistic that is lower on right runs separates as well: show max(AUC, 1 - AUC) and say which way.
        values = [max(aucs[n][0], 1 - aucs[n][0]) for n in names]
        flipped = [aucs[n][0] < 0.5 for n in names]
        low = [v - (1 - aucs[n][2] if f else aucs[n][1]) for n, v, f in zip(names, values, flipped)]
        high = [(1 - aucs[n][1] if f else aucs[n][2]) - v for n, v, f in zip(names, values, flipped)]
        ways = [f"{'lower' if f else 'higher'} on right runs" for f in flipped]
        figure.add_trace(go.Bar(x=names, y=values, name=f"{convention} normals", marker_color=COLOURS[convention],
                                hovertext=ways, error_y=dict(type="data", symmetric=False, array=high, arrayminus=low)))
    figure.add_hline(y=0.5, line_dash="dash", line_color="#888", annotation_text="chance")
    figure.update_layout(title="How well each statistic of the last iteration tells right skeletons from wrong ones "
                               "(ROC AUC, 95% interval from the number of runs)", barmode="group", height=520,
                         yaxis=dict(range=[0.4, 1.0], title="ROC AUC"), xaxis_tickangle=-40,
                         margin=dict(l=50, r=20, t=60, b=200), legend=dict(orientation="h", y=1.08))
    return figure


def d_theta_trajectories_figure(records: list[dict]):
    """Mean D_theta per iteration of the default runs on clean inputs, one panel per convention."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    figure = make_subplots(rows=1, cols=2, subplot_titles=[f"{c} normals" for c in NORMAL_CONVENTIONS], shared_yaxes=True)
    chosen = [r for r in records if r["setting"] in ("default", "sl 1.5") and r["variant"] == "clean"]
    for col, convention in enumerate(NORMAL_CONVENTIONS, start=1):
        for r in chosen:
            means = [e["d_theta"]["mean"] for e in r["conventions"][convention]]
            figure.add_trace(go.Scatter(x=list(range(len(means))), y=means, mode="lines+markers", showlegend=False,
                                        line=dict(color="#2a9d3f" if r["truth"]["right"] else "#d1342f", width=1),
                                        hovertext=f"{r['shape']} {r['setting']} seed {r['seed']}"), row=1, col=col)
        figure.add_hline(y=0.5, line_dash="dash", line_color="#888", row=1, col=col)
    figure.update_layout(title="Mean D_theta per iteration, default and s_L 1.5 runs on clean inputs "
                               "(green: right skeleton, red: wrong); the paper expects 0.5 when stable",
                         height=380, margin=dict(l=50, r=20, t=70, b=40))
    figure.update_xaxes(title_text="iteration")
    return figure


def goals_table(entry: dict) -> str:
    """HTML table: the verdict against the truth per half, shipped and calibrated thresholds."""
    rows = []
    for which in ("shipped", "calibrated"):
        for half in ("calibration", "held-out"):
            g = entry[which][half]
            confusion = ", ".join(f"{label}: {c['right']} right / {c['wrong']} wrong" for label, c in g["confusion"].items())
            rows.append([which, half, g["runs"], g["right_runs"], g["stable"], _pct(g["precision"]), _pct(g["recall"]),
                         g["bad_settings_stable"], g["collapsed_or_disconnected_stable"], confusion])
    return _table(["thresholds", "half", "runs", "right runs", "labelled stable", "stable is right",
                   "right runs labelled stable", "bad settings stable", "collapsed/disconnected stable",
                   "confusion (verdict: right / wrong runs)"], rows)


def contributions_table(entry: dict) -> str:
    """HTML table: the held-out goals with each criterion group switched off."""
    base = entry["calibrated"]["held-out"]
    rows = [["all criteria", _pct(base["precision"]), _pct(base["recall"]), base["bad_settings_stable"],
             base["collapsed_or_disconnected_stable"]]]
    for name, g in entry["contributions"].items():
        rows.append([f"without {name}", _pct(g["precision"]), _pct(g["recall"]), g["bad_settings_stable"],
                     g["collapsed_or_disconnected_stable"]])
    return _table(["held-out runs, calibrated thresholds", "stable is right", "right runs labelled stable",
                   "bad settings stable", "collapsed/disconnected stable"], rows)


def write_page(path: Path, records: list[dict], summary: dict) -> Path:
    """One self-contained page (plotly.js embedded, as skelcore.report does)."""
    from .report import _figure_html, _page

    body = [f"<h1>skelcore study: does the verdict predict a right skeleton?</h1>"
            f"<p>{summary['runs']} runs ({len(summary['failed_runs'])} failed), "
            f"{_pct(summary['right_share'])} with a right skeleton (topology exact; Chamfer at most 1% of the "
            f"diagonal where a centreline exists). Calibration shapes: {', '.join(summary['shapes']['calibration'])}; "
            f"held-out shapes: {', '.join(summary['shapes']['held-out'])}.</p>"]
    body.append(_figure_html(auc_figure(summary)))
    body.append(_figure_html(d_theta_trajectories_figure(records)))
    for convention in NORMAL_CONVENTIONS:
        entry = summary["conventions"][convention]
        paper = entry["paper"]
        body.append(f"<h2>{convention} normals</h2><p>Paper's behaviour on default runs of clean inputs: "
                    f"{paper['within_target_at_end']} of {paper['runs']} end within the target (|mean D_theta - 0.5| "
                    f"&le; 0.1, one peak, |skewness| &le; 0.5); {paper['skewed_left_unimodal_at_first']} of "
                    f"{paper['runs']} start skewed left with one peak; final means "
                    f"{_range(paper['final_mean_range'])}.</p>")
        body.append("<h3>The verdict against the truth</h3>" + goals_table(entry))
        body.append("<h3>Held-out runs by kind of shape, calibrated thresholds</h3>" + _table(
            ["kind", "runs", "right runs", "labelled stable", "stable is right", "right runs labelled stable"],
            [[kind, g["runs"], g["right_runs"], g["stable"], _pct(g["precision"]), _pct(g["recall"])]
             for kind, g in entry["held_out_by_source"].items()]))
        body.append("<h3>What each criterion contributes</h3>" + contributions_table(entry))
        body.append("<h3>Calibrated thresholds</h3>" + _table(["threshold", "value"],
                                                              [[k, v] for k, v in entry["thresholds"].items()]))
    if summary["failed_runs"]:
        body.append("<h2>Failed runs</h2>" + _table(list(summary["failed_runs"][0]),
                                                    [list(f.values()) for f in summary["failed_runs"]]))
    path.write_text(_page("skelcore study", "".join(body), plotly=True), encoding="utf-8")
    return path


def _table(header: list, rows: list[list]) -> str:
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    lines = ["<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in rows]
    return f"<table><tr>{head}</tr>{''.join(lines)}</table>"


def _pct(value) -> str:
    return "n/a" if value is None else f"{100 * value:.0f}%"


def _range(values) -> str:
    return "n/a" if not values else f"{np.round(values[0], 2)} to {np.round(values[1], 2)}"
