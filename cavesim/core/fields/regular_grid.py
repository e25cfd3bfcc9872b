"""Reading and checking grids at the file edge, and the cell lookup of trilinear sampling.

Shared by the flow field (grid.py, npz_field.py), the height field (heights.py) and the
scene loader, which reads an .npz field's box.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from cavesim.core.errors import FieldError
from cavesim.core.fields.npz_archive import read_npz


def float_grid(path: Path, name: str, array: np.ndarray, layout: str, max_nodes: int,
                components: int = 0) -> np.ndarray:
    """`array` as C-contiguous float32 after checking dtype, shape, size and finiteness."""
    where = f"{path}: array {name!r}"
    if array.dtype.kind != "f":
        raise FieldError(f"{where} has dtype {array.dtype}, expected float16, float32 or float64")
    nodes = array.shape[:-1] if components else array.shape
    if array.ndim != layout.count(",") + 1 or (components and array.shape[-1] != components):
        raise FieldError(f"{where} has shape {array.shape}, expected {layout}")
    if not all(2 <= n <= max_nodes for n in nodes):
        raise FieldError(f"{where} has shape {array.shape}, expected {layout} with 2 to "
                         f"{max_nodes} nodes per axis")
    with np.errstate(over="ignore"):
        grid = np.ascontiguousarray(array, dtype=np.float32)
    bad = ~np.isfinite(grid)
    if bad.any():
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        raise FieldError(f"{where} has {int(bad.sum())} non-finite value(s) in float32 (NaN, inf "
                         f"or beyond the float32 range), the first at index {first}")
    return grid


def corner_of(path: Path, name: str, array: np.ndarray, n: int) -> tuple[float, ...]:
    if array.shape != (n,) or array.dtype.kind not in "iuf" or not np.isfinite(array).all():
        raise FieldError(f"{path}: array {name!r} has shape {array.shape}, dtype {array.dtype} "
                         f"and values {array.ravel()[:8].tolist()!r}, expected {n} finite numbers")
    return tuple(float(v) for v in array)


def npz_corners(path: Path, n: int) -> dict[str, tuple[float, ...]]:
    """The box corners an .npz grid holds: those of its arrays "box_min" and "box_max" it
    has (n finite numbers each), by name."""
    arrays = read_npz(path, {}, {"box_min": n, "box_max": n})
    return {name: corner_of(path, name, array, n) for name, array in arrays.items()}


def check_box(box_min, box_max, n: int, what: str) -> tuple[tuple[float, ...], ...]:
    """The box corners as float tuples; FieldError unless n finite numbers, box_max > box_min."""
    try:
        lo, hi = tuple(float(v) for v in box_min), tuple(float(v) for v in box_max)
    except (TypeError, ValueError) as e:
        raise FieldError(f"{what} box corners must be numbers, got box_min={box_min!r}, "
                         f"box_max={box_max!r}") from e
    if (len(lo), len(hi)) != (n, n) or not all(map(math.isfinite, lo + hi)) \
            or not all(a < b for a, b in zip(lo, hi, strict=True)):
        raise FieldError(f"{what} box corners must be {n} finite numbers each with box_max > "
                         f"box_min on every axis, got box_min={lo}, box_max={hi}")
    return lo, hi


def cells(p: np.ndarray, lo: np.ndarray, hi: np.ndarray, res, dtype):
    """Cell index i0 (int), fraction t and unclamped index f per axis (see sample_field)."""
    last = np.asarray(res, dtype=dtype) - 1
    f = (p - lo) / (hi - lo) * last
    f = np.where(np.isnan(f), 0, f)  # callers turn NaN points into NaN results
    clamped = np.clip(f, 0, last)
    i0 = np.minimum(np.floor(clamped), last - 1)
    return i0.astype(np.intp), clamped - i0, f


def mix(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    return a * (1 - t) + b * t  # GLSL mix(), in this order


def index_scale(box_min, box_max, resolution) -> np.ndarray:
    """(resolution - 1) / (box_max - box_min) per axis, as float32: world to grid index.

    The bits the GPU's *_index_scale uniforms hold, and the portable twin multiplies by.
    """
    size = np.asarray(box_max, dtype=np.float64) - np.asarray(box_min, dtype=np.float64)
    return ((np.asarray(resolution, dtype=np.float64) - 1.0) / size).astype(np.float32)
