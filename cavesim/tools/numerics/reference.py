"""The float64 answers every run is measured against, at the final time of that run.

A GPU or twin run of n frames of dt ends at n * float32(dt), not exactly at T (dt enters
the engine as float32), so a reference is a state (p, v, a) at a known time and is carried
to each run's end by a Taylor step of the gap: p + v gap + a gap²/2 and v + a gap; the gap
is below 1e-7 s, the neglected terms, of order (da/dt) gap², below 1e-10 m/s.

  uniform flow: the closed form of dv/dt = f - lambda v with f, lambda constant;
  rotating flow: the closed form with the uniform flow turning at a steady rate;
  solid-body vortex: tracers turned by Omega t about the axis;
  other cases:  the float64 twin's RK4 on the same field (the same interpolated grid, the
                same float32-rounded constants) with REFINEMENT-times smaller steps than
                the finest dt measured.

How accurate the fine RK4 is, sweep.py says: `adaptive` carries the case's particles with
Dormand-Prince 5(4) and its own step control (adaptive.py) at each of TOLERANCES, and
each result is held against the reference.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cavesim.core.features.feature import FrameState
from cavesim.core.fields.analytic import rotating_velocity
from cavesim.core.scene.model import Integrator
from cavesim.core.twin.forces import ForceModel
from cavesim.core.twin.integrators import INTEGRATORS
from cavesim.core.twin.system import TwinSystem
from cavesim.tools.numerics.adaptive import dormand_prince
from cavesim.tools.numerics.cases import Case
from cavesim.tools.numerics.solid_body import centripetal, rotated, solid_body

REFINEMENT = 16  # reference step = finest dt / REFINEMENT
TOLERANCES = tuple(10.0**-k for k in range(6, 13))  # of the Dormand-Prince sweep


@dataclass(frozen=True)
class Reference:
    time: float  # s
    pos: np.ndarray  # (N, 3) float64
    vel: np.ndarray  # (N, 3) float64
    acc: np.ndarray  # (N, 3) float64, the acceleration at (pos, vel)
    step: float | None  # s, of the RK4 run; None for the closed form

    def position_at(self, t: float) -> np.ndarray:
        gap = t - self.time
        return self.pos + self.vel * gap + self.acc * (0.5 * gap * gap)

    def velocity_at(self, t: float) -> np.ndarray:
        return self.vel + self.acc * (t - self.time)


def twin_forces(case: Case) -> ForceModel:
    """The float64 twin's force model on the case's particles in the case's frame."""
    twin = TwinSystem(case.scene(Integrator.RK4), np.float64)
    rotor = twin.rotor_inputs.read(case.frame) if twin.rotor_inputs is not None else None
    return twin.forces_for(case.particles["class_id"], FrameState(rotor=rotor))


def closed_form(case: Case, t: float) -> Reference:
    """Exact state at t of linear drag toward a uniform flow, with gravity:
      v(t) = v_inf + (v0 - v_inf) e^(-lambda t)
      x(t) = x0 + v_inf t + (v0 - v_inf) (1 - e^(-lambda t)) / lambda
    where v_inf = f / lambda (= u + g tau without damping)."""
    p0 = case.particles["pos"].astype(np.float64)
    v0 = case.particles["vel"].astype(np.float64)
    f, lam, _ = twin_forces(case).linear_parts(p0, v0)  # Stokes: lambda does not depend on v0
    v_inf = f / lam
    decay = np.exp(-lam * t)
    grown = -np.expm1(-lam * t) / lam
    v = v_inf + (v0 - v_inf) * decay
    return Reference(t, p0 + v_inf * t + (v0 - v_inf) * grown, v, f - lam * v, None)


def rotating_closed_form(case: Case, t: float) -> Reference:
    """Exact state at t of linear drag toward the uniform flow u(t) = R(omega t) U turning
    about z, with gravity (Stokes drag, no damping). Horizontally, as complex numbers
    x + iy, with V = lambda U / (lambda + i omega) the velocity that turns with the flow:
      v(t) = V e^(i omega t) + (v0 - V) e^(-lambda t)
      x(t) = x0 + V (e^(i omega t) - 1) / (i omega) + (v0 - V) (1 - e^(-lambda t)) / lambda
    and vertically the uniform flow's closed form. The snapshots hold float32 values of
    u; the reference takes the exact flow, its own closed form."""
    scene = case.scene(Integrator.RK4)
    params = scene.field.params
    lam = float(np.float32(1.0 / scene.relaxation_times()[0]))  # the engine's 1/tau
    omega = params["angular_speed"]
    g = float(np.float32(scene.forces.gravity[2]))
    p0 = case.particles["pos"].astype(np.float64)
    v0 = case.particles["vel"].astype(np.float64)
    ux, uy, uz = rotating_velocity(0.0, params)
    turning = lam * complex(ux, uy) / (lam + 1j * omega)
    start = v0[:, 0] + 1j * v0[:, 1]
    spin, decay, grown = np.exp(1j * omega * t), np.exp(-lam * t), -np.expm1(-lam * t) / lam
    v_xy = turning * spin + (start - turning) * decay
    x_xy = (p0[:, 0] + 1j * p0[:, 1] + turning * (spin - 1) / (1j * omega)
            + (start - turning) * grown)
    v_inf = uz + g / lam
    v_z = v_inf + (v0[:, 2] - v_inf) * decay
    x_z = p0[:, 2] + v_inf * t + (v0[:, 2] - v_inf) * grown
    pos = np.stack([x_xy.real, x_xy.imag, x_z], axis=1)
    vel = np.stack([v_xy.real, v_xy.imag, v_z], axis=1)
    u = rotating_velocity(t, params)
    return Reference(t, pos, vel, lam * (u - vel) + np.array([0.0, 0.0, g]), None)


def solid_body_closed_form(case: Case, t: float) -> Reference:
    """Exact state at t of tracers in the solid-body vortex: the start turned by Omega t,
    moving with the flow there."""
    pos = rotated(case.particles["pos"].astype(np.float64), t)
    return Reference(t, pos, solid_body(pos), centripetal(pos), None)


def rotating_tracer_closed_form(case: Case, t: float) -> Reference:
    """Exact state at t of tracers in the flow u(t) = R(omega t) U turning about z: as
    complex numbers x + iy, x(t) = x0 + U (e^(i omega t) - 1) / (i omega), and z climbs at
    U's vertical speed; each moves with the flow, which turns at omega."""
    params = case.scene(Integrator.RK4).field.params
    omega = params["angular_speed"]
    ux, uy, uz = rotating_velocity(0.0, params)
    p0 = case.particles["pos"].astype(np.float64)
    x_xy = p0[:, 0] + 1j * p0[:, 1] + complex(ux, uy) * (np.exp(1j * omega * t) - 1) / (1j * omega)
    pos = np.stack([x_xy.real, x_xy.imag, p0[:, 2] + uz * t], axis=1)
    u = rotating_velocity(t, params)
    turning = np.array([-omega * u[1], omega * u[0], 0.0])  # du/dt
    return Reference(t, pos, np.broadcast_to(u, pos.shape).copy(),
                     np.broadcast_to(turning, pos.shape).copy(), None)


CLOSED_FORMS = {"uniform": closed_form, "rotating": rotating_closed_form,
                "solid_body": solid_body_closed_form,
                "rotating_tracer": rotating_tracer_closed_form}  # Case.closed_form


def fine_rk4(case: Case, t: float, step: float) -> Reference:
    """The float64 twin's RK4 from the case's particles to t in round(t / step) equal steps."""
    steps = max(1, round(t / step))
    h = t / steps
    p = case.particles["pos"].astype(np.float64)
    v = case.particles["vel"].astype(np.float64)
    forces = twin_forces(case)
    rk4 = INTEGRATORS[Integrator.RK4]
    for _ in range(steps):
        p, v = rk4(p, v, h, forces)
    return Reference(t, p, v, forces.acceleration(p, v), h)


@dataclass(frozen=True)
class AdaptiveState:
    """Where Dormand-Prince at one tolerance ends, and what it cost per particle."""

    tolerance: float
    pos: np.ndarray  # (N, 3) float64 at the end time
    vel: np.ndarray
    accepted: np.ndarray  # (N,) steps
    rejected: np.ndarray
    evaluations: np.ndarray  # (N,) field evaluations


def adaptive(case: Case, t: float, tolerance: float) -> AdaptiveState:
    """The case's particles carried to t by Dormand-Prince 5(4) at `tolerance`."""
    run = dormand_prince(case.particles["pos"], case.particles["vel"], twin_forces(case), t,
                         tolerance)
    return AdaptiveState(tolerance, run.pos, run.vel, run.accepted, run.rejected,
                         run.evaluations)


def concatenate(parts: list[Reference]) -> Reference:
    """One reference from references of consecutive particle chunks."""
    first = parts[0]
    return Reference(first.time, *(np.concatenate([getattr(r, name) for r in parts])
                                   for name in ("pos", "vel", "acc")), first.step)

