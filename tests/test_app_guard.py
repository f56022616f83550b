"""The inspector's server against hostile clients: a raw websocket client uploading too much or giving up
half-way, a server bound beyond this machine that needs its token, and paths that never leave it."""
from __future__ import annotations

import re
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
import uuid
from pathlib import Path

import msgspec
import psutil
import pytest
import websockets.sync.client

import viser
from app.main import serve, viser_server
from skelcore.io import validate
from skelcore.shapes import make_shape

MIB = 2**20
REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def served():
    cloud = validate(make_shape("torus", 800).points, name="torus.xyz")
    server, inspector = serve(cloud, "127.0.0.1", 0)
    refusals: list[tuple[int, str, str]] = []
    guard = inspector.upload_guard
    original = guard.on_refused

    def record(client_id, name, reason):
        refusals.append((client_id, name, reason))
        original(client_id, name, reason)

    guard.on_refused = record
    inspector.refusals = refusals
    yield server, inspector
    inspector.close()
    server.stop()


class RawClient:
    """A websocket client that speaks viser's wire format for the two upload messages, and nothing else."""

    def __init__(self, port: int, headers: dict | None = None, camera: bool = False):
        self.ws = websockets.sync.client.connect(
            f"ws://127.0.0.1:{port}", subprotocols=[f"viser-v{viser.__version__}"], max_size=None,
            compression=None, additional_headers=headers, proxy=None)
        self._drain = threading.Thread(target=self._read, daemon=True)
        self._drain.start()
        if camera:  # what makes viser count it as a client, as a browser does on connecting
            self.send(type="ViewerCameraMessage", wxyz=[1.0, 0.0, 0.0, 0.0], position=[0.0, 0.0, 3.0], fov=1.0,
                      near=0.01, far=100.0, image_height=600, image_width=800, look_at=[0.0, 0.0, 0.0],
                      up_direction=[0.0, 1.0, 0.0])

    def _read(self):
        try:
            while True:
                self.ws.recv()
        except Exception:  # closed
            pass

    def send(self, **message):
        self.ws.send(msgspec.msgpack.encode(message))

    def start(self, button: str, size: int, parts: int, name: str = "cloud.ply") -> str:
        transfer = uuid.uuid4().hex
        self.send(type="FileTransferStartUpload", source_component_uuid=button, transfer_uuid=transfer,
                  filename=name, mime_type="application/octet-stream", part_count=parts, size_bytes=size)
        return transfer

    def part(self, button: str, transfer: str, index: int, content: bytes):
        self.send(type="FileTransferPart", source_component_uuid=button, transfer_uuid=transfer,
                  part_index=index, content=content)

    def close(self):
        self.ws.close()
        self._drain.join(timeout=30)


def rss() -> int:
    return psutil.Process().memory_info().rss


def settle(predicate, what: str, timeout: float = 120.0):
    deadline = time.monotonic() + timeout  # waiting limit only
    while not predicate():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)


def test_oversized_and_abandoned_uploads_keep_memory_bounded(served):
    server, inspector = served
    guard, button = inspector.upload_guard, inspector.ui.files.upload._impl.uuid
    cap = inspector.max_upload_bytes
    chunk = bytes(MIB)
    baseline = rss()

    # 1. announces 600 MB, then sends them anyway (three times, as in the report): refused at the start
    client = RawClient(server.get_port())
    for attempt in range(3):
        transfer = client.start(button, 600 * MIB, 600)
        for index in range(600):
            client.part(button, transfer, index, chunk)
    client.ws.ping().wait(60)  # everything sent so far has been handled
    settle(lambda: len(inspector.refusals) >= 3, "three refusals")
    assert all("exceeds the cap" in reason for _, _, reason in inspector.refusals[:3])
    assert guard.in_flight() == 0 and not server.gui._current_file_upload_states
    oversized = rss() - baseline

    # 2. a client that lies: announces 1 MiB in two parts, and sends 8 MiB in the first
    transfer = client.start(button, MIB, 2)
    client.part(button, transfer, 0, bytes(8 * MIB))
    client.ws.ping().wait(60)
    settle(lambda: len(inspector.refusals) >= 4, "the lying upload refused")
    assert "more bytes arrived" in inspector.refusals[3][2]

    # 3. abandoned: announces the cap, sends all but one part, and stays
    parts = cap // MIB
    transfer = client.start(button, cap, parts)
    for index in range(parts - 1):
        client.part(button, transfer, index, chunk)
    client.ws.ping().wait(60)
    settle(lambda: guard.in_flight() == cap, "the abandoned transfer to be buffered")
    abandoned = rss() - baseline
    client.close()  # ... then leaves: freed at once, not by the idle sweep
    settle(lambda: guard.in_flight() == 0 and not server.gui._current_file_upload_states, "the buffer freed",
           timeout=guard.idle_seconds / 2)
    time.sleep(1.0)
    after = rss() - baseline
    print(f"server memory over baseline: oversized {oversized / MIB:.0f} MB, abandoned {abandoned / MIB:.0f} MB, "
          f"after the client left {after / MIB:.0f} MB (cap {cap / MIB:.0f} MB)")
    assert oversized < 50 * MIB
    assert abandoned < cap + 50 * MIB
    assert after < 50 * MIB


def test_an_idle_transfer_is_dropped_while_its_client_stays(served):
    server, inspector = served
    guard, button = inspector.upload_guard, inspector.ui.files.upload._impl.uuid
    guard.idle_seconds = 1.0
    before = len(inspector.refusals)
    try:
        client = RawClient(server.get_port())
        transfer = client.start(button, 4 * MIB, 4)
        client.part(button, transfer, 0, bytes(MIB))
        client.ws.ping().wait(60)
        # under load the idle second may pass before the first look: the abandoned refusal shows it started
        abandoned = lambda: any("abandoned" in refusal[2] for refusal in inspector.refusals[before:])
        settle(lambda: guard.in_flight() == 4 * MIB or abandoned(), "the transfer to start")
        settle(lambda: guard.in_flight() == 0, "the idle transfer to be dropped")
        assert transfer not in server.gui._current_file_upload_states
        settle(abandoned, "the abandoned refusal")  # said just after the transfer is dropped
        client.close()
    finally:
        guard.idle_seconds = 30.0


def test_a_whole_upload_within_the_cap_still_loads(served):
    server, inspector = served
    button = inspector.ui.files.upload._impl.uuid
    content = "\n".join(" ".join(map(str, p)) for p in make_shape("y_branch", 500).points).encode()
    client = RawClient(server.get_port(), camera=True)
    transfer = client.start(button, len(content), 1, name="branch.xyz")
    client.part(button, transfer, 0, content)
    client.ws.ping().wait(60)
    settle(lambda: inspector.session.cloud.name == "branch.xyz", "the uploaded cloud to load")
    assert inspector.wait_idle(120)
    client.close()


def test_a_token_guards_page_and_websocket():
    token = "s3cret-token"
    server = viser_server("127.0.0.1", 0, token=token)
    try:
        port = server.get_port()
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=60)
        assert refused.value.code == 403
        with pytest.raises(urllib.error.HTTPError):
            urllib.request.urlopen(f"http://127.0.0.1:{port}/?token=wrong", timeout=60)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/?token={token}", timeout=60) as page:
            assert page.status == 200 and b"<html" in page.read().lower()
            cookie = page.headers["Set-Cookie"].split(";")[0]
        assert "HttpOnly" in page.headers["Set-Cookie"] and "SameSite=Strict" in page.headers["Set-Cookie"]
        with pytest.raises(websockets.exceptions.InvalidStatus):
            RawClient(port)
        with pytest.raises(websockets.exceptions.InvalidStatus):  # the page's cookie, from another site
            RawClient(port, headers={"Cookie": cookie, "Origin": "http://evil.example"})
        RawClient(port, headers={"Cookie": cookie}).close()
    finally:
        server.stop()


def test_binding_beyond_loopback_warns_and_prints_a_token_url():
    process = subprocess.Popen([sys.executable, "-m", "app.main", "--host", "0.0.0.0", "--port", "0"],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=REPO)
    try:
        lines, url = [], None
        deadline = time.monotonic() + 120  # waiting limit only
        while url is None and time.monotonic() < deadline:
            line = process.stdout.readline()
            if not line:
                break
            lines.append(line)
            url = re.search(r"http://\S+:(\d+)/\?token=([\w-]+)", line)
        assert url, "".join(lines)
        assert any("warning" in line and "0.0.0.0" in line for line in lines)
        port, token = url.group(1), url.group(2)
        with pytest.raises(urllib.error.HTTPError):
            urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=60)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/?token={token}", timeout=60) as page:
            assert page.status == 200
    finally:
        process.terminate()
        process.wait(timeout=60)


def test_no_token_must_be_asked_for_and_still_warns():
    process = subprocess.Popen([sys.executable, "-m", "app.main", "--host", "0.0.0.0", "--port", "0", "--no-token"],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=REPO)
    try:
        lines = []
        deadline = time.monotonic() + 120  # waiting limit only
        while time.monotonic() < deadline:
            line = process.stdout.readline()
            if not line:
                break
            lines.append(line)
            if "Ctrl+C" in line:
                break
        assert any("warning" in line and "--no-token" in line for line in lines), lines
        port = re.search(r":(\d+)  \(Ctrl", lines[-1]).group(1)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=60) as page:
            assert page.status == 200
    finally:
        process.terminate()
        process.wait(timeout=60)


def test_save_names_are_sanitised_and_short_and_paths_stay_on_the_server(served, tmp_path):
    server, inspector = served
    from app.messages import without_paths

    inspector.delivery.save_dir = tmp_path / "saves"
    inspector.ui.files.save_on_server.value = True
    try:
        long_name = ("a/../b \u00e9" + "x" * 300)[:251] + ".xyz"
        inspector.open(validate(make_shape("torus", 300).points, name=long_name))
        assert inspector.wait_idle(120)
        stem = inspector.delivery.stem(inspector.shown)
        assert len(stem) <= 100 and re.fullmatch(r"[A-Za-z0-9._-]+", stem)
        inspector.delivery.deliver(None, f"{stem}.png", b"png")
        assert (tmp_path / "saves" / f"{stem}.png").read_bytes() == b"png"
        assert not any(str(tmp_path) in line for line in inspector.session.log)
        assert without_paths(f"{tmp_path}/saves/x.png: cannot write") == "x.png: cannot write"
    finally:
        inspector.ui.files.save_on_server.value = False
        inspector.delivery.save_dir = None


def test_a_full_disk_on_save_is_one_line_and_keeps_earlier_saves(served, tmp_path, monkeypatch):
    import errno
    import os

    from skelcore import results
    from skelcore.errors import OutputError

    server, inspector = served
    inspector.delivery.save_dir = tmp_path / "saves"
    inspector.ui.files.save_on_server.value = True
    try:
        inspector.delivery.deliver(None, "first.png", b"first")
        real = os.replace

        def replace(source, destination):
            raise OSError(errno.ENOSPC, "No space left on device")

        monkeypatch.setattr(results.os, "replace", replace)
        with pytest.raises(OutputError, match="disk is full"):
            inspector.delivery.deliver(None, "second.png", b"second")
        monkeypatch.setattr(results.os, "replace", real)
        assert (tmp_path / "saves" / "first.png").read_bytes() == b"first"
        assert sorted(p.name for p in (tmp_path / "saves").iterdir()) == ["first.png"]
    finally:
        inspector.ui.files.save_on_server.value = False
        inspector.delivery.save_dir = None


@pytest.mark.browser
def test_a_browser_with_the_token_url_gets_the_inspector():
    from browser_support import browser_missing, launch, open_inspector

    if browser_missing():
        pytest.skip(browser_missing())
    from playwright.sync_api import sync_playwright

    cloud = validate(make_shape("torus", 500).points, name="torus.xyz")
    server, inspector = serve(cloud, "127.0.0.1", 0, token="browser-token")
    try:
        with sync_playwright() as playwright:
            browser = launch(playwright)
            page = open_inspector(browser, f"http://127.0.0.1:{server.get_port()}/?token=browser-token")
            assert len(server.get_clients()) == 1  # its websocket passed the gate with the cookie
            stranger = browser.new_context().new_page()
            response = stranger.goto(f"http://127.0.0.1:{server.get_port()}/")
            assert response.status == 403
            page.context.close()
            browser.close()
    finally:
        inspector.close()
        server.stop()


def test_a_cloud_over_the_inspector_budget_is_offered_downsampled(served, monkeypatch):
    import app.loading
    from skelcore import memory

    server, inspector = served
    monkeypatch.setattr(app.loading, "_budget", lambda: 1000 * memory.PIPELINE_BYTES_PER_POINT)
    points = make_shape("torus", 5000).points
    content = "\n".join(" ".join(map(str, p)) for p in points).encode()
    client = RawClient(server.get_port(), camera=True)
    transfer = client.start(inspector.ui.files.upload._impl.uuid, len(content), 1, name="dense.xyz")
    client.part(inspector.ui.files.upload._impl.uuid, transfer, 0, content)
    client.ws.ping().wait(60)
    settle(lambda: inspector.offer is not None, "the offer of a voxel size")
    assert inspector.wait_idle(120)
    assert inspector.ui.files.downsample.visible and "voxel" in inspector.ui.files.downsample.label
    assert any("dense.xyz" in line and "Load downsampled" in line for line in inspector.session.log)
    assert inspector.session.cloud.name != "dense.xyz"  # the session stayed as it was
    voxel, read = inspector.offer
    inspector.worker.submit(lambda: inspector.loader.load(lambda: read(voxel)))
    assert inspector.wait_idle(120)
    assert inspector.session.cloud.name == "dense.xyz" and len(inspector.session.cloud.points) <= 1000
    assert not inspector.ui.files.downsample.visible and inspector.offer is None
    client.close()
