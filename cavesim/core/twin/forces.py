"""Accelerations on particles (twin of `acceleration` in shaders/include/physics.glsl)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

FlowSampler = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class ForceModel:
    """a(p, v) = (u(p) - v) / tau + g - k v, with each term present only if configured."""

    gravity: np.ndarray | None  # (3,)
    damping: float | None  # k, 1/s
    inv_tau: np.ndarray | None  # (N, 1) per particle; None without drag
    flow: FlowSampler | None  # u(p) for points (N, 3); None without drag

    def acceleration(self, p: np.ndarray, v: np.ndarray) -> np.ndarray:
        a = np.zeros_like(v)
        if self.flow is not None:
            a += (self.flow(p) - v) * self.inv_tau
        if self.gravity is not None:
            a += self.gravity
        if self.damping is not None:
            a -= self.damping * v
        return a

    def linear_parts(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(f, lambda) of dv/dt = f - lambda v with the flow held at p (exponential integrator)."""
        f = np.zeros_like(p)
        lam = np.zeros((len(p), 1), dtype=p.dtype)
        if self.flow is not None:
            f += self.flow(p) * self.inv_tau
            lam += self.inv_tau
        if self.gravity is not None:
            f += self.gravity
        if self.damping is not None:
            lam += self.damping
        return f, lam
