"""Rendering test helpers: a tiny CAVE, particle clouds placed on purpose, golden images.

Golden images live in tests/golden/. To update them after an intended change of the
picture, run the tests with CAVESIM_UPDATE_GOLDEN=1 and look at the new PNGs before
committing them.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from PIL import Image

from cavesim.core.cave.geometry import parse_cave
from cavesim.core.records import PARTICLE_DTYPE

GOLDEN = Path(__file__).parent / "golden"
GOLDEN_RENDERER = "llvmpipe"  # the goldens were drawn by Mesa's llvmpipe
# Another driver draws the same scene with its own rasterization (sub-pixel precision,
# coverage of billboard edges) and its own exp/sqrt in the dust shading, so edges move by
# a pixel and soft dust shifts by a few levels: the picture must match, not the bits.
OTHER_RENDERER_TOLERANCE = {"pixel_tolerance": 32, "max_differing": 0.03, "mean_levels": 4.0}


def small_cave(resolution=(96, 96), left_resolution=None):
    """The FLEX CAVE's front, left and floor walls at a test resolution."""
    walls = [
        {"name": "front", "lower_left": [-1.5, 1.5, 0.0], "lower_right": [1.5, 1.5, 0.0],
         "upper_left": [-1.5, 1.5, 3.0], "resolution": list(resolution)},
        {"name": "left", "lower_left": [-1.5, -1.5, 0.0], "lower_right": [-1.5, 1.5, 0.0],
         "upper_left": [-1.5, -1.5, 3.0], "resolution": list(left_resolution or resolution)},
        {"name": "floor", "lower_left": [-1.5, -1.5, 0.0], "lower_right": [1.5, -1.5, 0.0],
         "upper_left": [-1.5, 1.5, 0.0], "resolution": list(resolution)},
    ]
    return parse_cave({"name": "test", "wall": walls})


def particles_at(points, class_id: int = 0) -> np.ndarray:
    records = np.zeros(len(points), dtype=PARTICLE_DTYPE)
    records["pos"] = points
    records["lifetime"] = 1e6
    records["class_id"] = class_id
    return records


def assert_matches_golden(image: np.ndarray, name: str, renderer: str,
                          pixel_tolerance: int = 8, max_differing: float = 0.002,
                          mean_levels: float = 255.0) -> None:
    """Compare with tests/golden/<name>.png: at most `max_differing` of the pixels may
    differ by more than `pixel_tolerance` in any channel, and the mean difference is at
    most `mean_levels` (software GL is stable, but a Mesa update may move an edge by a
    pixel). `renderer` is GL_RENDERER: other drivers than the goldens' get
    OTHER_RENDERER_TOLERANCE."""
    if GOLDEN_RENDERER not in renderer:
        pixel_tolerance, max_differing, mean_levels = OTHER_RENDERER_TOLERANCE.values()
    path = GOLDEN / f"{name}.png"
    if os.environ.get("CAVESIM_UPDATE_GOLDEN") == "1":
        Image.fromarray(image).save(path)
    golden = np.asarray(Image.open(path).convert("RGB"))
    assert golden.shape == image.shape, f"{name}: shape {image.shape}, golden {golden.shape}"
    differing = (np.abs(golden.astype(int) - image.astype(int)).max(axis=2) > pixel_tolerance)
    assert differing.mean() <= max_differing, (
        f"{name}: {differing.sum()} pixels differ by more than {pixel_tolerance}")
    mean = np.abs(golden.astype(float) - image).mean()
    assert mean <= mean_levels, f"{name}: the mean difference is {mean:.1f} levels"
