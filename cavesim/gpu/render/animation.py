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


def _frame(path: Path, max_width: int, even: bool = False) -> Image.Image:
    """The image at `path` as RGB, scaled down to `max_width` (and to even sides: H.264's
    4:2:0 colour takes pixels in pairs)."""
    with Image.open(path) as im:
        frame = im.convert("RGB")
    if frame.width > max_width:
        height = max(1, round(frame.height * max_width / frame.width))
        frame = frame.resize((max_width, height), Image.Resampling.LANCZOS)
    if even and (frame.width % 2 or frame.height % 2):
        frame = frame.crop((0, 0, frame.width - frame.width % 2, frame.height - frame.height % 2))
    return frame


def write_animation(frames: list[Path], path: Path, fps: float = 15,
                    max_width: int = MAX_WIDTH_PX) -> Path:
    """Write `frames` (image files, in order) as an animation at `path`: a GIF that loops
    forever, or an MP4 when `path` ends with .mp4 (needs the imageio-ffmpeg package).
    Frames wider than `max_width` are scaled down. Returns `path`."""
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
        first, *rest = (_frame(f, max_width) for f in frames)
        # GIF keeps delays in centiseconds; Pillow merges identical consecutive frames
        # into one longer frame, so n_frames may be below len(frames) for a still scene.
        with writing(path):
            first.save(path, save_all=True, append_images=rest, duration=round(1000 / fps),
                       loop=0, optimize=False)
    else:
        import imageio.v2 as imageio

        with writing(path), imageio.get_writer(path, format="FFMPEG", fps=fps,
                                               macro_block_size=2) as writer:
            for f in frames:
                writer.append_data(np.asarray(_frame(f, max_width, even=True)))
    return path
