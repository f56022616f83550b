"""What the Files tab sends: a PNG of the view, an animation of the run (GIF and MP4), and a zip bundle of
the shown iteration's results. Pictures come from a browser's renderer (the caller renders); here they
are composed: background, burned-in labels, frames into files."""
from __future__ import annotations

import io
import tempfile
import zipfile
from pathlib import Path

import imageio.v3 as iio
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from skelcore import display, report

from .colours import COLOUR_RANGES, TARGETS, colour_values
from .messages import without_paths
from .words import METHOD_LABELS

BACKGROUND = (255, 255, 255)  # the viewer's background, under the render's transparent pixels
ANIMATION_FPS = 2  # frames (iterations) per second: slow enough to follow one contraction step
# Pictures are taken from afar with a narrow lens, whatever the browser's (viser's is 75 degrees: near points
# loom), along the view's direction: the cloud's projected bounding box spans this share of the binding side,
# which leaves room above it for three burned-in lines (LABEL_SIZE each). Its bounding sphere spanning 85% of the
# shorter side, as before, left an elongated object a third of the picture.
PICTURE_FOV = np.radians(30.0)
PICTURE_FILL = 0.75
WARM_UP = 8  # pixels a side of the render before each picture's (see delivery.Delivery.picture)
PLOTLY_JS = "plotly.min.js"  # the bundle's copy, which its pages load
LABEL_SIZE = 1 / 26  # burned-in text height, of the image's shorter side: 23 px at 800x600, 38 px at 1600x1000


def framed_camera(points: np.ndarray, camera, width: int, height: int, states=()) -> dict:
    """get_render's camera arguments framing the original cloud `points` along a client camera's viewing direction,
    in the scene's coordinates (from the cloud's display_origin, as app.scene draws it), and the contracted points
    of `states` (IterationStates) too: a step can carry some beyond the original's box (a thin ear's tip, and its
    skeleton's end node, reached into the burned-in lines)."""
    import viser.transforms as tf

    direction = camera.look_at - camera.position
    # each state's points as framing samples them: a run's many states cost no more
    drawn = [points, *(display.framing_sample(state.points) for state in states)]
    framing = display.framing_camera(np.vstack(drawn) - display.display_origin(points), direction, PICTURE_FOV,
                                     width / height, PICTURE_FILL, up=camera.up_direction)
    return {"wxyz": tf.SO3.from_matrix(framing.rotation).wxyz, "position": framing.position, "fov": PICTURE_FOV}


def point_scale(camera, height: int) -> float:
    """How many times their size points are drawn in a picture `height` pixels high (taken through PICTURE_FOV) so
    that they look beside the skeleton's edges as they do in the browser's view: viser's get_render draws points at
    the size the live view's lens and canvas height give them (their size uniform is the live camera's), while
    edges are in world units, so points came out half their size and less in pictures."""
    if not camera.image_height:
        return 1.0
    return float(np.tan(camera.fov / 2) / np.tan(PICTURE_FOV / 2) * height / camera.image_height)


def caption(cloud_name: str, state, verdict: str | None = None, notes: list[str] = ()) -> list[str]:
    """The lines burned into a picture: file, method, iteration (and the verdict, and `notes` on the skeletons
    drawn: why one is provisional, which run the pinned one is)."""
    lines = [f"{Path(cloud_name).name} · {METHOD_LABELS[state.params.method]} · iteration {state.iteration}"]
    return lines + ([f"verdict: {verdict}"] if verdict else []) + list(notes)


def compose(rgba: np.ndarray, labels: list[str] = (), transparent: bool = False, colour_by: str | None = None
            ) -> np.ndarray:
    """An (h,w,4) uint8 render -> (h,w,3) on the background (or (h,w,4) kept transparent), with `labels`
    burned in, one line each, at the top left, and with them the colour bar of a quantity the points are coloured
    by (`colour_by`, a key of app.colours.COLOUR_RANGES), at the bottom left."""
    image = np.asarray(rgba)
    if image.shape[-1] == 3:
        image = np.concatenate([image, np.full(image.shape[:2] + (1,), 255, np.uint8)], axis=-1)
    if not transparent:
        alpha = image[..., 3:4].astype(np.float32) / 255.0
        flat = image[..., :3] * alpha + np.asarray(BACKGROUND, np.float32) * (1.0 - alpha)
        image = np.clip(flat, 0, 255).astype(np.uint8)
    if labels:
        picture = Image.fromarray(image)
        draw = ImageDraw.Draw(picture)
        size = round(LABEL_SIZE * min(picture.size))
        font = ImageFont.load_default(size=size)
        y = size // 2
        for line in labels:
            box = draw.textbbox((size // 2, y), line, font=font)
            fill = (255, 255, 255, 200) if transparent else (255, 255, 255)
            draw.rectangle((box[0] - 4, box[1] - 3, box[2] + 4, box[3] + 3), fill=fill)
            draw.text((size // 2, y), line, fill=(20, 20, 20, 255) if transparent else (20, 20, 20), font=font)
            y += int(size * 1.35)
        if colour_by in COLOUR_RANGES:
            _colour_bar(draw, picture.size, size, font, colour_by, transparent)
        image = np.asarray(picture)
    return image


def _colour_bar(draw: ImageDraw.ImageDraw, picture_size: tuple[int, int], size: int, font, quantity: str,
                transparent: bool) -> None:
    """The view's colour bar of `quantity` at the bottom left: its name and target above it, its range's ends and
    the target under it (a picture without it showed colours no one could read)."""
    low, high = COLOUR_RANGES[quantity]
    target = TARGETS[quantity]
    width, height = picture_size
    left, bar_width, bar_height = size // 2, min(12 * size, width // 2), max(size // 2, 4)
    top = height - size // 2 - int(1.35 * size) - bar_height
    fill = (255, 255, 255, 200) if transparent else (255, 255, 255)
    ink = (20, 20, 20, 255) if transparent else (20, 20, 20)
    title = f"{quantity} (target {target:g}, dark)"
    box = draw.textbbox((left, top - int(1.35 * size)), title, font=font)
    draw.rectangle((box[0] - 4, box[1] - 3, max(box[2], left + bar_width) + 4, height - size // 4), fill=fill)
    draw.text((left, top - int(1.35 * size)), title, fill=ink, font=font)
    colours = colour_values(np.linspace(low, high, bar_width), quantity)
    for x, colour in enumerate(colours):
        draw.line((left + x, top, left + x, top + bar_height), fill=tuple(int(c) for c in colour))
    ticks = ((low, f"{low:.2f}", "la"), (target, f"{target:g}", "ma"), (high, f"{high:.2f}", "ra"))
    for value, text, anchor in ticks:
        x = left + round((value - low) / (high - low) * (bar_width - 1))
        draw.text((x, top + bar_height + 2), text, fill=ink, font=font, anchor=anchor)


def png_bytes(rgba: np.ndarray, labels: list[str] = (), transparent: bool = False,
              colour_by: str | None = None) -> bytes:
    return iio.imwrite("<bytes>", compose(rgba, labels, transparent, colour_by), extension=".png")


def animation_files(frames: list[np.ndarray], fps: float = ANIMATION_FPS) -> dict[str, bytes]:
    """A GIF and an MP4 (H.264 through imageio-ffmpeg) of (h,w,3) frames, one per iteration."""
    frames = [np.asarray(frame)[..., :3] for frame in frames]
    gif = iio.imwrite("<bytes>", np.stack(frames), extension=".gif", duration=1000 / fps, loop=0)
    with tempfile.TemporaryDirectory(prefix="skel-inspect-") as tmp:
        path = Path(tmp) / "run.mp4"
        # imageio-ffmpeg's bundled ffmpeg; macro_block_size=1 keeps the exact frame size
        iio.imwrite(path, np.stack(frames), extension=".mp4", fps=fps, codec="libx264", macro_block_size=1, quality=7,
                    ffmpeg_log_level="error")  # not its warning that a few frames give no rate estimate
        mp4 = path.read_bytes()
    return {"gif": gif, "mp4": mp4}


def bundle(session, index: int, screenshot_png: bytes) -> bytes:
    """A zip with the screenshot, the pipeline's result files for history[index], the session's Log, and the
    histograms and the convergence plot as HTML pages that load the copy of plotly.js beside them: they open
    offline (from its CDN they were blank pages there), and the zip holds plotly.js once (1.4 MB compressed)."""
    from plotly.offline import get_plotlyjs

    metrics = session.metrics_upto(index)
    iteration = session.history[index].iteration
    with tempfile.TemporaryDirectory(prefix="skel-inspect-") as tmp:
        out = Path(tmp)
        session.write_results(index, out)
        (out / "screenshot.png").write_bytes(screenshot_png)
        (out / PLOTLY_JS).write_text(get_plotlyjs(), encoding="utf-8")
        # the session's Log in full (its tab shows the newest lines), oldest first, no server path in it
        (out / "log.txt").write_text("".join(f"{without_paths(line)}\n" for line in session.log), encoding="utf-8")
        (out / "histograms.html").write_text(report.histograms_html(metrics[-1], iteration=iteration, plotly=PLOTLY_JS,
                                                                    of_points=len(session.run.cloud.points)),
                                             encoding="utf-8")
        (out / "convergence.html").write_text(report.figures_html("Convergence", [report.convergence_figure(metrics)],
                                                                  plotly=PLOTLY_JS), encoding="utf-8")
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
            for path in sorted(out.iterdir()):
                archive.write(path, path.name)
    return buffer.getvalue()
