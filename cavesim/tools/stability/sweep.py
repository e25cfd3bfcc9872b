"""The stiff sweep: every integrator, relaxation times from 10 s down to 1 µs, two steps.

Linear drag makes dv/dt = -v/tau stiff when tau is far below dt. Theory bounds h = dt/tau
by each integrator's `stability_limit` (its `Integrator` row; infinite for the methods
implicit in the drag or solving it exactly).
One GPU run per integrator, drag law and dt covers every tau: one particle class per tau.

Each drag law is a `DragCase`: the classes' `drag` key and the rate theory reads. An
explicit method's limit is on the Jacobian of the drag, d(lambda(|w|) w)/dw, whose largest
eigenvalue lies along the slip w = u - v; the semi-implicit and exponential steps freeze
lambda over the step. Stokes drag has one rate, 1/tau, so h = dt/tau. Schiller-Naumann's
lambda = f(Re)/tau grows with the slip (Re = |w| d/nu, f = 1 + 0.15 Re^0.687), and so does
its Jacobian along the slip, (1 + 0.15·1.687 Re^0.687)/tau: a class's stiffness is an
interval, from h at its settling slip (where a bounded particle ends: above the limit there
it cannot settle, divergent) to h at the largest slip it starts with (below the limit there
every slip it meets is stable, bounded); between the two the outcome depends on the path
(marginal: either agrees with theory).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cavesim.core.drag import (
    SCHILLER_NAUMANN_COEFFICIENT,
    SCHILLER_NAUMANN_EXPONENT,
    terminal_speed,
)
from cavesim.core.features.stokes_drag import Drag
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import Integrator, parse_scene
from cavesim.core.scene.model import AIR_VISCOSITY, ParticleClass
from cavesim.gpu.engine import FrameInput, ParticleSystem

STEPS = (1 / 60, 1 / 30)
# The explicit methods' limits on h = dt/tau (their `Integrator` rows), each bracketed at
# every dt: a class BRACKET below it (bounded) and one BRACKET above (divergent)
EXPLICIT_LIMITS = tuple(sorted({i.stability_limit for i in Integrator
                                if math.isfinite(i.stability_limit)}))
BRACKET = 0.05
# 10 s to 1 µs; the two taus that put dt/tau at 2.4 (between RK2's and RK4's limits); the
# brackets
TAUS = tuple(sorted([float(t) for t in np.logspace(1, -6, 15)]
                    + [dt / 2.4 for dt in STEPS]
                    + [dt / (limit * (1.0 + side * BRACKET)) for dt in STEPS
                       for limit in EXPLICIT_LIMITS for side in (-1, 1)], reverse=True))
DENSITY = 2650.0
FLOW = (1.0, 0.0, 0.2)
GRAVITY = 9.81
AIR = Drag()  # the sweep's [forces.drag] = {}: the default air
MARGIN = 0.02  # within 2% of a limit either outcome agrees with theory (inside the brackets)


@dataclass(frozen=True)
class DragCase:
    """A drag law swept: the particle classes' `drag` key and the rate theory reads."""

    name: str
    law: str = "stokes"  # every class's drag = "stokes" | "schiller_naumann"
    # (tau, slip in m/s) -> the largest eigenvalue of the drag's Jacobian, 1/s
    jacobian_rate: Callable[[float, float], float] = lambda tau, slip: 1.0 / tau


def schiller_naumann_rate(tau: float, slip: float) -> float:
    """(1 + 0.15·1.687 Re^0.687)/tau: d(f(Re) w / tau)/d|w| along the slip."""
    reynolds = slip * diameter_for(tau) / AIR.kinematic_viscosity
    return (1.0 + SCHILLER_NAUMANN_COEFFICIENT * (1.0 + SCHILLER_NAUMANN_EXPONENT)
            * reynolds**SCHILLER_NAUMANN_EXPONENT) / tau


STOKES = DragCase("stokes")
SCHILLER_NAUMANN = DragCase("schiller_naumann", "schiller_naumann", schiller_naumann_rate)
DRAG_CASES: tuple[DragCase, ...] = (STOKES, SCHILLER_NAUMANN)


def diameter_for(tau: float) -> float:
    """The grain whose Stokes relaxation time is tau (tau = rho d² / 18 mu)."""
    return math.sqrt(18.0 * AIR_VISCOSITY * tau / DENSITY)


def sweep_scene(integrator: Integrator, per_class: int, drag: DragCase = STOKES):
    return parse_scene({
        "simulation": {"capacity": per_class * len(TAUS), "seed": 1,
                       "integrator": integrator.value, "random_texture_size": 16},
        # the law named (the loader would give the larger grains Schiller-Naumann's)
        "particle_class": [{"name": f"tau{i}", "diameter": diameter_for(tau),
                            "density": DENSITY, "drag": drag.law}
                           for i, tau in enumerate(TAUS)],
        "forces": {"gravity": [0.0, 0.0, -GRAVITY], "drag": {}},
        "field": {"kind": "uniform", "box_min": [-1e7] * 3, "box_max": [1e7] * 3,
                  "resolution": [2, 2, 2], "params": {"velocity": list(FLOW)}},
    }, name=f"stiff-{drag.name}-{integrator.value}")


def settling_slip(drag: DragCase, tau: float) -> float:
    """m/s: the slip a particle of this law and tau ends at, its settling speed in still air
    (the uniform flow moves it, gravity alone sets the slip)."""
    grain = ParticleClass("sweep", diameter_for(tau), DENSITY)
    return terminal_speed(grain, drag.law == "schiller_naumann", AIR.kinematic_viscosity,
                          AIR.air_viscosity, GRAVITY)


def stiffness_range(drag: DragCase, dt: float, tau: float, start_slip: float
                    ) -> tuple[float, float]:
    """h = dt × the Jacobian's rate at the settling slip and at the largest slip met (the
    start's, or the settling one if larger): one value for Stokes drag."""
    settled = settling_slip(drag, tau)
    return (dt * drag.jacobian_rate(tau, settled),
            dt * drag.jacobian_rate(tau, max(settled, start_slip)))


def expected(integrator: Integrator, stiffness: tuple[float, float]) -> str:
    """bounded below the limit over the whole range, divergent above it at the settled end,
    marginal within MARGIN of it or across it."""
    limit = integrator.stability_limit
    low, high = stiffness
    if high < limit * (1.0 - MARGIN):
        return "bounded"
    if low > limit * (1.0 + MARGIN):
        return "divergent"
    return "marginal"


def run_sweep(ctx, frames: int = 120, per_class: int = 32,
              drags: tuple[DragCase, ...] = DRAG_CASES) -> list[dict]:
    """One row per drag law, integrator, dt and tau: outcome on the GPU, theory, agreement."""
    rows = []
    rng = np.random.default_rng(0)
    start = np.zeros(per_class * len(TAUS), dtype=PARTICLE_DTYPE)
    start["pos"] = rng.uniform(-5, 5, (len(start), 3))
    start["vel"] = rng.uniform(-5, 5, (len(start), 3))
    start["lifetime"] = 1e6
    start["class_id"] = np.repeat(np.arange(len(TAUS)), per_class)
    slips = np.linalg.norm(start["vel"].astype(np.float64) - FLOW, axis=1)
    start_slips = [float(slips[start["class_id"] == c].max()) for c in range(len(TAUS))]
    identity = np.eye(3, dtype=np.float32)
    for drag in drags:
        for integrator in Integrator:
            system = ParticleSystem(ctx, sweep_scene(integrator, per_class, drag))
            for dt in STEPS:
                system.write_particles(start)
                for _ in range(frames):
                    system.step(FrameInput(dt, identity))
                end = system.read_particles()
                rows += [outcome_row(drag, integrator, dt, c, tau, end, per_class,
                                     start_slips[c]) for c, tau in enumerate(TAUS)]
            system.release()
    return rows


def outcome_row(drag, integrator, dt, class_id, tau, end, per_class, start_slip) -> dict:
    mine = end[end["class_id"] == class_id]
    finite = bool(np.isfinite(mine["pos"]).all() and np.isfinite(mine["vel"]).all())
    speed = float(np.abs(mine["vel"]).max()) if len(mine) else math.inf
    bound = 2.0 * (math.hypot(*FLOW) + GRAVITY * tau + 10.0)
    outcome = "bounded" if len(mine) == per_class and speed <= bound else "divergent"
    low, high = stiffness_range(drag, dt, tau, start_slip)
    theory = expected(integrator, (low, high))
    return {"drag": drag.name, "integrator": integrator.value, "dt": dt, "tau": tau,
            "dt_over_tau": dt / tau, "stiffness": low, "stiffness_max": high,
            "outcome": outcome, "theory": theory, "agrees": theory in ("marginal", outcome),
            "survivors": int(len(mine)), "max_speed": speed if finite else None,
            "state_finite": finite}
