"""Rendering test helpers: a tiny CAVE, particle clouds placed on purpose, seams measured in
pictures, golden images.

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
from cavesim.gpu.render.unfold import _shared_edge

GOLDEN = Path(__file__).parents[1] / "golden"
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


def angled_cave(side_px: int = 96):
    """Three 3 m x 3 m walls in a bay whose wings meet the front at 120 degrees (not 90),
    and a floor under the front; square walls of `side_px` pixels."""
    wing = 3.0 * np.array([np.cos(np.radians(60)), -np.sin(np.radians(60)), 0.0])
    front_left, front_right = np.array([-1.5, 1.5, 0.0]), np.array([1.5, 1.5, 0.0])
    up = np.array([0.0, 0.0, 3.0])
    corners = {"left": (front_left + wing * [-1, 1, 1], front_left),
               "front": (front_left, front_right),
               "right": (front_right, front_right + wing)}
    walls = [{"name": name, "lower_left": list(a), "lower_right": list(b),
              "upper_left": list(a + up), "resolution": [side_px, side_px]}
             for name, (a, b) in corners.items()]
    walls.append({"name": "floor", "lower_left": [-1.5, -1.5, 0.0],
                  "lower_right": [1.5, -1.5, 0.0], "upper_left": [-1.5, 1.5, 0.0],
                  "resolution": [side_px, side_px]})
    return parse_cave({"name": "angled", "wall": walls})


def particles_at(points, class_id: int = 0) -> np.ndarray:
    records = np.zeros(len(points), dtype=PARTICLE_DTYPE)
    records["pos"] = points
    records["lifetime"] = 1e6
    records["class_id"] = class_id
    return records


def shared_edges(cave):
    """(wall, wall, edge) for every pair of walls that share an edge (room metres)."""
    return [(a, b, edge) for i, a in enumerate(cave.walls) for b in cave.walls[i + 1:]
            if (edge := _shared_edge(a, b)) is not None]


def edge_lines(wall, image: np.ndarray, edge, count: int) -> tuple[np.ndarray, np.ndarray]:
    """`image`'s colours (float) along `edge`, a segment of the wall's border, at `count`
    evenly spaced points: on the outermost line of pixels and on the one just inside it."""
    height_px, width_px = image.shape[:2]
    t = (np.arange(count) + 0.5) / count
    points = edge[0] + np.outer(t, edge[1] - edge[0]) - wall.lower_left
    column = np.clip((points @ wall.right / wall.width * width_px).astype(int), 0, width_px - 1)
    row = np.clip(((1 - points @ wall.up / wall.height) * height_px).astype(int), 0,
                  height_px - 1)
    inward = np.sign(np.array([width_px / 2, height_px / 2]) - [column[0], row[0]]).astype(int)
    inward[0 if len(np.unique(column)) > 1 else 1] = 0  # step across the edge, not along it
    inner = image[row + inward[1], column + inward[0]]
    return image[row, column].astype(float), inner.astype(float)


def edge_samples(edge, *pictured) -> int:
    """How many points along `edge` the coarsest of the (wall, image) pairs resolves."""
    length = np.linalg.norm(edge[1] - edge[0])
    return int(min(length / wall.height * image.shape[0] for wall, image in pictured))


def seam_jumps(cave, images: dict[str, np.ndarray]) -> dict[tuple[str, str], float]:
    """For each pair of walls that share an edge: the mean colour step (RGB distance) across
    the edge, from the outer pixel line of one wall to that of the other, divided by the
    mean step between the two outermost pixel lines inside either wall.

    The two outer lines sit one pixel apart on the screen, straddling the edge, so a picture
    that does not depend on which wall draws it has a ratio near 1; a wall that shades or
    thins the same dust its own way shows a jump several times its inner steps.
    """
    jumps = {}
    for a, b, edge in shared_edges(cave):
        count = edge_samples(edge, (a, images[a.name]), (b, images[b.name]))
        outer_a, inner_a = edge_lines(a, images[a.name], edge, count)
        outer_b, inner_b = edge_lines(b, images[b.name], edge, count)
        across = np.linalg.norm(outer_a - outer_b, axis=1).mean()
        inside = (np.linalg.norm(outer_a - inner_a, axis=1).mean()
                  + np.linalg.norm(outer_b - inner_b, axis=1).mean()) / 2
        jumps[a.name, b.name] = float(across / max(inside, 1e-9))
    return jumps


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
