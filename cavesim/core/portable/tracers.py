"""One step of a passive tracer in portable arithmetic: `trace` of shaders/include/tracers.glsl,
operation by operation in float32.

Same signature as the float64 twin's (cavesim/core/twin/tracers.py): (p, h, forces) ->
(p, v), with `forces` a `PortableForces` whose `move` carries the position's low part.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from cavesim.core.fields.snapshot_time import END, MIDDLE, START
from cavesim.core.operations import PORTABLE_OPERATIONS
from cavesim.core.portable.arithmetic import f_add, f_div, f_mul
from cavesim.core.portable.integrators import HALF, SIX, rk4_sum
from cavesim.core.position import move
from cavesim.core.scene.model import TracerMethod
from cavesim.core.substeps import adaptive_trace, stage_nodes, tableau


def _carried(p, forces):
    """The moved position and the flow there, the record's velocity."""
    return p, forces.flow(p, END)


def euler(p, h, forces):
    """Explicit Euler on the flow, order 1."""
    return _carried(forces.move(p, f_mul(h, forces.flow(p, START))), forces)


def midpoint(p, h, forces):
    """Explicit midpoint on the flow, order 2."""
    k1 = forces.flow(p, START)
    k2 = forces.flow(f_add(p, f_mul(f_mul(HALF, h), k1)), MIDDLE)
    return _carried(forces.move(p, f_mul(h, k2)), forces)


def heun(p, h, forces):
    """Heun's method (explicit trapezoid) on the flow, order 2."""
    k1 = forces.flow(p, START)
    k2 = forces.flow(f_add(p, f_mul(h, k1)), END)
    return _carried(forces.move(p, f_mul(f_mul(HALF, h), f_add(k1, k2))), forces)


def rk4(p, h, forces):
    """Classic Runge-Kutta on the flow, order 4."""
    half_h = f_mul(HALF, h)
    k1 = forces.flow(p, START)
    k2 = forces.flow(f_add(p, f_mul(half_h, k1)), MIDDLE)
    k3 = forces.flow(f_add(p, f_mul(half_h, k2)), MIDDLE)
    k4 = forces.flow(f_add(p, f_mul(h, k3)), END)
    return _carried(forces.move(p, f_mul(f_div(h, SIX), rk4_sum(k1, k2, k3, k4))), forces)


def rk45(p, h, forces, tolerance=math.inf, record=None):
    """Dormand-Prince 5(4) in substeps held to `tolerance` (cavesim/core/substeps.py)."""
    return adaptive_trace(p, h, forces, tolerance, PORTABLE_OPERATIONS, _moved, tableau(),
                          stage_nodes(), record)


def _moved(forces, rows, p, dp):
    """position.glsl's move of the points of `rows`, their low parts carried in forces."""
    p, forces.position_low[rows] = move(p, forces.position_low[rows], dp)
    return p


# Each tracer method's step is the function above named as the table names it.
TRACERS: dict[TracerMethod, Callable] = {m: globals()[m.value] for m in TracerMethod}
