"""The Labels panel: a labelled cloud's per-label contraction weights, and its colours by label.

Shown only for a cloud with labels (a PLY label property, or labels given to skelcore.inspect). A weight
changed here applies on the next Restart (it changes the system being solved, not one step). The weights are text
boxes taken as the parameters' are (app.panel): once the person stops typing, a refused one said and put back.
"""
from __future__ import annotations

import html

import numpy as np
import viser

from .panel import ParameterPanel, Part
from .session import Session
from .words import number_text, typed_weight

# Distinct hues for categories, none of the scene's own (red contracted points, blue ends, orange junctions,
# purple removed points): ColorBrewer's Dark2/Set1 picks; the label's rank picks one, cycling
PALETTE = np.array([[77, 175, 74], [231, 41, 138], [166, 118, 29], [27, 158, 119], [230, 171, 2], [102, 102, 102],
                    [166, 206, 227], [102, 166, 30], [251, 154, 153], [0, 90, 50]], dtype=np.uint8)
MAX_WEIGHT_INPUTS = 12  # weight inputs for the labels with the most points; the others keep their weight


class LabelPanel:
    """The "Labels" GUI folder (placed at `order`), rebuilt for each cloud by `refresh`; the weights typed, once
    `panel` takes them, go to session.set_label_weights on the engine worker (`submit`), then `on_change` runs."""

    def __init__(self, gui: viser.GuiApi, session: Session, panel: ParameterPanel, submit, on_change, order: float):
        self.gui, self.session, self.panel, self.order = gui, session, panel, order
        self.submit, self.on_change = submit, on_change
        self.folder = None
        self.inputs: dict[int, viser.GuiTextHandle] = {}
        self.values = np.zeros(0, dtype=np.int64)  # the cloud's distinct labels, ascending
        self.accepted: dict[int, float] = dict(session.label_weights)  # the weights last taken
        panel.add_part("labels", Part(self._shown, self._take, self._put_back))

    def refresh(self) -> None:
        """Rebuild for the session's cloud (after a load or a restart)."""
        if self.folder is not None:
            self.folder.remove()
            self.folder, self.inputs = None, {}
        labels = self.session.cloud.labels
        self.values, counts = (np.unique(labels, return_counts=True) if labels is not None
                               else (np.zeros(0, dtype=np.int64), np.zeros(0)))
        self.accepted = dict(self.session.label_weights)
        if not len(self.values):
            return
        shown = sorted(self.values[np.argsort(-counts, kind="stable")[:MAX_WEIGHT_INPUTS]].tolist())
        count_of = dict(zip(self.values.tolist(), counts.tolist()))
        with self.gui.add_folder("Labels", order=self.order) as self.folder:
            listed = "" if len(shown) == len(self.values) else f" (the {len(shown)} largest listed)"
            self.gui.add_markdown(f"{len(self.values)} labels{listed}. Contraction weight per label (a multiplier "
                                  "of W_L on its points' rows); applies on Restart.")
            for label in shown:  # text boxes: viser's number box sends 13 for a typed 1e3
                handle = self.gui.add_text(f"Label {label} ({count_of[label]:,} pts)",
                                           initial_value=number_text(self.accepted.get(label, 1.0)))
                handle.on_update(self._on_typed)
                self.inputs[label] = handle

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
