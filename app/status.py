"""The words a browser shows about the iteration it looks at: the status under the run controls, the notes on the
run below the tabs, the verdict's headline above the histograms, and the legend over the 3-D view. Plain
functions of what is shown; nothing here computes.

The status sits above the tabs, so every line it has pushes the tabs' boxes towards the window's edge (app.layout):
it says each fact once, in few words, in three or four paragraphs (where the browser is and what the run does; the
shown cloud's figures; a warning or the skeleton's state), and leaves figures of the run's end and the explanations
to the notes and the legend."""
from __future__ import annotations

from typing import Callable

from skelcore import single_view
from skelcore.metrics import JUDGED_POINTS
from skelcore.step import REJECTION_CAUSES, TERMINATION_MESSAGES

from .analysis import Readiness
from .colours import COLOUR_RANGES, POINT_LAYERS, legend_html
from .layout import PROVISIONAL
from .words import label


def ending_words(state) -> str:
    """The words a run's last state ended on, without their figures (TERMINATION_MESSAGES; a run opened from
    files may name a reason this engine lacks: its whole message then)."""
    return TERMINATION_MESSAGES.get(state.termination, state.message)


def run_state(history, doing: str, playing: bool, ahead=None, paused: bool = False, weights=None) -> str:
    """What the shared run is doing, in a few words (ahead: the next state, when it was computed ahead; paused: a
    person paused it playing, app.playback.Playback.paused: "paused" then, else "ready" between steps; weights: the
    run's per-point contraction weights, named where a discarded step ends the run, as they can be its cause)."""
    latest = history[-1]
    if playing:  # the Play button says Pause meanwhile (app.playback)
        if latest.termination:  # Play on an ended run replays its iterations
            return "replaying"
        return f"playing: {doing}…" if doing else "playing"
    if doing:
        return f"busy: {doing}…"
    if latest.termination:  # at the iteration the status's "of N computed" names
        return f"ended: {ending_words(latest)}{_weights_in_force(latest, weights)}"
    state = "paused" if paused and len(history) > 1 else "ready"
    if ahead is None:
        return state
    if ahead.iteration <= latest.iteration:  # the next step was rejected: Step ends the run
        return f"{state}; the next step, computed ahead, ends the run{_weights_in_force(ahead, weights)}"
    return f"{state}; iteration {ahead.iteration} computed ahead"


def _weights_in_force(state, weights) -> str:
    """" (per-point weights 1 to 1e+09 in force)" after a step discarded by a run whose weights are not all 1: a
    weight far from 1 can make the system fail, and nothing else on the screen would say it is there."""
    if weights is None or not len(weights) or state.termination not in REJECTION_CAUSES:
        return ""
    low, high = float(weights.min()), float(weights.max())
    return "" if low == high == 1.0 else f" (per-point weights {low:g} to {high:g} in force)"


def hold_inside_hint(verdict: dict, state, solid_loops: Callable[[], int | None], mesh: bool = True) -> str:
    """What to try when the verdict's skeleton keeps fewer loops than the solid has (`solid_loops()`: a closed mesh's
    genus, or with mesh False those a closed point cloud's inside test reads; asked only for a judged skeleton of a
    run that did not hold its points inside the solid, as reading a cloud's takes a few tenths of a second) and the
    run did not hold them (`skelcore run` tries that by itself); "" otherwise."""
    loops = next((c for c in verdict.get("criteria", []) if c["name"] == "skeleton loops"), None)
    if loops is None or state.params.hold_inside:
        return ""
    solid = solid_loops()
    if solid is None or int(loops["value"]) >= solid:
        return ""
    return (f"{loops['value']} of the {'mesh' if mesh else 'solid'}'s {solid} "
            f"loop{'' if solid == 1 else 's'} kept: try More > {label('hold_inside')}")


# The verdict's headline above the histograms, in characters shown: two lines of the 470 px plots panel (118, a
# third of them bold, took two lines in Chromium; 124 took three). A third gave the panel a scrollbar at 1280x720.
HEADLINE_CHARS = 115
HEADLINE_CRITERIA = 2  # failed criteria named in it, at most
VERDICT_TAB = "(see Verdict tab)"


def verdict_headline(head: str, failed: list[str], hint: str = "") -> str:
    """The verdict above the histograms (markdown), within HEADLINE_CHARS where it can be (the panel clamps the rest,
    app.viewer.HEADLINE_STYLE): `head` (markdown, "**Iteration 4: unstable**"), the failed criteria, named while
    that fits and counted when it does not, and `hint` (what to try). The Verdict tab shows every criterion and the
    hint."""
    said = [f"failed: {', '.join(failed[:shown])}" + (f" and {len(failed) - shown} more" if len(failed) > shown
                                                      else "")
            for shown in range(min(len(failed), HEADLINE_CRITERIA), 0, -1)]
    if len(failed) > 1:
        said.append(f"{len(failed)} criteria failed")

    def line(failures: str, bold: str = "**", italic: str = "_") -> str:
        return (" · ".join(filter(None, [head.replace("**", bold), failures, hint and f"{bold}{hint}{bold}"]))
                + f" {italic}{VERDICT_TAB}{italic}")
    failures = next((each for each in said if len(line(each, "", "")) <= HEADLINE_CHARS), said[-1] if said else "")
    return line(failures)


def skeleton_note(readiness: Readiness | None, skeleton_shown: bool, provisional_wanted: bool) -> str:
    """Whether the skeleton of a state of this readiness is drawn, when not as a final one ("" when it is final or
    hidden); why not is the legend's to say."""
    if readiness is None or not readiness.provisional or not skeleton_shown:
        return ""
    return "skeleton drawn provisionally" if provisional_wanted else f"no skeleton yet (View: {PROVISIONAL})"


def status_markdown(session, index: int, *, run: str, readiness: Readiness | None, skeleton: str,
                    following: bool) -> str:
    """The status of history[index] as one browser sees it; `readiness`: None while not measured yet. Parameter
    changes (`pending_markdown`) and notes on the run (`run_notes`) are said below the tabs."""
    history = session.history
    state, latest = history[index], history[-1]
    removed = len(state.owner) - state.n_points
    counts = (f"{state.n_points:,} points retained, {removed:,} removed" if removed
              else f"{state.n_points:,} points")
    held = f", {state.anchored:,} held on thin handles" if state.anchored else ""
    share = "…" if readiness is None else f"{readiness.share:.0%}"
    # a line breaks between two figures, never inside one ("W_L =" at one line's end, its value on the next)
    figures = [f"<span style='white-space:nowrap'>{figure}</span>" for figure in (
        f"W_L = {state.wl:.4g}", f"W_H in [{state.wh.min():.3g}, {state.wh.max():.3g}]",
        f"ring-size ratio a_t = {state.ring_ratio:.4f}", f"curve-like {share}")]
    behind = "" if following or index == len(history) - 1 else " &middot; _not following the newest (key L)_"
    return "\n\n".join(filter(None, [
        f"**Iteration {state.iteration}** {_computed(latest.iteration)}{behind} &middot; run {run}",
        " &middot; ".join([counts + held, *figures]),
        # what it means for the skeleton, the legend says beside it
        readiness is not None and readiness.barely_contracted
        and f"⚠ **Barely contracted:** {readiness.barely_contracted}",
        skeleton and f"_{skeleton}_",
    ]))


def pending_markdown(session) -> str:
    """The parameter changes waiting for the next step or a restart (below the tabs: it grows as a person types
    into a box, so it must not push that box down)."""
    return session.pending and f"**Pending:** {session.pending}"


def run_notes(run, state, notice: str, skeleton: list[str] | None = None) -> str:
    """What the status leaves out, of `run` (app.run.Run) and its shown `state`: what loading and cleaning
    did to the input (the cloud's notes: a mesh drawn over, points dropped, outliers removed, ...), what the
    skeleton's balls cannot resolve and the loops it cut as more than the solid has (`skeleton`), the
    contraction at reduced resolution, the points held on thin handles, what the view leaves out (`notice`),
    the sample the histograms judge and the figures the run ended on."""
    inside = None if run.metrics is None else run.metrics.reference.inside
    input_notes = [note[:1].upper() + note[1:] + ("" if note.endswith(".") else ".")
                   for note in [*single_view.with_note(run.cloud.notes, inside), *(skeleton or [])]]
    reduction = run.reduction
    if reduction is None:
        reduced = ""
    elif reduction.thinned:
        reduced = (f"Dense parts thinned for the contraction: {reduction.n_input - len(reduction.points):,} of the "
                   f"{reduction.n_input:,} points, in parts many times denser than the surface around them, were left "
                   f"out of it, each carried along with its nearest contracted point (so in the histograms they can "
                   f"stand together as a narrow spike; skel-inspect --full-resolution turns it off).")
    elif reduction.scan_lines:
        reduced = (f"Contracted on {len(reduction.points):,} voxel centroids one line spacing apart: the points lie "
                   f"on scan lines {reduction.scan_lines:.1f} times farther apart than the points along them, where "
                   f"one-rings are strips; every point carried along (skel-inspect --full-resolution turns it off).")
    else:
        reduced = (f"Contracted at reduced resolution: {len(reduction.points):,} voxel centroids, every point "
                   f"carried along (skel-inspect --full-resolution turns it off).")
    points, merging = len(run.cloud.points), state.params.method == "glskeleton"
    judged = (f"a fixed random sample of {JUDGED_POINTS:,} of the {points:,} points" if points > JUDGED_POINTS
              else f"the {points:,} points")
    unmerged = ", those of them GLSkeleton has not merged into others" if merging else ""
    sampled = (f"The histograms judge {judged}{unmerged}; their n counts those with a value (a point whose "
               f"neighbourhood has collapsed to a point has no normal or curvature)."
               if points > JUDGED_POINTS or merging else "")
    held = (f"{state.anchored:,} points on thin handles are held in place and drawn on their axis "
            f"(More: {label('hold_curves')})." if state.anchored else "")
    latest = run.history[-1]
    end_figures = (f"Run ended at iteration {latest.iteration}: {latest.message}."
                   if latest.termination and latest.message != ending_words(latest) else "")
    return "\n\n".join(filter(None, [*input_notes, reduced, held, notice, sampled, end_figures]))


def legend(colour_by: str, state, readiness: Readiness | None, *, note: str, visible: dict[str, bool],
           original_coloured: bool, provisional_wanted: bool, pinned: bool, labels_html: str) -> str:
    """The legend of one browser's view (`visible`: its layers shown): the layers it draws (the skeleton's node
    kinds once the state is known to have a skeleton drawn), and why a skeleton is provisional, not drawn yet, or
    may not follow the shape."""
    skeleton_shown = visible["skeleton"]
    skeleton_drawn = (skeleton_shown and readiness is not None
                      and (not readiness.provisional or provisional_wanted))  # as app.presenter draws it
    caveat = ""
    if readiness is not None and readiness.provisional and skeleton_shown:
        caveat = f"{'skeleton provisional' if provisional_wanted else 'no skeleton yet'}: {readiness.reason(state)}"
    elif readiness is not None and readiness.barely_contracted and skeleton_shown:
        caveat = "⚠ barely contracted: the skeleton may not follow the shape"
    quantity = colour_by if colour_by in COLOUR_RANGES else None
    drawn = {"original": True, "contracted": True, "removed": len(state.owner) > state.n_points}  # LBC absorbs none
    layers = tuple(layer for layer in POINT_LAYERS if visible[layer] and drawn[layer])
    return legend_html(quantity, note, caveat=caveat, pinned=pinned,
                       extra=labels_html if colour_by == "label" else "", skeleton=skeleton_drawn, layers=layers,
                       original_coloured=original_coloured, points_coloured=colour_by != "plain")


def _computed(newest: int) -> str:
    """How far the run has got, after the shown iteration's number. Before the first Step: "taken", not "computed",
    since the run state beside it may say the next iteration was computed ahead."""
    return "(the input) &middot; no step taken yet" if newest == 0 else f"of {newest} computed"
