"""The self-contained HTML report of runs, and HTML pages of figures (skelcore.figures draws them).

`skelcore report RUN_DIR... --out report.html` reproduces, per run, the seed paper's figures: the
histograms of D_theta and delta_kappa across iterations (Fig. 2), the final histograms beside the
original and contracted clouds (Figs. 3-4), the curve skeleton (Fig. 5), and the convergence of the
means with the verdicts. With several runs (and for `skelcore batch`, which also passes its summary
rows, failed objects included) the page opens with a sortable table of all objects and figures that
compare them: final means against their targets, the means' convergence, the final histograms. A section
states how far the verdict can be trusted (what `skelcore study` measured). plotly.js is embedded once,
so the page opens offline; clouds are subsampled and large batches keep only the table and the
comparison, so the page stays small.
"""
from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from .errors import InputError, ParameterError, SkelError
# The figure builders stay importable from here: the inspector and the tests read them as report.X.
from .figures import (LABEL_COLOURS, MAX_CLOUD_POINTS, MEASURES, cloud_figure,  # noqa: F401
                      convergence_comparison_figure, convergence_figure, empty_figure,
                      final_histograms_figure, final_means_figure, fitted_edges, histogram_figure,
                      histograms_over_iterations_figure, measure_key, per_point_values,
                      skeleton_figure, verdict_colour, verdict_text)
from .metric_entries import entry_problem, run_summary  # noqa: F401 (run_summary: read as report.run_summary)
from .verdict import PREDICTIVE_POWER, run_verdict

FAILED_COLOUR = "#8b1a1a"
MAX_DETAILED_RUNS = 50  # more runs than this: only the table and the comparison figures (no per-run sections)
# summary-row key -> table header; a column that no row fills is left out
TABLE_COLUMNS = {
    "name": "object", "status": "status", "verdict": "verdict", "error": "error", "method": "method", "points": "points",
    "iterations": "iterations", "termination": "termination", "seconds": "seconds", "nodes": "nodes",
    "edges": "edges", "components": "components", "cycles": "cycles", "ends": "ends", "junctions": "junctions",
    "d_theta_mean": "mean D<sub>θ</sub>", "delta_kappa_mean": "mean Δκ", "d_theta_skewness": "skew D<sub>θ</sub>",
    "delta_kappa_skewness": "skew Δκ", "d_theta_peaks": "peaks D<sub>θ</sub>", "delta_kappa_peaks": "peaks Δκ",
    "inside_share": "inside share", "spread_ratio": "spread ratio", "bounded": "bounded", "reused": "reused",
}


def histograms_html(metrics, iteration: int | None = None, plotly: bool | str = True,
                    of_points: int | None = None) -> str:
    """A page with the two histograms of one iteration (plotly: see figures_html; of_points: see
    histogram_figure)."""
    return figures_html("Histograms", [histogram_figure(metrics, key, iteration=iteration, of_points=of_points)
                                       for key in MEASURES], plotly)


def figures_html(title: str, figures, plotly: bool | str = True) -> str:
    """A page of figures. plotly=True embeds plotly.js (about 4.8 MB, opens offline); a string is the
    address of a plotly.js script to load instead, e.g. a shared copy beside the page."""
    return _page(title, "".join(_figure_html(figure) for figure in figures), plotly=plotly)


# --- the report of run folders ------------------------------------------------------------------

def load_run(run_dir, clouds: bool = True) -> dict:
    """The contents of one `skelcore run` output folder; problems raise InputError naming the folder.
    clouds=False leaves the original and contracted clouds unread (None), for the table and comparison only."""
    folder = Path(run_dir)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a run folder ({'a file' if folder.exists() else 'no such directory'})")
    metrics = _read_json(folder, "metrics.json", required=True)
    iterations = metrics.get("iterations") if isinstance(metrics, dict) else None
    if not isinstance(iterations, list) or not iterations:
        raise InputError(f"{folder / 'metrics.json'}: no \"iterations\" list")
    for position, entry in enumerate(iterations):
        problem = entry_problem(entry)
        if problem:
            raise InputError(f"{folder / 'metrics.json'}: iterations[{position}] {problem}")
    verdict = metrics.get("verdict")
    if not isinstance(verdict, dict) or "label" not in verdict:
        verdict = run_verdict(iterations)
    params = _read_json(folder, "params.json")
    params = params if isinstance(params, dict) else {}
    skeleton = _read_json(folder, "skeleton.json")
    notes = []
    if skeleton is not None:
        problem = _skeleton_problem(skeleton)
        if problem:
            raise InputError(f"{folder / 'skeleton.json'}: {problem}")
    else:
        notes.append("no skeleton.json")
    original, contracted = _load_clouds(folder, params, notes) if clouds else (None, None)
    return {"folder": folder, "name": folder.resolve().name, "metrics": metrics, "iterations": iterations,
            "verdict": verdict, "params": params, "skeleton": skeleton, "contracted": contracted,
            "original": original, "notes": notes}


def _load_clouds(folder: Path, params: dict, notes: list[str]) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The original cloud (read again as the run read it) and the contracted one; what is missing goes to notes."""
    from . import io

    contracted = original = None
    if (folder / "contracted.ply").is_file():
        try:
            contracted = io.load(folder / "contracted.ply").points
        except SkelError as error:
            notes.append(f"contracted cloud not shown: {error}")
    else:
        notes.append("no contracted.ply")
    source = params.get("input")
    if source:
        try:
            original = io.load(source, sample=params.get("sample"), voxel_size=params.get("voxel_size"),
                               seed=params.get("seed") or 0).points
        except SkelError as error:
            notes.append(f"original cloud not shown: {error}")
    else:
        notes.append("params.json names no input: original cloud not shown")
    return original, contracted


def write_report(run_dirs, out_path, rows=None) -> Path:
    """Write one self-contained HTML page: a table of the objects, with several runs figures comparing them,
    then the paper's figures for each run folder.

    rows: the summary rows of a batch (skelcore.batch.SUMMARY_COLUMNS), one per object, failed ones included: the
    table lists them all, with each failure's one-line error; run folders match rows by folder name. A run folder
    that cannot be read is then an error in its row instead of stopping the page. Without rows, the table is built
    from the run folders and any unreadable one raises InputError before anything is written.
    """
    run_dirs = [run_dirs] if isinstance(run_dirs, (str, Path)) else list(run_dirs)
    rows = None if rows is None else [dict(row) for row in rows]
    if not run_dirs and not rows:
        raise ParameterError("report: no run folders given")
    if Path(out_path).suffix.lower() not in (".html", ".htm"):  # never over a run's own files by a slip
        raise ParameterError(f"report: {out_path}: the page's name must end in .html")
    detailed = len(run_dirs) <= MAX_DETAILED_RUNS  # above: neither clouds nor per-run sections, the page stays small
    runs, problems = [], {}
    for folder in run_dirs:
        try:
            runs.append(load_run(folder, clouds=detailed))
        except InputError as error:
            if rows is None:
                raise
            problems[Path(folder).resolve().name] = f"not in the report: {error}"
    if rows is None:
        rows = [_run_row(run) for run in runs]
    for row in rows:
        if row.get("name") in problems:
            row["error"] = problems[row["name"]]
    out_path = Path(out_path)
    failed = sum(row.get("status") == "failed" for row in rows)
    count = f"{len(rows)} object(s), {failed} failed" if failed else f"{len(rows)} object(s)"
    body = [f"<h1>Contraction stability report</h1><p>{count}. Criteria of the seed paper: bell-shaped "
            "(unimodal, symmetric) histograms whose means move toward 0.5 (D<sub>θ</sub>) and 0 (Δκ), a contracted "
            "cloud that stays inside the original shape and keeps shrinking. Click a column header to sort.</p>",
            _table(rows, {run["name"]: run for run in runs}, linked=detailed)]
    body.append(predictive_power_html())
    if len(runs) > 1:
        body.append(_figures_html("Comparison across objects", [
            [final_means_figure(runs), convergence_comparison_figure(runs)],
            [final_histograms_figure(runs, key) for key in MEASURES]]))
    if detailed:
        body += [_run_section(run) for run in runs]
    else:
        body.append(f"<p class='muted'>{len(runs)} runs, more than {MAX_DETAILED_RUNS}: the per-object figures and "
                    "clouds are left out to keep this page small; <code>skelcore report OUT/&lt;name&gt;</code> draws "
                    "one object's.</p>")
    try:
        out_path.parent.mkdir(parents=True, exist_ok=True)
        out_path.write_text(_page("Contraction stability report", "".join(body), plotly=bool(runs)), encoding="utf-8")
    except OSError as error:
        raise InputError(f"{out_path}: cannot write the report ({error.strerror})") from None
    return out_path


def predictive_power_html(power: dict = PREDICTIVE_POWER) -> str:
    """How far a verdict can be trusted: what `skelcore study` measured on shapes held out from calibration."""
    if not power["stable"]:
        return ""
    best = ", ".join(f"{html.escape(name)} {area:.2f}" for name, area in power["best_statistics"])
    return (f"<h2>How far to trust the verdict</h2><p>Measured by <code>{html.escape(power['command'])}</code> on "
            f"{power['runs']} runs over shapes held out from the calibration of the thresholds ({power['right_runs']} "
            f"with a right skeleton: exact topology, Chamfer distance at most 1% of the diagonal where a centreline is "
            f"known): <b>\"stable\" was right in {100 * power['precision']:.0f}% of the {power['stable']} runs it "
            f"labelled</b>, and labelled {100 * power['recall']:.0f}% of the right runs. Bad settings judged stable: "
            f"{power['bad_settings_stable']}; collapsed or disconnected skeletons judged stable: "
            f"{power['collapsed_or_disconnected_stable']}. \"Not yet converged\" and \"unstable\" are not proof of a "
            f"wrong skeleton. Alone, no statistic of the contraction separates right from wrong skeletons well "
            f"(ROC AUC: {best}); the skeleton checks carry most of the verdict's power.</p>" + _added_html(power))


def _added_html(power: dict) -> str:
    """The criteria added to the paper's: why each is there, and what it did on the held-out shapes."""
    added = power.get("added_criteria") or []
    if not added:
        return ""
    items = "".join(f"<li><b>{html.escape(name)}</b>: {html.escape(why)} {html.escape(effect)}</li>"
                    for name, why, effect in added)
    return f"<p>Criteria added to the paper's, and what switching each off did on the held-out shapes:</p><ul>{items}</ul>"


def _run_section(run: dict) -> str:
    """Per run: the verdict and the paper's figures."""
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
         [histogram_figure(final, key, of_points=run["metrics"].get("n_points")) for key in MEASURES]
         + [cloud_figure(run["original"], run["contracted"])]),
    ]
    if run["skeleton"] is not None:
        figures.append(("Curve skeleton (paper Fig. 5)", [skeleton_figure(run["skeleton"], run["contracted"])]))
    for heading, row in figures:
        sections.append(f"<h3>{heading}</h3>{_row_html(row)}")
    return f"<section>{''.join(sections)}</section>"


def _figures_html(heading: str, rows: list[list]) -> str:
    return f"<section><h2>{heading}</h2>{''.join(_row_html(row) for row in rows)}</section>"


def _row_html(figures: list) -> str:
    # Columns fixed before any figure draws: plotly sizes a figure once, when its div is parsed.
    cells = "".join(f"<div>{_figure_html(figure)}</div>" for figure in figures)
    return f"<div class='row' style='grid-template-columns:repeat({len(figures)},minmax(340px,1fr))'>{cells}</div>"


def _run_row(run: dict) -> dict:
    """A summary row (as skelcore.batch writes) from a run folder, for `skelcore report` without a batch."""
    metrics, final = run["metrics"], run["iterations"][-1]
    skeleton = run["skeleton"] or {}
    return {
        "name": run["name"], "input": run["params"].get("input"), "status": "ok", "verdict": run["verdict"]["label"],
        "method": metrics.get("method"), "points": metrics.get("n_points"),
        "iterations": final.get("iteration", len(run["iterations"]) - 1), "termination": metrics.get("termination"),
        "nodes": len(skeleton["nodes"]) if "nodes" in skeleton else None,
        "edges": len(skeleton["edges"]) if "edges" in skeleton else None,
        **{f"{key}_{field}": final[key][field] for key in MEASURES for field in ("mean", "skewness")},
        **{f"{key}_peaks": final[key]["peaks"].get("count") for key in MEASURES},
        "inside_share": final["boundedness"].get("inside_share"),
        "spread_ratio": final["boundedness"].get("spread_ratio"),
    }


def _table(rows: list[dict], runs: dict, linked: bool) -> str:
    """All objects, one row each, failed ones shaded with their error; the verdict coloured, its reasons on hover."""
    columns = [key for key in TABLE_COLUMNS if any(row.get(key) not in (None, "") for row in rows)]
    lines = []
    for row in rows:
        name, status, run = str(row.get("name", "")), row.get("status"), runs.get(row.get("name"))
        cells = []
        for key in columns:
            value = row.get(key)
            text = html.escape(_cell(value))
            numeric = isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value)
            if key == "name":
                title = html.escape(str(row.get("input") or ""))
                text = f"<a href='#{html.escape(name)}'>{text}</a>" if run is not None and linked else text
                cells.append(f"<td title='{title}'>{text}</td>")
            elif key == "verdict" and value:
                reasons = html.escape("; ".join(run["verdict"].get("reasons", [])[:6])) if run is not None else ""
                cells.append(f"<td title='{reasons}' style='color:{verdict_colour(value)}'><b>{text}</b></td>")
            elif key == "status" and status == "failed":
                cells.append(f"<td style='color:{FAILED_COLOUR}'><b>{text}</b></td>")
            elif key == "error":
                cells.append(f"<td class='error'>{text}</td>")
            else:
                cells.append(f"<td data-v='{float(value)!r}'>{text}</td>" if numeric else f"<td>{text}</td>")
        lines.append(f"<tr{' class=failed' if status == 'failed' else ''}>{''.join(cells)}</tr>")
    header = "".join(f"<th>{TABLE_COLUMNS[key]}</th>" for key in columns)
    return (f"<div class='scroll'><table class='sortable'><thead><tr>{header}</tr></thead><tbody>{''.join(lines)}"
            f"</tbody></table></div><script>{_SORT_SCRIPT}</script>")


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.3f}"
    return str(value)


# Sort a table by the clicked column: numbers (data-v) as numbers, the rest as text, empty cells last.
_SORT_SCRIPT = """
document.querySelectorAll('table.sortable th').forEach((th, column) => th.addEventListener('click', () => {
  const body = th.closest('table').tBodies[0], ascending = th.dataset.order !== 'asc';
  th.parentNode.querySelectorAll('th').forEach(other => delete other.dataset.order);
  th.dataset.order = ascending ? 'asc' : 'desc';
  const key = row => { const cell = row.cells[column];
    return cell.dataset.v !== undefined ? Number(cell.dataset.v) : cell.textContent.trim(); };
  const rows = [...body.rows].sort((a, b) => {
    const x = key(a), y = key(b);
    if (x === '' || y === '') return (x === '') - (y === '');
    const order = typeof x === 'number' && typeof y === 'number' ? x - y : String(x).localeCompare(String(y));
    return ascending ? order : -order; });
  rows.forEach(row => body.appendChild(row));
}));
"""


def _verdict_html(verdict: dict) -> str:
    label = verdict.get("label") or "none (no contraction step to judge)"
    reasons = "".join(f"<li>{html.escape(r)}</li>" for r in verdict.get("reasons", []))
    return (f"<p>Verdict: <b style='color:{LABEL_COLOURS.get(label, '#000')}'>{html.escape(label)}</b></p>"
            f"<ul>{reasons}</ul>")


# plotly.js 3+ shows a "Share chart..." button that uploads the chart to Plotly's cloud unless told not to: our
# figures stay on the machine that made them
PLOTLY_CONFIG = {"displaylogo": False, "showSendToCloud": False}


def _figure_html(figure) -> str:
    return figure.to_html(full_html=False, include_plotlyjs=False, config=PLOTLY_CONFIG)


def _page(title: str, body: str, plotly: bool | str) -> str:
    """The page; plotly=True embeds plotly.js once in the head, so it opens offline and stays one file;
    a string loads plotly.js from that address."""
    style = ("body{font-family:system-ui,sans-serif;margin:24px;color:#222}.row{display:grid;gap:8px}"
             ".muted{color:#666;font-size:90%}table{border-collapse:collapse}.scroll{overflow-x:auto}"
             "td,th{border:1px solid #ddd;padding:4px 8px;text-align:left}section{margin-top:32px}"
             "th{cursor:pointer;background:#f4f4f4}th[data-order=asc]::after{content:' ▲'}"
             "th[data-order=desc]::after{content:' ▼'}tr.failed{background:#fbeaea}"
             "td.error{min-width:24em;max-width:48em;font-size:90%;overflow-wrap:anywhere}")
    script = ""
    if isinstance(plotly, str):
        script = f"<script src='{html.escape(plotly)}' charset='utf-8'></script>"
    elif plotly:
        from plotly.offline import get_plotlyjs

        script = f"<script>{get_plotlyjs()}</script>"
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
            f"<style>{style}</style>{script}</head><body>{body}</body></html>")


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
    except RecursionError:
        raise InputError(f"{path}: nested too deeply for a skelcore file") from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"{path}: cannot read ({error})") from None


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
