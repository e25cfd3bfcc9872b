"""GLSL's exact built-ins as the GLSL specification defines them, for the portable twin.

max, min and clamp select one of their arguments (no rounding), but numpy's choice between
-0 and +0 or with a NaN is not GLSL's "y if x < y, otherwise x"; `nodes` is texelFetch of a
grid's nodes at integer offsets from each cell's first node.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np


def glsl_max(x, y):
    return np.where(x < y, y, x)


def glsl_min(x, y):
    return np.where(y < x, y, x)


def glsl_clamp(x, low, high):
    return glsl_min(glsl_max(x, low), high)


def first_node(f: np.ndarray, resolution: np.ndarray) -> np.ndarray:
    """min(ivec(floor(f)), res - 2): each point's cell by its first node, (N, d) int.

    A NaN coordinate (a particle the pass drops anyway) reads node 0 instead of failing.
    """
    cell = np.floor(f)
    cell[np.isnan(cell)] = 0
    return np.minimum(cell.astype(np.int64), resolution - 2)


def nodes(grid: np.ndarray, first: np.ndarray, offsets: Iterable[tuple[int, ...]]
          ) -> list[np.ndarray]:
    """grid[first + offset] per point and offset, as texelFetch reads them: `first` (N, d)
    holds (x, y[, z]) indices, and the first d axes of `grid` are (z,) y, x."""
    d = first.shape[1]
    strides = np.cumprod((1, *grid.shape[:d][:0:-1]))  # of x, y[, z] in the flat grid
    flat = grid.reshape(-1, *grid.shape[d:])
    base = first @ strides
    return [flat[base + int(np.dot(offset, strides))] for offset in offsets]
