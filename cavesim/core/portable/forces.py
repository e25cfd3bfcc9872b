"""Accelerations in portable arithmetic: `acceleration`, `linear_parts` and `drag_rate` of
shaders/include/forces.glsl, operation by operation in float32.

Per-particle scalars (1/tau, lambda) are (N, 1) columns, so they scale (N, 3) vectors as a
float scales a vec3 in GLSL.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from cavesim.core.fields.snapshot_time import END, START, FlowSampler
from cavesim.core.portable.arithmetic import f_add, f_length, f_mul, f_pow, f_sub
from cavesim.core.portable.constants import (
    SCHILLER_NAUMANN_COEFFICIENT,
    SCHILLER_NAUMANN_EXPONENT,
)
from cavesim.core.position import move

ONE = np.float32(1.0)
# PortableForces' (N, k) columns: the float64 model's (cavesim.core.twin.forces) and the
# low part of the positions
PER_PARTICLE = ("inv_tau", "reynolds_per_speed", "turbulence", "position_low")


@dataclass
class PortableForces:
    """a(p, v) = (u(p) + u_t - v) lambda + g - k v, each term present only if the scene has
    it (cavesim.core.twin.forces.ForceModel says what each is); and the low part of the
    positions being stepped, which `move` carries (position.glsl's step_position_low)."""

    gravity: np.ndarray | None = None  # (3,) float32
    damping: np.float32 | None = None  # k, 1/s
    inv_tau: np.ndarray | None = None  # (N, 1) float32 per particle; None without drag
    flow: FlowSampler | None = None  # u(p, stage) for (N, 3); None without drag
    reynolds_per_speed: np.ndarray | None = None  # (N, 1) d/nu, 0 for Stokes; None: all Stokes
    turbulence: np.ndarray | None = None  # (N, 3) u_t, held over the step; None: none
    frame_rotation: np.ndarray | None = None  # (3,) float32 Omega of a = -2 Omega x v
    position_low: np.ndarray | None = None  # (N, 3) float32, set before a step

    def of_rows(self, rows: np.ndarray) -> PortableForces:
        """The model of the particles in `rows`: its per-particle columns, the low part of
        their positions among them, taken there."""
        return dataclasses.replace(self, **{
            name: getattr(self, name)[rows] for name in PER_PARTICLE
            if getattr(self, name) is not None})

    def move(self, p: np.ndarray, dp: np.ndarray) -> np.ndarray:
        """position.glsl's move: p + position_low + dp as a new p and position_low."""
        p, self.position_low = move(p, self.position_low, dp)
        return p

    def drag_rate(self, slip: np.ndarray) -> np.ndarray:
        """lambda (N, 1) at the slip u - v (N, 3)."""
        if self.reynolds_per_speed is None:
            return self.inv_tau
        reynolds = f_mul(f_length(slip)[:, None], self.reynolds_per_speed)
        positive = reynolds > 0  # the shader's branch: Re = 0 (a Stokes class) or NaN
        wake = f_mul(SCHILLER_NAUMANN_COEFFICIENT,
                     f_pow(np.where(positive, reynolds, ONE), SCHILLER_NAUMANN_EXPONENT))
        return np.where(positive, f_mul(self.inv_tau, f_add(ONE, wake)), self.inv_tau)

    def seen_flow(self, u: np.ndarray) -> np.ndarray:
        return u if self.turbulence is None else f_add(u, self.turbulence)

    def acceleration(self, p: np.ndarray, v: np.ndarray, stage: int = START) -> np.ndarray:
        a = np.zeros_like(v)
        if self.flow is not None:
            u = self.flow(p, stage)
            a = f_add(a, f_mul(f_sub(self.seen_flow(u), v), self.drag_rate(f_sub(u, v))))
        if self.gravity is not None:
            a = f_add(a, self.gravity)
        if self.damping is not None:
            a = f_sub(a, f_mul(self.damping, v))
        return self._with_coriolis(a, v)

    def _with_coriolis(self, a: np.ndarray, v: np.ndarray) -> np.ndarray:
        """a - 2 Omega x v, as forces.glsl's coriolis() adds it (a as it is without)."""
        if self.frame_rotation is None:
            return a
        w = self.frame_rotation
        turn = f_sub(f_mul(w[[1, 2, 0]], v[:, [2, 0, 1]]), f_mul(w[[2, 0, 1]], v[:, [1, 2, 0]]))
        return f_add(a, f_mul(np.float32(-2.0), turn))

    def _forcing(self, u: np.ndarray | None, drag: np.ndarray) -> np.ndarray:
        f = np.zeros((len(drag), 3), dtype=np.float32)
        if u is not None:
            f = f_add(f, f_mul(self.seen_flow(u), drag))
        if self.gravity is not None:
            f = f_add(f, self.gravity)
        return f

    def remainder(self, p: np.ndarray, v: np.ndarray, held: np.ndarray) -> np.ndarray:
        """`remainder_at` of forces.glsl: what the linear part with the drag rate `held`
        (N, 1) leaves of the acceleration at (p, v) (the float64 twin's `remainder`)."""
        if self.flow is None:
            return self._with_coriolis(self._forcing(None, held), v)
        u = self.flow(p, END)
        drag = self.drag_rate(f_sub(u, v))
        remainder = self._forcing(u, drag)
        if self.reynolds_per_speed is not None:
            remainder = f_sub(remainder, f_mul(f_sub(drag, held), v))
        return self._with_coriolis(remainder, v)

    def linear_parts(self, p: np.ndarray, v: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(f, lambda, lambda_d) of dv/dt = f - lambda v with the flow and the drag rate held
        at (p, v); each (N, 1) but f."""
        drag = np.zeros((len(p), 1), dtype=np.float32)
        u = None
        if self.flow is not None:
            u = self.flow(p, START)
            drag = self.drag_rate(f_sub(u, v))
        lam = drag if self.damping is None else f_add(drag, self.damping)
        return self._with_coriolis(self._forcing(u, drag), v), lam, drag
