"""A run as one animation: the composite PNGs of `compose_run` strung into a GIF or MP4."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
from PIL import Image

from cavesim.core.output import writing

MAX_WIDTH_PX = 1280  # wider frames are scaled down: a full-resolution CAVE GIF is huge
FORMATS = (".gif", ".mp4")


def _frame(path: Path) -> Image.Image:
    with Image.open(path) as im:
        frame = im.convert("RGB")
    if frame.width > MAX_WIDTH_PX:
        height = max(1, round(frame.height * MAX_WIDTH_PX / frame.width))
        frame = frame.resize((MAX_WIDTH_PX, height), Image.Resampling.LANCZOS)
    return frame


def write_animation(frames: list[Path], path: Path, fps: float = 15) -> Path:
    """Write `frames` (image files, in order) as an animation at `path`: a GIF that loops
    forever, or an MP4 when `path` ends with .mp4 (needs the imageio-ffmpeg package).
    Frames wider than `MAX_WIDTH_PX` are scaled down. Returns `path`."""
    path = Path(path)
    frames = [Path(f) for f in frames]
    if not frames:
        raise ValueError("frames is empty: an animation needs at least one frame")
    if not (isinstance(fps, int | float) and math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a finite number > 0, got {fps=!r}")
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(f"path must end with one of {', '.join(FORMATS)}, got {str(path)!r}")
    if suffix == ".mp4" and importlib.util.find_spec("imageio_ffmpeg") is None:
        raise ImportError(f"writing {str(path)!r} needs the imageio-ffmpeg package: "
                          "pip install imageio-ffmpeg, or write a .gif instead")
    path.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".gif":
        first, *rest = (_frame(f) for f in frames)
        # GIF keeps delays in centiseconds; Pillow merges identical consecutive frames
        # into one longer frame, so n_frames may be below len(frames) for a still scene.
        with writing(path):
            first.save(path, save_all=True, append_images=rest, duration=round(1000 / fps),
                       loop=0, optimize=False)
    else:
        import imageio.v2 as imageio

        with imageio.get_writer(path, format="FFMPEG", fps=fps) as writer:
            for f in frames:
                writer.append_data(np.asarray(_frame(f)))
    return path
