"""The float64 answers every run is measured against, at the final time of that run.

A GPU or twin run of n frames of dt ends at n * float32(dt), not exactly at T (dt enters
the engine as float32), so a reference is a state (p, v) at a known time and is carried
to each run's end as p + v * (t - t_ref): the gap is below 1e-7 s, the neglected term
a * gap² / 2 below 1e-13 m.

  uniform flow: the closed form of dv/dt = f - lambda v with f, lambda constant;
  other cases:  the float64 twin's RK4 on the same field (the same interpolated grid, the
                same float32-rounded constants) with REFINEMENT-times smaller steps than
                the finest dt measured.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cavesim.core.scene.model import Integrator
from cavesim.core.twin import TwinSystem
from cavesim.core.twin.integrators import INTEGRATORS
from cavesim.tools.numerics.cases import Case

REFINEMENT = 16  # reference step = finest dt / REFINEMENT


@dataclass(frozen=True)
class Reference:
    time: float  # s
    pos: np.ndarray  # (N, 3) float64
    vel: np.ndarray  # (N, 3) float64
    step: float | None  # s, of the RK4 run; None for the closed form

    def position_at(self, t: float) -> np.ndarray:
        return self.pos + self.vel * (t - self.time)


def _twin_forces(case: Case):
    twin = TwinSystem(case.scene(Integrator.RK4), np.float64)
    rotor = twin.rotor_inputs.read(case.frame) if twin.rotor_inputs is not None else None
    return twin.forces_for(case.particles["class_id"], rotor)


def closed_form(case: Case, t: float) -> Reference:
    """Exact state at t of linear drag toward a uniform flow, with gravity:
      v(t) = v_inf + (v0 - v_inf) e^(-lambda t)
      x(t) = x0 + v_inf t + (v0 - v_inf) (1 - e^(-lambda t)) / lambda
    where v_inf = f / lambda (= u + g tau without damping)."""
    p0 = case.particles["pos"].astype(np.float64)
    v0 = case.particles["vel"].astype(np.float64)
    f, lam = _twin_forces(case).linear_parts(p0, v0)  # Stokes: lambda does not depend on v0
    v_inf = f / lam
    decay = np.exp(-lam * t)
    grown = -np.expm1(-lam * t) / lam
    return Reference(t, p0 + v_inf * t + (v0 - v_inf) * grown,
                     v_inf + (v0 - v_inf) * decay, None)


def fine_rk4(case: Case, t: float, step: float) -> Reference:
    """The float64 twin's RK4 from the case's particles to t in round(t / step) equal steps."""
    steps = max(1, round(t / step))
    h = t / steps
    p = case.particles["pos"].astype(np.float64)
    v = case.particles["vel"].astype(np.float64)
    forces = _twin_forces(case)
    rk4 = INTEGRATORS[Integrator.RK4]
    for _ in range(steps):
        p, v = rk4(p, v, h, forces)
    return Reference(t, p, v, h)


def concatenate(parts: list[Reference]) -> Reference:
    """One reference from references of consecutive particle chunks."""
    first = parts[0]
    return Reference(first.time, np.concatenate([r.pos for r in parts]),
                     np.concatenate([r.vel for r in parts]), first.step)

