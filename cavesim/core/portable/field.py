"""The gridded flow in portable arithmetic: `flow_at` of shaders/include/field.glsl with
manual sampling, operation by operation in float32 (float64 reference:
cavesim/core/fields.py sample_field).
"""

from __future__ import annotations

import numpy as np

from cavesim.core.fields import FieldGrid
from cavesim.core.portable.arithmetic import f_mix, f_mul, f_sub
from cavesim.core.portable.builtins import first_node, glsl_clamp, nodes
from cavesim.core.scene.model import OutOfDomain

CORNERS = ((0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0),
           (0, 0, 1), (1, 0, 1), (0, 1, 1), (1, 1, 1))  # (x, y, z) offsets: c000, c100, ...


def flow_at(grid: FieldGrid, p: np.ndarray, out_of_domain: OutOfDomain) -> np.ndarray:
    """Trilinear flow (N, 3) at points (N, 3); ZERO: still air outside the closed box."""
    res = np.asarray(grid.resolution)
    last = (res - 1).astype(np.float32)
    f = f_mul(f_sub(p, np.asarray(grid.box_min, np.float32)), grid.index_scale)
    outside = ((f < 0) | (f > last)).any(axis=1)
    f = glsl_clamp(f, np.float32(0.0), last)
    i0 = first_node(f, res)
    t = f_sub(f, i0.astype(np.float32))
    tx, ty, tz = t[:, 0:1], t[:, 1:2], t[:, 2:3]
    c000, c100, c010, c110, c001, c101, c011, c111 = nodes(grid.velocity, i0, CORNERS)
    c00 = f_mix(c000, c100, tx)
    c10 = f_mix(c010, c110, tx)
    c01 = f_mix(c001, c101, tx)
    c11 = f_mix(c011, c111, tx)
    out = f_mix(f_mix(c00, c10, ty), f_mix(c01, c11, ty), tz)
    if OutOfDomain(out_of_domain) is OutOfDomain.ZERO:
        out[outside] = 0
    return out
