"""One step of a passive tracer, dx/dt = u(x, t): (p, h, forces) -> (p, v).

Twin of `trace` in shaders/include/tracers.glsl; `TRACERS` maps each `TracerMethod` to the
step of its name. The step moves the position by an explicit Runge-Kutta tableau on the
flow alone (no inertia, gravity or damping) and gives the record the flow at the new
position as its velocity, for drawing.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from cavesim.core.fields.snapshot_time import END, STAGE_OF_FRACTION
from cavesim.core.operations import REFERENCE_OPERATIONS
from cavesim.core.scene.model import TracerMethod
from cavesim.core.substeps import adaptive_trace, stage_nodes, tableau
from cavesim.core.twin.forces import ForceModel
from cavesim.core.twin.integrators import (
    RK2_MIDPOINT_A,
    RK2_MIDPOINT_B,
    RK4_CLASSIC_A,
    RK4_CLASSIC_B,
)

TracerStep = Callable[[np.ndarray, float, ForceModel], tuple[np.ndarray, np.ndarray]]

EULER_A, EULER_B = ((),), (1.0,)
HEUN_A, HEUN_B = ((), (1.0,)), (0.5, 0.5)  # the explicit trapezoid rule


def _tracer_runge_kutta(a_table, b_weights) -> TracerStep:
    """The tracer step of an explicit tableau: each stage the flow at its point, taken at
    its time c = sum(row) of the step."""

    def step(p, h, forces):
        k = []
        for row in a_table:
            ps = p
            for coefficient, kj in zip(row, k, strict=False):
                if coefficient:
                    ps = ps + (coefficient * h) * kj
            k.append(forces.flow(ps, STAGE_OF_FRACTION[sum(row)]))
        p = p + h * sum(w * kj for w, kj in zip(b_weights, k, strict=True) if w)
        return p, forces.flow(p, END)

    return step


euler = _tracer_runge_kutta(EULER_A, EULER_B)
euler.__doc__ = "Explicit Euler on the flow, order 1."
midpoint = _tracer_runge_kutta(RK2_MIDPOINT_A, RK2_MIDPOINT_B)
midpoint.__doc__ = "Explicit midpoint on the flow, order 2."
heun = _tracer_runge_kutta(HEUN_A, HEUN_B)
heun.__doc__ = "Heun's method (explicit trapezoid) on the flow, order 2."
rk4 = _tracer_runge_kutta(RK4_CLASSIC_A, RK4_CLASSIC_B)
rk4.__doc__ = "Classic Runge-Kutta on the flow, order 4."


def rk45(p, h, forces, tolerance=math.inf, record=None):
    """Dormand-Prince 5(4) in substeps held to `tolerance` (cavesim/core/substeps.py), order 5
    at a fixed substep; `record` gets the frame's SubstepCounts."""
    return adaptive_trace(p, h, forces, tolerance, REFERENCE_OPERATIONS, _moved, tableau(p.dtype),
                          stage_nodes(p.dtype), record)


def _moved(forces, rows, p, dp):
    return p + dp


# Each tracer method's step is the function above named as the table names it.
TRACERS: dict[TracerMethod, TracerStep] = {m: globals()[m.value] for m in TracerMethod}
