"""Accelerations in portable arithmetic: `acceleration` and `linear_parts` of
shaders/include/physics.glsl, operation by operation in float32.

Per-particle scalars (1/tau, lambda) are (N, 1) columns, so they scale (N, 3) vectors as a
float scales a vec3 in GLSL.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cavesim.core.portable.arithmetic import f_add, f_mul, f_sub


@dataclass(frozen=True)
class PortableForces:
    """a(p, v) = (u(p) - v) / tau + g - k v, each term present only if the scene has it."""

    gravity: np.ndarray | None  # (3,) float32
    damping: np.float32 | None  # k, 1/s
    inv_tau: np.ndarray | None  # (N, 1) float32 per particle; None without drag
    flow: Callable[[np.ndarray], np.ndarray] | None  # u(p) for (N, 3); None without drag

    def acceleration(self, p: np.ndarray, v: np.ndarray) -> np.ndarray:
        a = np.zeros_like(v)
        if self.flow is not None:
            a = f_add(a, f_mul(f_sub(self.flow(p), v), self.inv_tau))
        if self.gravity is not None:
            a = f_add(a, self.gravity)
        if self.damping is not None:
            a = f_sub(a, f_mul(self.damping, v))
        return a

    def linear_parts(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(f, lambda) of dv/dt = f - lambda v with the flow held at p; lambda is (N, 1)."""
        f = np.zeros_like(p)
        lam = np.zeros((len(p), 1), dtype=np.float32)
        if self.flow is not None:
            f = f_add(f, f_mul(self.flow(p), self.inv_tau))
            lam = f_add(lam, self.inv_tau)
        if self.gravity is not None:
            f = f_add(f, self.gravity)
        if self.damping is not None:
            lam = f_add(lam, self.damping)
        return f, lam
