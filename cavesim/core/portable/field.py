"""The gridded flow in portable arithmetic: `flow_at` of shaders/include/field.glsl with
manual sampling, trilinear or cubic, operation by operation in float32 (float64 reference:
cavesim/core/fields/grid.py sample_field).
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from cavesim.core.fields.grid import FieldGrid
from cavesim.core.fields.interpolation import is_cubic, weights
from cavesim.core.portable.arithmetic import f_add, f_mix, f_mul, f_sub
from cavesim.core.portable.builtins import first_node, glsl_clamp, nodes
from cavesim.core.scene.model import OutOfDomain

CORNERS = ((0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0),
           (0, 0, 1), (1, 0, 1), (0, 1, 1), (1, 1, 1))  # (x, y, z) offsets: c000, c100, ...


def field_coordinates(grid: FieldGrid, p: np.ndarray) -> np.ndarray:
    """field.glsl's `field_coordinates`: the grid coordinates (N, 3) of points (N, 3)."""
    return f_mul(f_sub(p, np.asarray(grid.box_min, np.float32)), grid.index_scale)


def outside_field(grid: FieldGrid, p: np.ndarray) -> np.ndarray:
    """field.glsl's `outside_field` at points (N, 3): (N,) bool, NaN not outside."""
    f = field_coordinates(grid, p)
    last = (np.asarray(grid.resolution) - 1).astype(np.float32)
    return ((f < 0) | (f > last)).any(axis=1)


def flow_at(grid: FieldGrid, p: np.ndarray, out_of_domain: OutOfDomain) -> np.ndarray:
    """The grid's flow (N, 3) at points (N, 3); ZERO: still air outside the closed box."""
    res = np.asarray(grid.resolution)
    last = (res - 1).astype(np.float32)
    f = field_coordinates(grid, p)
    outside = ((f < 0) | (f > last)).any(axis=1)
    f = glsl_clamp(f, np.float32(0.0), last)
    i0 = first_node(f, res)
    t = f_sub(f, i0.astype(np.float32))
    out = (_cubic if is_cubic(grid.interpolation) else _trilinear)(grid, i0, t)
    if OutOfDomain(out_of_domain) is OutOfDomain.ZERO:
        out[outside] = 0
    return out


def _trilinear(grid: FieldGrid, i0: np.ndarray, t: np.ndarray) -> np.ndarray:
    tx, ty, tz = t[:, 0:1], t[:, 1:2], t[:, 2:3]
    c000, c100, c010, c110, c001, c101, c011, c111 = nodes(grid.velocity, i0, CORNERS)
    c00 = f_mix(c000, c100, tx)
    c10 = f_mix(c010, c110, tx)
    c01 = f_mix(c001, c101, tx)
    c11 = f_mix(c011, c111, tx)
    return f_mix(f_mix(c00, c10, ty), f_mix(c01, c11, ty), tz)


def _cubic(grid: FieldGrid, i0: np.ndarray, t: np.ndarray) -> np.ndarray:
    """cubic_flow: the 4 x 4 x 4 texels from i0 summed along x, then y, then z."""
    blocks = sliding_window_view(grid.texels, (4, 4, 4), axis=(0, 1, 2))  # a view, no copy
    texels = blocks[i0[:, 2], i0[:, 1], i0[:, 0]]  # (N, 3, z, y, x)
    wx, wy, wz = (weights(t[:, a], grid.interpolation, f_add, f_sub, f_mul) for a in range(3))
    rows = _tap_sum([w[:, None, None, None] for w in wx], texels)  # (N, 3, z, y)
    planes = _tap_sum([w[:, None, None] for w in wy], rows)  # (N, 3, z)
    return _tap_sum([w[:, None] for w in wz], planes)  # (N, 3)


def _tap_sum(w: list[np.ndarray], values: np.ndarray) -> np.ndarray:
    """Sum from 0 of w[k] · values[..., k] over k = 0..3, in this order, as the shader's loops."""
    total = np.float32(0.0)
    for k in range(4):
        total = f_add(total, f_mul(w[k], values[..., k]))
    return total
