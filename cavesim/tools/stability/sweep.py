"""The stiff sweep: every integrator, relaxation times from 10 s down to 1 µs, two steps.

Linear drag makes dv/dt = -v/tau stiff when tau is far below dt. Theory for h = dt/tau:
explicit Euler, trapezoid (its velocity is Euler's), velocity Verlet and RK2 are stable
for h < 2, RK4 for h < 2.785; semi-implicit Euler (implicit in the drag) and the two
exponential integrators (exponential Euler, ETD2RK: the drag is solved exactly) for any h.
One GPU run per integrator, drag law and dt covers every tau: one particle class per tau.

Each drag law is a `DragCase`: the classes' `drag` key and the stiffness h the limits are
read at. Stokes drag has h = dt/tau; a law whose rate lambda depends on the slip speed
(Schiller-Naumann: lambda = (1 + 0.15 Re^0.687)/tau) adds a DragCase whose stiffness is
dt times the largest rate the sweep's slip speeds give (the explicit methods' limit is on
the Jacobian of the drag, d(lambda(|w|) w)/dw, the exponential ones freeze lambda).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import Integrator, parse_scene
from cavesim.core.scene.model import AIR_VISCOSITY
from cavesim.gpu.engine import FrameInput, ParticleSystem

# 10 s to 1 µs, plus the two taus that put dt/tau at 2.4 (between RK2's and RK4's limits)
TAUS = tuple(sorted([float(t) for t in np.logspace(1, -6, 15)] + [1 / 60 / 2.4, 1 / 30 / 2.4],
                    reverse=True))
STEPS = (1 / 60, 1 / 30)
STABILITY_LIMITS = {  # the largest dt/tau at which linear drag stays bounded
    Integrator.EXPLICIT_EULER: 2.0,
    Integrator.TRAPEZOID: 2.0,
    Integrator.VERLET: 2.0,
    Integrator.RK2: 2.0,
    Integrator.RK4: 2.785,
    Integrator.SEMI_IMPLICIT_EULER: math.inf,
    Integrator.EXPONENTIAL: math.inf,
    Integrator.ETD2RK: math.inf,
}
DENSITY = 2650.0
FLOW = (1.0, 0.0, 0.2)
MARGIN = 0.05  # within 5% of a limit either outcome agrees with theory


@dataclass(frozen=True)
class DragCase:
    """A drag law swept: the particle classes' `drag` key and the stiffness theory reads."""

    name: str
    law: str = "stokes"  # every class's drag = "stokes" | "schiller_naumann"
    # (dt, tau) -> the h = dt * lambda that STABILITY_LIMITS are compared with
    stiffness: Callable[[float, float], float] = lambda dt, tau: dt / tau


STOKES = DragCase("stokes")
DRAG_CASES: tuple[DragCase, ...] = (STOKES,)  # Schiller-Naumann adds its own here


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
        "forces": {"gravity": [0.0, 0.0, -9.81], "drag": {}},
        "field": {"kind": "uniform", "box_min": [-1e7] * 3, "box_max": [1e7] * 3,
                  "resolution": [2, 2, 2], "params": {"velocity": list(FLOW)}},
    }, name=f"stiff-{drag.name}-{integrator.value}")


def expected(integrator: Integrator, ratio: float) -> str:
    limit = STABILITY_LIMITS[integrator]
    if abs(ratio / limit - 1.0) < MARGIN:
        return "marginal"
    return "bounded" if ratio < limit else "divergent"


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
    identity = np.eye(3, dtype=np.float32)
    for drag in drags:
        for integrator in Integrator:
            system = ParticleSystem(ctx, sweep_scene(integrator, per_class, drag))
            for dt in STEPS:
                system.write_particles(start)
                for _ in range(frames):
                    system.step(FrameInput(dt, identity))
                end = system.read_particles()
                rows += [outcome_row(drag, integrator, dt, c, tau, end, per_class)
                         for c, tau in enumerate(TAUS)]
            system.release()
    return rows


def outcome_row(drag, integrator, dt, class_id, tau, end, per_class) -> dict:
    mine = end[end["class_id"] == class_id]
    finite = bool(np.isfinite(mine["pos"]).all() and np.isfinite(mine["vel"]).all())
    speed = float(np.abs(mine["vel"]).max()) if len(mine) else math.inf
    bound = 2.0 * (math.hypot(*FLOW) + 9.81 * tau + 10.0)
    outcome = "bounded" if len(mine) == per_class and speed <= bound else "divergent"
    stiffness = drag.stiffness(dt, tau)
    theory = expected(integrator, stiffness)
    return {"drag": drag.name, "integrator": integrator.value, "dt": dt, "tau": tau,
            "dt_over_tau": dt / tau, "stiffness": stiffness, "outcome": outcome,
            "theory": theory, "agrees": theory in ("marginal", outcome),
            "survivors": int(len(mine)), "max_speed": speed if finite else None,
            "state_finite": finite}
