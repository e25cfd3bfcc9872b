"""Turbulent dispersion in portable arithmetic: `turbulence_seen` of
shaders/include/dispersion.glsl, operation by operation in float32 (the model:
cavesim/core/twin/dispersion.py). Its draws xi are cavesim.core.twin.dispersion.draws in float32:
exact but for the last product by sqrt(3), which numpy rounds as f_mul does.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.fields.snapshot_time import START
from cavesim.core.portable.arithmetic import f_add, f_div, f_length, f_mul, f_sqrt, f_sub
from cavesim.core.portable.builtins import glsl_max
from cavesim.core.portable.constants import (
    HALF_SHEAR_STEP,
    KARMAN,
    SHEAR_STEP,
    TURBULENCE_FLOOR,
)

ZERO, HALF, ONE, TWO = np.float32(0.0), np.float32(0.5), np.float32(1.0), np.float32(2.0)
INVERSE_SHEAR_STEP = np.float32(10.0)


def mixing_length_at(z: np.ndarray, longest: np.float32) -> np.ndarray:
    grown = f_mul(KARMAN, glsl_max(z, ZERO))
    return f_div(grown, f_add(ONE, f_div(grown, longest)))


def particle_diffusivity(lower, upper, z, rate, longest) -> np.ndarray:
    shear = f_mul(f_length(f_sub(upper, lower)), INVERSE_SHEAR_STEP)
    speed = f_length(f_mul(HALF, f_add(lower, upper)))
    length = mixing_length_at(z, longest)
    sigma = glsl_max(f_mul(length, shear), f_mul(TURBULENCE_FLOOR, speed))
    relaxed = f_mul(rate, length)
    denominator = f_add(relaxed, sigma)
    positive = denominator > ZERO
    share = f_div(f_mul(f_mul(length, sigma), relaxed), np.where(positive, denominator, ONE))
    return np.where(positive, share, ZERO)


def turbulence(forces, p: np.ndarray, v: np.ndarray, ground: np.ndarray, longest: float,
               xi: np.ndarray, h: np.float32) -> np.ndarray:
    """What particles at p moving at v see besides u(p) over a step h (N, 3)."""
    lift = np.array([0.0, 0.0, SHEAR_STEP], dtype=np.float32)
    below, here, above = (forces.flow(f_sub(p, lift), START), forces.flow(p, START),
                           forces.flow(f_add(p, lift), START))
    rate = forces.drag_rate(f_sub(here, v))[:, 0]
    height = f_sub(p[:, 2], ground)
    longest = np.float32(longest)
    low = particle_diffusivity(below, here, f_sub(height, HALF_SHEAR_STEP), rate, longest)
    high = particle_diffusivity(here, above, f_add(height, HALF_SHEAR_STEP), rate, longest)
    if not h > 0:
        return np.zeros_like(p)
    diffusivity = f_mul(HALF, f_add(low, high))
    gradient = f_mul(f_sub(high, low), INVERSE_SHEAR_STEP)
    seen = f_mul(f_sqrt(f_div(f_mul(TWO, diffusivity), h))[:, None], xi)
    seen[:, 2] = f_add(seen[:, 2], gradient)
    return seen
