"""The words a browser shows about the iteration it looks at: the status under the run controls and the
legend over the 3-D view. Plain functions of what is shown; nothing here computes."""
from __future__ import annotations

from .analysis import Readiness
from .layout import PROVISIONAL
from .scene import COLOUR_RANGES, POINT_LAYERS, legend_html


def run_state(history, doing: str, playing: bool, ahead=None) -> str:
    """What the shared run is doing, in a few words (ahead: the next state, when it was computed ahead)."""
    latest = history[-1]
    if playing:  # the Play button says Pause meanwhile (app.playback)
        return f"playing: {doing}…" if doing else "playing"
    if doing:
        return f"busy: {doing}…"
    if latest.termination:
        return f"ended at iteration {latest.iteration}: {latest.message}"
    state = "paused" if len(history) > 1 else "ready"
    if ahead is None:
        return state
    if ahead.iteration <= latest.iteration:  # the next step was rejected: Step ends the run
        return f"{state}; the next step, computed ahead, ends the run"
    return f"{state}; iteration {ahead.iteration} computed ahead"


def skeleton_note(readiness: Readiness | None, state, skeleton_shown: bool, provisional_wanted: bool) -> str:
    """Why no skeleton, or only a provisional one, is drawn for `state` ("" when the skeleton is final or
    hidden), in the legend's words."""
    if readiness is None or not readiness.provisional or not skeleton_shown:
        return ""
    if provisional_wanted:
        return f"skeleton drawn provisionally: {readiness.reason(state)}"
    return f"no skeleton yet: {readiness.reason(state)} (View: {PROVISIONAL})"


def status_markdown(session, index: int, *, run: str, readiness: Readiness | None, skeleton: str,
                    following: bool) -> str:
    """The status of history[index] as one browser sees it; `readiness`: None while not measured yet. Facts
    about the whole cloud (`cloud_notes`, folded) and parameter changes (`pending_markdown`) are said below the
    tabs: a long status pushes the parameters below the fold."""
    history = session.history
    state, latest = history[index], history[-1]
    removed = len(state.owner) - state.n_points
    counts = (f"{state.n_points:,} points retained, {removed:,} removed" if removed
              else f"{state.n_points:,} points")
    share = "…" if readiness is None else f"{readiness.share:.0%}"
    behind = "" if following or index == len(history) - 1 else " &middot; _not following the newest (key L)_"
    return "\n\n".join(filter(None, [
        f"**Iteration {state.iteration}** of {latest.iteration} computed &middot; {counts}{behind}",
        f"W_L = {state.wl:.4g} &middot; W_H in [{state.wh.min():.3g}, {state.wh.max():.3g}] "
        f"&middot; ring-size ratio a_t = {state.ring_ratio:.4f} &middot; curve-like {share}",
        state.anchored and f"{state.anchored:,} points on thin handles held in place (drawn on their axis)",
        readiness is not None and readiness.barely_contracted
        and f"⚠ **Barely contracted:** {readiness.barely_contracted}; the skeleton may not follow the shape",
        skeleton and f"_{skeleton}_",
        f"Run {run}",
    ]))


def pending_markdown(session) -> str:
    """The parameter changes waiting for the next step or a restart (below the tabs: it grows as a person types
    into a box, so it must not push that box down)."""
    return session.pending and f"**Pending:** {session.pending}"


def cloud_notes(session, notice: str) -> str:
    """What cleaning and multi-resolution did to the run's cloud, and what the view leaves out (`notice`)."""
    cleaning = session.run.cloud.cleaning or {}
    removed_by_cleaning = (f"Cleaning removed {cleaning['outliers_removed']:,} outliers and "
                           f"{cleaning['stray_removed']:,} stray points of {cleaning['input_points']:,}."
                           if cleaning.get("kept", 0) < cleaning.get("input_points", 0) else "")
    reduction = session.run.reduction
    reduced = (f"Contracted at reduced resolution: {len(reduction.points):,} voxel centroids, every point carried "
               f"along (skel-inspect --full-resolution turns it off)." if reduction is not None else "")
    return "\n\n".join(filter(None, [removed_by_cleaning, reduced, notice]))


def legend(colour_by: str, state, readiness: Readiness | None, *, note: str, visible: dict[str, bool],
           original_coloured: bool, provisional_wanted: bool, pinned: bool, labels_html: str) -> str:
    """The legend of one browser's view (`visible`: its layers shown): the layers it draws, and why a skeleton is
    provisional, or not drawn yet."""
    skeleton_shown = visible["skeleton"]
    reason = ""
    if readiness is not None and readiness.provisional and skeleton_shown:
        reason = f"{'skeleton provisional' if provisional_wanted else 'no skeleton yet'}: {readiness.reason(state)}"
    quantity = colour_by if colour_by in COLOUR_RANGES else None
    drawn = {"original": True, "contracted": True, "removed": len(state.owner) > state.n_points}  # LBC absorbs none
    layers = tuple(layer for layer in POINT_LAYERS if visible[layer] and drawn[layer])
    return legend_html(quantity, note, provisional=reason, pinned=pinned,
                       extra=labels_html if colour_by == "label" else "", skeleton=skeleton_shown, layers=layers,
                       original_coloured=original_coloured)
