"""What the Export panel sends: a PNG of the view, and a zip bundle of the shown iteration's results."""
from __future__ import annotations

import io
import tempfile
import zipfile
from pathlib import Path

import imageio.v3 as iio
import numpy as np

from skelcore import report

BACKGROUND = (255, 255, 255)  # the viewer's background, under the render's transparent pixels


def png_bytes(rgba: np.ndarray) -> bytes:
    """An (h,w,4) uint8 render (transparent background) as an opaque PNG."""
    image = np.asarray(rgba)
    if image.shape[-1] == 4:
        alpha = image[..., 3:4].astype(np.float32) / 255.0
        image = image[..., :3] * alpha + np.asarray(BACKGROUND, np.float32) * (1.0 - alpha)
    return iio.imwrite("<bytes>", np.clip(image, 0, 255).astype(np.uint8), extension=".png")


def bundle(session, index: int, screenshot_png: bytes) -> bytes:
    """A zip with the screenshot, the pipeline's result files for history[index] and the histograms as HTML."""
    with tempfile.TemporaryDirectory(prefix="skel-inspect-") as tmp:
        out = Path(tmp)
        session.write_results(index, out)
        (out / "screenshot.png").write_bytes(screenshot_png)
        (out / "histograms.html").write_text(report.histograms_html(session.metrics(index), iteration=index),
                                             encoding="utf-8")
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
            for path in sorted(out.iterdir()):
                archive.write(path, path.name)
    return buffer.getvalue()
