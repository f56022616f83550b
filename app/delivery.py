"""The Files tab's exports for one viewer: a screenshot of its view, an animation of the run, a bundle of the
iteration it shows; each sent to its browser as a download, and also saved on the server when asked.

Pictures are rendered by the asking browser, from a camera framed on the object (app.export composes
them); the animation shows each iteration in that browser's scene in turn, then puts its view back.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Callable

import numpy as np
import viser

from skelcore.errors import InputError
from skelcore.results import write_atomic

from . import export
from .layout import FileWidgets
from .progress import Activity
from .session import Session
from .viewer import Viewer

SAVE_NAME_LENGTH = 80  # characters of a cloud's name kept in the names of exported files


class Delivery:
    def __init__(self, session: Session, files: FileWidgets, activity: Activity, save_dir: Path | None,
                 redraw: Callable[[Viewer, int], None], draw_frame: Callable[[Viewer, object, int], None],
                 skeleton_notes: Callable[[Viewer, object, int], list[str]]):
        """redraw(viewer, index): show history[index] in a viewer again (after the animation); draw_frame(viewer,
        run, index): draw run.history[index] in it at once, as its view settings draw it (a frame);
        skeleton_notes(viewer, run, index): what a picture of it says of the skeletons drawn."""
        self.session, self.files, self.activity, self.save_dir = session, files, activity, save_dir
        self.redraw, self.draw_frame, self.skeleton_notes = redraw, draw_frame, skeleton_notes

    def _size(self) -> tuple[int, int]:
        width, height = (int(v) for v in self.files.resolution.value.split("x"))
        return width, height

    @staticmethod
    def picture(viewer: Viewer, width: int, height: int, camera: dict) -> np.ndarray:
        """A render of the viewer's scene as a picture (`camera`: get_render's camera arguments), its points at the
        view's size (export.point_scale). A tiny render comes first: a browser sets a point cloud's size on the frame
        after it changes, and a render's capture runs before that in its frame, so points resized or drawn anew (a
        GLSkeleton frame whose count changed) came out 2 pixels wide."""
        client = viewer.client
        with viewer.view.picture(export.point_scale(client.camera, height)):
            client.get_render(export.WARM_UP, export.WARM_UP, transport_format="png", timeout=120, **camera)
            return client.get_render(height, width, transport_format="png", timeout=120, **camera)

    def _render(self, viewer: Viewer, index: int) -> bytes:
        width, height = self._size()
        client, run = viewer.client, self.session.run
        camera = export.framed_camera(run.cloud.points, client.camera, width, height, [run.history[index]])
        rgba = self.picture(viewer, width, height, camera)
        labels = []
        if self.files.labels.value:  # the verdict the panel shows: with the skeleton's checks once they are made
            judged = (index, self.session.skeleton_params) in run.evidence
            labels = export.caption(run.cloud.name, run.history[index],
                                    self.session.verdict(index, run, with_skeleton=judged)["label"],
                                    self.skeleton_notes(viewer, run, index))
        return export.png_bytes(rgba, labels, bool(self.files.transparent.value), viewer.view.colour_quantity)

    def stem(self, index: int | None = None) -> str:
        """The name of exported files: the cloud's, made safe for any file system and shortened, and the
        iteration (None: the whole run)."""
        name = re.sub(r"[^A-Za-z0-9._-]+", "_", Path(self.session.cloud.name).stem).strip("._-")
        suffix = "run" if index is None else f"it{self.session.history[index].iteration:03d}"
        return f"{name[:SAVE_NAME_LENGTH] or 'cloud'}-{suffix}"

    def screenshot(self, viewer: Viewer) -> None:
        index = viewer.shown
        with self.activity.busy(viewer.client, "Screenshot", "rendering the screenshot"):
            png = self._render(viewer, index)
        self.deliver(viewer.client, f"{self.stem(index)}.png", png)

    def bundle(self, viewer: Viewer) -> None:
        index = viewer.shown
        with self.activity.busy(viewer.client, "Export bundle", "rendering and writing the bundle"):
            png = self._render(viewer, index)
            data = export.bundle(self.session, index, png)
        self.deliver(viewer.client, f"{self.stem(index)}.zip", data)

    def animation(self, viewer: Viewer) -> None:
        """One frame per iteration of the run so far, from one framed camera, the iteration burned in; each drawn
        as the view draws it (its colouring, and its skeleton when the view shows that iteration's)."""
        run, shown, client = self.session.run, viewer.shown, viewer.client
        width, height = self._size()
        camera = export.framed_camera(run.cloud.points, client.camera, width, height, run.history)
        frames = []
        labels = self.files.labels.value
        with self.activity.busy(client, "Export animation", f"rendering {len(run.history)} frames"):
            try:
                for index, state in enumerate(run.history):
                    self.draw_frame(viewer, run, index)
                    rgba = self.picture(viewer, width, height, camera)
                    caption = export.caption(run.cloud.name, state, notes=self.skeleton_notes(viewer, run, index))
                    frames.append(export.compose(rgba, caption if labels else [],
                                                 colour_by=viewer.view.colour_quantity))
            finally:
                self.redraw(viewer, shown)
            files = export.animation_files(frames)
        for extension, data in files.items():
            self.deliver(client, f"{self.stem()}.{extension}", data)

    def deliver(self, client: viser.ClientHandle | None, name: str, data: bytes) -> None:
        if client is not None:
            client.send_file_download(name, data, save_immediately=True)
        if self.save_dir is not None and self.files.save_on_server.value:
            try:
                self.save_dir.mkdir(parents=True, exist_ok=True)
            except OSError as error:
                raise InputError(f"cannot create the save folder ({error.strerror})") from None
            write_atomic(self.save_dir / name, lambda path: path.write_bytes(data))  # a full disk keeps what was saved
            self.session.note(f"saved {name} on the server")
