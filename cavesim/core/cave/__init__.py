"""The CAVE: its walls in room coordinates and the head-tracked projection onto each.

`load_cave(DEFAULT_CAVE)` reads the screens; per frame, `eye_positions` turns the tracked
head into eyes and `off_axis(wall, eye)` gives each wall's projection and view matrices.
"""

from cavesim.core.cave.geometry import Cave, Wall, load_cave, parse_cave
from cavesim.core.cave.projection import (
    eye_positions,
    frustum,
    gl_matrix,
    matrices_for_gl,
    off_axis,
    project_to_pixels,
    recut,
)

DEFAULT_CAVE = "config/cave/flex4.toml"  # relative to the repository root

__all__ = [
    "DEFAULT_CAVE",
    "Cave",
    "Wall",
    "eye_positions",
    "frustum",
    "gl_matrix",
    "load_cave",
    "matrices_for_gl",
    "off_axis",
    "parse_cave",
    "project_to_pixels",
    "recut",
]
