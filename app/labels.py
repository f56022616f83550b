"""The Labels tab: a labelled cloud's per-label contraction weights, and its colours by label.

A tab beside the others, so that its boxes, like theirs, sit under the run controls in a 1280x720 window (a folder
below the tabs put them under the window's edge, and typing into one scrolled Step and Play away). Shown only for
a cloud with labels (a PLY label property, or labels given to skelcore.inspect). A weight changed here applies on
the next Restart (it changes the system being solved, not one step). The weights are text boxes taken as the
parameters' are (app.panel): once the person stops typing, a refused one said and put back.
"""
from __future__ import annotations

import html

import numpy as np
import viser

from .panel import ParameterPanel, Part
from .session import Session
from .words import number_text, typed_weight, weight_name

# Distinct hues for categories, none of the scene's own (red contracted points, blue ends, orange junctions,
# purple removed points): ColorBrewer's Dark2/Set1 picks; the label's rank picks one, cycling
PALETTE = np.array([[77, 175, 74], [231, 41, 138], [166, 118, 29], [27, 158, 119], [230, 171, 2], [102, 102, 102],
                    [166, 206, 227], [102, 166, 30], [251, 154, 153], [0, 90, 50]], dtype=np.uint8)
MAX_WEIGHT_INPUTS = 5  # a box per label up to this many (as many as fit a 1280x720 window under the longest
# status); beyond, one box for the label chosen from a list (the Legend lists every label's weight)


class LabelPanel:
    """The "Labels" tab of `tabs`, rebuilt for each cloud by `refresh`; the weights typed, once `panel` takes them,
    go to session.set_label_weights on the engine worker (`submit`), then `on_change` runs."""

    def __init__(self, gui: viser.GuiApi, session: Session, panel: ParameterPanel, submit, on_change,
                 tabs: viser.GuiTabGroupHandle, wire_restart):
        """wire_restart(button): make `button` restart the run with the panel's parameters and weights."""
        self.gui, self.session, self.panel, self.tabs = gui, session, panel, tabs
        self.submit, self.on_change, self.wire_restart = submit, on_change, wire_restart
        self.tab = None
        self.inputs: dict[int, viser.GuiTextHandle] = {}  # label -> the box of its weight
        self._choice, self._by_name = None, {}  # with more labels than boxes: the list to choose one from
        self.values = np.zeros(0, dtype=np.int64)  # the cloud's distinct labels, ascending
        self.accepted: dict[int, float] = dict(session.label_weights)  # the weights last taken
        panel.add_part("labels", Part(self._shown, self._take, self._put_back,
                                      lambda: {weight_name(label): box for label, box in self.inputs.items()}))

    def refresh(self) -> None:
        """Rebuild for the session's cloud (after a load or a restart)."""
        if self.tab is not None:
            self.tab.remove()
            self.tab, self.inputs = None, {}
        labels = self.session.cloud.labels
        self.values, counts = (np.unique(labels, return_counts=True) if labels is not None
                               else (np.zeros(0, dtype=np.int64), np.zeros(0)))
        self.accepted = dict(self.session.label_weights)
        if not len(self.values):
            return
        count_of = dict(zip(self.values.tolist(), counts.tolist()))
        named = {label: f"Label {label} ({count_of[label]:,} pts)" for label in self.values.tolist()}
        with self.tabs.add_tab("Labels") as self.tab:
            if len(self.values) <= MAX_WEIGHT_INPUTS:
                for label, name in named.items():  # text boxes: viser's number box sends 13 for a typed 1e3
                    self.inputs[label] = self._weight_box(name, label)
            else:  # more than fit: one box, for the label chosen
                first = int(self.values[np.argmax(counts)])
                self._choice = self.gui.add_dropdown("Label", tuple(named.values()), initial_value=named[first])
                self._by_name = {name: label for label, name in named.items()}
                self._choice.on_update(self._on_chosen)
                self.inputs[first] = self._weight_box("Weight", first)
            self.wire_restart(self.gui.add_button("Restart with these weights",
                                                  hint="a label's weight multiplies W_L on its points' rows"))

    def _weight_box(self, name: str, label: int) -> viser.GuiTextHandle:
        box = self.gui.add_text(name, initial_value=number_text(self.accepted.get(label, 1.0)))
        box.on_update(self._on_typed)
        return box

    async def _on_chosen(self, event: viser.GuiEvent) -> None:
        """The one weight box now edits the chosen label's weight: what was typed for the label before is taken
        first."""
        if event.client is None:
            return
        self.panel.flush()
        label, box = self._by_name[self._choice.value], next(iter(self.inputs.values()))
        self.inputs = {label: box}
        box.value = number_text(self.accepted.get(label, 1.0))

    def colours(self, point_ids: np.ndarray) -> np.ndarray | None:
        """(m,3) colours of the labels of the input points `point_ids` (None: the cloud has no labels)."""
        labels = self.session.cloud.labels
        if labels is None:
            return None
        return PALETTE[np.searchsorted(self.values, labels[point_ids]) % len(PALETTE)]

    def legend_html(self) -> str:
        if not len(self.values):
            return "<div style='font-size:0.8em;padding:0 0.5em'>This cloud has no labels.</div>"
        weights = self.session.label_weights
        items = [f"<span style='color:rgb{tuple(PALETTE[rank % len(PALETTE)].tolist())}'>&#9679;</span> "
                 f"{html.escape(str(label))} (w={weights.get(label, 1.0):g})"
                 for rank, label in enumerate(self.values.tolist())]
        return f"<div style='font-size:0.8em;padding:0 0.5em'>{' &nbsp; '.join(items)}</div>"

    async def _on_typed(self, event: viser.GuiEvent) -> None:
        if event.client is not None:
            self.panel.changed("labels", event.client, typing=True)

    def _shown(self) -> dict[int, float]:
        """Every label's weight as the boxes show it (those not listed keep theirs); ParameterError: refused."""
        table = dict(self.accepted)
        table.update({label: typed_weight(label, handle.value) for label, handle in self.inputs.items()})
        return table

    def _take(self, table: dict[int, float], client) -> None:
        self.accepted = table

        def apply() -> None:
            self.session.set_label_weights({label: w for label, w in table.items() if w != 1.0})
            self.on_change()
        self.submit(apply, client)

    def _put_back(self) -> None:
        for label, handle in self.inputs.items():
            handle.value = number_text(self.accepted.get(label, 1.0))
