"""Accelerations on particles (twin of `acceleration` in shaders/include/forces.glsl)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from cavesim.core.drag import drag_factor
from cavesim.core.fields.snapshot_time import END, START, FlowSampler

PER_PARTICLE = ("inv_tau", "reynolds_per_speed", "turbulence")  # ForceModel's (N, k) columns


@dataclass(frozen=True)
class ForceModel:
    """a(p, v) = (u(p) + u_t - v) lambda(|u(p) - v|) + g - k v, with each term present only
    if configured: lambda = f(Re)/tau is the drag rate (f = 1 for Stokes particles,
    Schiller-Naumann's 1 + 0.15 Re^0.687 with Re = |u - v| d/nu for the others) and u_t
    the turbulence a particle sees over the step (cavesim.core.twin.dispersion)."""

    gravity: np.ndarray | None = None  # (3,)
    damping: float | None = None  # k, 1/s
    inv_tau: np.ndarray | None = None  # (N, 1) per particle; None without drag
    flow: FlowSampler | None = None  # u(p) for points (N, 3); None without drag
    reynolds_per_speed: np.ndarray | None = None  # (N, 1) d/nu, 0 for Stokes; None: all Stokes
    turbulence: np.ndarray | None = None  # (N, 3) u_t, held over the step; None: none
    frame_rotation: np.ndarray | None = None  # (3,) Omega of a = -2 Omega x v; None: none

    def of_rows(self, rows: np.ndarray) -> ForceModel:
        """The model of the particles in `rows`: its per-particle columns taken there."""
        return dataclasses.replace(self, **{
            name: getattr(self, name)[rows] for name in PER_PARTICLE
            if getattr(self, name) is not None})

    def drag_rate(self, slip: np.ndarray) -> np.ndarray:
        """lambda (N, 1) at the slip u - v (N, 3)."""
        if self.reynolds_per_speed is None:
            return self.inv_tau
        speed = np.linalg.norm(slip, axis=1, keepdims=True)
        return self.inv_tau * drag_factor(speed * self.reynolds_per_speed)

    def acceleration(self, p: np.ndarray, v: np.ndarray, stage: int = START) -> np.ndarray:
        """a(p, v) with the flow at the step's `stage`."""
        a = np.zeros_like(v)
        if self.flow is not None:
            u = self.flow(p, stage)
            seen = u if self.turbulence is None else u + self.turbulence
            a += (seen - v) * self.drag_rate(u - v)
        if self.gravity is not None:
            a += self.gravity
        if self.damping is not None:
            a -= self.damping * v
        return self._with_coriolis(a, v)

    def _with_coriolis(self, a: np.ndarray, v: np.ndarray) -> np.ndarray:
        """a - 2 Omega x v (a as it is in a frame that does not turn)."""
        if self.frame_rotation is None:
            return a
        return a - 2.0 * np.cross(self.frame_rotation, v)

    def _forcing(self, u: np.ndarray | None, drag: np.ndarray) -> np.ndarray:
        if u is None:
            f = np.zeros((len(drag), 3), dtype=drag.dtype)
        else:
            f = (u if self.turbulence is None else u + self.turbulence) * drag
        if self.gravity is not None:
            f = f + self.gravity
        return f

    def remainder(self, p: np.ndarray, v: np.ndarray, held: np.ndarray) -> np.ndarray:
        """N(p, v) = a(p, v) + (held + k) v: what the linear part -(held + k) v, its drag rate
        `held` (N, 1) taken at the step's start, leaves of the acceleration (ETD2RK's second
        stage, the flow at the step's end). With the drag rate lambda_d at (p, v) itself,
        that is (u(p) + u_t) lambda_d + g - (lambda_d - held) v; for Stokes drag
        lambda_d = held."""
        if self.flow is None:
            return self._with_coriolis(self._forcing(None, held), v)
        u = self.flow(p, END)
        drag = self.drag_rate(u - v)
        remainder = self._forcing(u, drag)
        if self.reynolds_per_speed is not None:
            remainder = remainder - (drag - held) * v
        return self._with_coriolis(remainder, v)

    def linear_parts(self, p: np.ndarray, v: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(f, lambda, lambda_d) of dv/dt = f - lambda v with the flow and the drag rate
        lambda_d held at their values at (p, v) at the step's start (the exponential
        integrators); lambda = lambda_d + k, each (N, 1)."""
        drag = np.zeros((len(p), 1), dtype=p.dtype)
        u = None
        if self.flow is not None:
            u = self.flow(p, START)
            drag = self.drag_rate(u - v)
        lam = drag if self.damping is None else drag + self.damping
        return self._with_coriolis(self._forcing(u, drag), v), lam, drag
