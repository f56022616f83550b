"""Opening clouds in the inspector: a bundled asset, an upload, a too large cloud voxel-downsampled on
request, a file with NaN rows loaded without them on request. Reading and the one-rings of the new run
happen on the engine worker; a failure leaves the current run as it was."""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from skelcore.errors import InputError, NonFiniteError, TooLargeError
from skelcore.io import load, load_bytes
from skelcore.memory import INSPECTOR_SHARE, budget_bytes

from .layout import NO_ASSET, FileWidgets
from .messages import Messages
from .playback import Playback
from .progress import PROGRESS_AFTER, Activity
from .session import Session
from .worker import Worker


class Loader:
    def __init__(self, session: Session, files: FileWidgets, worker: Worker, playback: Playback, activity: Activity,
                 messages: Messages, assets: dict[str, Path], max_upload_bytes: int,
                 loaded: Callable[[], None]):
        """loaded(): draw the new run (on the worker, after a load)."""
        self.session, self.files, self.worker, self.playback = session, files, worker, playback
        self.activity, self.messages, self.assets = activity, messages, assets
        self.max_upload_bytes, self.loaded = max_upload_bytes, loaded
        self.offer = None  # (voxel size, read) of a too large cloud offered voxel-downsampled

    def open(self, cloud) -> None:
        """Replace the session's cloud by a validated skelcore.io.Cloud."""
        self.playback.pause()
        self.worker.submit(lambda: self.load(lambda voxel=None, drop=False: cloud))

    def select_loaded(self) -> None:
        """The asset list selects the cloud loaded when it is a bundled asset, else a first entry that selects none
        (an upload, the command line's file): a list left at another asset reads as the cloud shown. (A browser's
        list keeps showing its last choice for a value that is none of its entries.)"""
        if not self.assets:  # the list only says there are none
            return
        loaded = Path(self.session.cloud.name).resolve()
        name = next((name for name, path in self.assets.items() if path.resolve() == loaded), None)
        listed = self.files.asset
        if name is None:
            listed.options = (NO_ASSET, *self.assets)
            listed.value = NO_ASSET
        else:
            listed.value = name  # before the entry it replaces goes
            listed.options = tuple(self.assets)

    def on_load_asset(self, event) -> None:
        path = self.assets.get(self.files.asset.value)
        if path is not None:  # only names of files the server listed itself
            self.playback.pause()
            read = lambda voxel=None, drop=False: load(path, drop_nonfinite=drop, voxel_size=voxel,  # noqa: E731
                                                       budget=_budget())
            self.worker.submit(lambda: self.load(read, event.client, f"Loading {path.name}"), event.client)

    def on_upload(self, event) -> None:
        upload = self.files.upload.value
        if len(upload.content) > self.max_upload_bytes:
            self.messages.notify(event.client, "Upload refused",
                                 f"{upload.name}: {len(upload.content) / 2**20:.1f} MiB exceeds the cap of "
                                 f"{self.max_upload_bytes / 2**20:.0f} MiB")
            return
        self.playback.pause()
        read = lambda voxel=None, drop=False: load_bytes(upload.content, upload.name,  # noqa: E731
                                                         drop_nonfinite=drop, voxel_size=voxel, budget=_budget())
        self.worker.submit(lambda: self.load(read, event.client, f"Reading {upload.name}", at_once=True),
                           event.client)

    def on_downsample(self, event) -> None:
        if self.offer is not None:
            voxel, read = self.offer
            self.playback.pause()
            self.worker.submit(lambda: self.load(lambda _=None, drop=False: read(voxel, drop), event.client,
                                                 "Loading downsampled"), event.client)

    def load(self, read, client=None, what: str = "Loading", at_once: bool = False) -> None:
        """On the worker. at_once: say so at once (an upload: viser's progress bar has just gone)."""
        try:
            with self.activity.busy(client, what, f"{what.lower()} and computing its one-rings",
                                    after=0.0 if at_once else PROGRESS_AFTER):
                try:
                    cloud = read()  # an InputError leaves the session as it was
                except NonFiniteError as error:
                    self._offer_to_drop(client, error, _dropping(read), what)
                    return
                kept = self.session.load(cloud)
        except TooLargeError as error:
            self.offer = (error.voxel_size, read)
            self.files.downsample.label = f"Load downsampled (voxel {error.voxel_size:g})"
            self.files.downsample.visible = True
            raise InputError(f"{error}: press '{self.files.downsample.label}' in Files") from None
        self.offer = None
        self.files.downsample.visible = False
        self.loaded()
        said = [*cloud.notes, kept] if kept else cloud.notes
        if said:
            self.messages.notify(client, f"Loaded {Path(cloud.name).name}", "; ".join(said), color="blue")

    def _offer_to_drop(self, client, error: NonFiniteError, read, what: str) -> None:
        """A file with a few NaN/Inf rows, which `read` leaves out: ask the person who loaded it whether to load it
        without them (a question, not an error); with nobody to ask, say why it was not loaded."""
        if client is None:
            self.messages.notify(client, "Points with NaN or Inf", str(error))
            return
        with client.gui.add_modal("Points with NaN or Inf") as modal:
            client.gui.add_markdown(f"{error}. Load the file without these {error.count:,} points?")
            drop = client.gui.add_button(f"Drop {error.count:,} points and load")
            cancel = client.gui.add_button("Cancel", color="gray")

        @drop.on_click
        async def _(event) -> None:
            modal.close()
            self.worker.submit(lambda: self.load(read, client, what, at_once=True), client)

        @cancel.on_click
        async def _(event) -> None:
            modal.close()


def _dropping(read):
    """`read` leaving out the points with NaN or Inf. They are left out now: a file whose other points cannot be
    loaded (too few of them, say) is refused at once, not after the person agreed to drop them; what can is kept
    for Drop. A cloud too large is read again then, to be offered voxel-downsampled."""
    try:
        cloud = read(drop=True)
    except TooLargeError:
        return lambda voxel=None, drop=False: read(voxel, True)
    return lambda voxel=None, drop=False: cloud


def _budget() -> int:
    """The memory a run in the inspector may take: a smaller share of the machine than the command line's."""
    return budget_bytes(INSPECTOR_SHARE)
