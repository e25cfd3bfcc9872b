"""Emission in portable arithmetic: `spawn` of shaders/include/spawn.glsl, operation by
operation in float32 (float64 reference: cavesim/core/twin/emission.py spawn). The random
texels come from the same integer lookup as the reference's.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.emitters import EmitterTable
from cavesim.core.portable.arithmetic import f_add, f_cos, f_mul, f_sin, f_sqrt, f_sub
from cavesim.core.portable.builtins import glsl_max
from cavesim.core.portable.constants import TWO_PI
from cavesim.core.random_texture import random_texels, unit_float
from cavesim.core.records import PARTICLE_DTYPE

ZERO, HALF, ONE, TWO = np.float32(0.0), np.float32(0.5), np.float32(1.0), np.float32(2.0)


def spawn(table: EmitterTable, e: int, serials: np.ndarray, random: np.ndarray,
          transform: np.ndarray, origin=None) -> np.ndarray:
    """New particles of emitter e with the given emission serials (PARTICLE_DTYPE).

    `origin` is the frame's emission origin of a scene whose emitters follow the
    helicopter (the shader's FOLLOWING), None in other scenes.
    """
    r0, r1 = random_texels(random, table.random_base[e], serials, transform)
    u0 = unit_float(r0).astype(np.float32)  # 24-bit fractions: exact in float32
    u1 = unit_float(r1).astype(np.float32)
    position = table.position[e]
    center = position if origin is None else f_add(np.asarray(origin, np.float32), position)
    in_box = f_sub(u0[:, :3], HALF)
    versine = f_mul(u0[:, 3], table.versine_spread[e])
    cos_theta = f_sub(ONE, versine)
    sin_theta = f_sqrt(glsl_max(ZERO, f_mul(versine, f_sub(TWO, versine))))
    phi = f_mul(TWO_PI, u1[:, 0])
    direction = f_add(f_add(f_mul(f_mul(sin_theta, f_cos(phi))[:, None], table.tangent[e]),
                            f_mul(f_mul(sin_theta, f_sin(phi))[:, None], table.bitangent[e])),
                      f_mul(cos_theta[:, None], table.axis[e]))
    spread = f_sub(f_mul(TWO, u1[:, 1]), ONE)
    speed = f_add(table.speed[e], f_mul(table.speed_spread[e], spread))
    low, high = table.lifetime[e]
    out = np.zeros(len(serials), dtype=PARTICLE_DTYPE)
    out["pos"] = f_add(center, f_mul(in_box, table.extent[e]))
    out["vel"] = f_mul(speed[:, None], direction)
    out["lifetime"] = f_add(low, f_mul(f_sub(high, low), u1[:, 2]))
    out["class_id"] = table.class_id[e]
    return out
