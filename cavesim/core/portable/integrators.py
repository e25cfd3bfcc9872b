"""One step of each integrator in portable arithmetic: `integrate`, `exponential_weights` and
`phi3_weight` of shaders/include/integrators.glsl, operation by operation in float32.

Same signature as the float64 reference (cavesim/core/twin/integrators.py): (p, v, h,
forces) -> (p, v), with `forces` a `PortableForces`, whose `move` adds the position's one
increment a step to hi + low as position.glsl's move does (cavesim/core/position.py). Where
the shader branches per particle, both sides are computed here and the branch's own is
selected.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cavesim.core.fields.snapshot_time import END, MIDDLE
from cavesim.core.portable.arithmetic import f_add, f_div, f_exp, f_mul, f_sub
from cavesim.core.portable.constants import (
    INV_FACTORIAL_3,
    INV_FACTORIAL_4,
    INV_FACTORIAL_5,
    INV_FACTORIAL_6,
    INV_FACTORIAL_7,
    INV_FACTORIAL_8,
    INV_FACTORIAL_9,
    INV_FACTORIAL_10,
    INV_FACTORIAL_11,
)
from cavesim.core.scene.model import Integrator

HALF, ONE, TWO, SIX = np.float32(0.5), np.float32(1.0), np.float32(2.0), np.float32(6.0)
SERIES_BELOW = np.float32(0.5)  # x below which phi1 and phi2 are summed as series
PHI3_SERIES_BELOW = np.float32(1.0)  # and phi3


def explicit_euler(p, v, h, forces):
    """Explicit (forward) Euler, order 1."""
    a = forces.acceleration(p, v)
    return forces.move(p, f_mul(h, v)), f_add(v, f_mul(h, a))


def semi_implicit_euler(p, v, h, forces):
    """Semi-implicit Euler: drag implicit, the rest explicit, new velocity moves, order 1."""
    f, lam, _ = forces.linear_parts(p, v)
    weight = f_div(h, f_add(ONE, f_mul(h, lam)))
    v = f_add(v, f_mul(weight, f_sub(f, f_mul(lam, v))))
    return forces.move(p, f_mul(h, v)), v


def trapezoid(p, v, h, forces):
    """UberFlow eq. (1)-(2): Euler velocity, trapezoidal position, order 1."""
    half_h = f_mul(HALF, h)
    v1 = f_add(v, f_mul(h, forces.acceleration(p, v)))
    return forces.move(p, f_mul(half_h, f_add(v, v1))), v1


def verlet(p, v, h, forces):
    """Velocity Verlet with an Euler-predicted velocity for the drag, order 2."""
    half_h = f_mul(HALF, h)
    a0 = forces.acceleration(p, v)
    p = forces.move(p, f_mul(h, f_add(v, f_mul(half_h, a0))))
    a1 = forces.acceleration(p, f_add(v, f_mul(h, a0)), END)
    return p, f_add(v, f_mul(half_h, f_add(a0, a1)))


def rk2(p, v, h, forces):
    """Explicit midpoint Runge-Kutta, order 2."""
    half_h = f_mul(HALF, h)
    a0 = forces.acceleration(p, v)
    pm = f_add(p, f_mul(half_h, v))
    vm = f_add(v, f_mul(half_h, a0))
    return forces.move(p, f_mul(h, vm)), f_add(v, f_mul(h, forces.acceleration(pm, vm, MIDDLE)))


def rk4_sum(k1, k2, k3, k4):
    """k1 + 2 k2 + 2 k3 + k4, integrators.glsl's rk4_sum."""
    return f_add(f_add(f_add(k1, f_mul(TWO, k2)), f_mul(TWO, k3)), k4)


def rk4(p, v, h, forces):
    """Classic Runge-Kutta, order 4."""
    half_h = f_mul(HALF, h)
    k1p = v
    k1v = forces.acceleration(p, v)
    k2p = f_add(v, f_mul(half_h, k1v))
    k2v = forces.acceleration(f_add(p, f_mul(half_h, k1p)), k2p, MIDDLE)
    k3p = f_add(v, f_mul(half_h, k2v))
    k3v = forces.acceleration(f_add(p, f_mul(half_h, k2p)), k3p, MIDDLE)
    k4p = f_add(v, f_mul(h, k3v))
    k4v = forces.acceleration(f_add(p, f_mul(h, k3p)), k4p, END)
    sixth_h = f_div(h, SIX)
    return (forces.move(p, f_mul(sixth_h, rk4_sum(k1p, k2p, k3p, k4p))),
            f_add(v, f_mul(sixth_h, rk4_sum(k1v, k2v, k3v, k4v))))


def exponential_weights(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """e^-x, phi1 = (1 - e^-x)/x and phi2 = (x - 1 + e^-x)/x^2; series below x = 0.5."""
    e = f_exp(-x)
    tail1 = f_sub(INV_FACTORIAL_6, f_mul(x, INV_FACTORIAL_7))
    for coefficient in (INV_FACTORIAL_5, INV_FACTORIAL_4, INV_FACTORIAL_3, HALF):
        tail1 = f_sub(coefficient, f_mul(x, tail1))
    tail2 = f_sub(INV_FACTORIAL_7, f_mul(x, INV_FACTORIAL_8))
    for coefficient in (INV_FACTORIAL_6, INV_FACTORIAL_5, INV_FACTORIAL_4, INV_FACTORIAL_3):
        tail2 = f_sub(coefficient, f_mul(x, tail2))
    with np.errstate(divide="ignore", invalid="ignore"):  # x = 0 takes the series
        closed1 = f_div(f_sub(ONE, e), x)
        closed2 = f_div(f_add(f_sub(x, ONE), e), f_mul(x, x))
    series = x < SERIES_BELOW
    phi1 = np.where(series, f_sub(ONE, f_mul(x, tail1)), closed1)
    phi2 = np.where(series, f_sub(HALF, f_mul(x, tail2)), closed2)
    return e, phi1, phi2


def phi3_weight(x: np.ndarray, phi2: np.ndarray) -> np.ndarray:
    """phi3 = (x^2/2 - x + 1 - e^-x)/x^3 = (1/2 - phi2)/x; series below x = 1."""
    tail = f_sub(INV_FACTORIAL_10, f_mul(x, INV_FACTORIAL_11))
    for coefficient in (INV_FACTORIAL_9, INV_FACTORIAL_8, INV_FACTORIAL_7, INV_FACTORIAL_6,
                        INV_FACTORIAL_5, INV_FACTORIAL_4):
        tail = f_sub(coefficient, f_mul(x, tail))
    with np.errstate(divide="ignore", invalid="ignore"):  # x = 0 takes the series
        closed = f_div(f_sub(HALF, phi2), x)
    return np.where(x < PHI3_SERIES_BELOW, f_sub(INV_FACTORIAL_3, f_mul(x, tail)), closed)


def exponential(p, v, h, forces):
    """Exponential Euler in increment form, order 1: r = f - lambda v,
    p += h (v + h phi2 r), v += h phi1 r."""
    f, lam, _ = forces.linear_parts(p, v)
    _, phi1, phi2 = exponential_weights(f_mul(lam, h))
    r = f_sub(f, f_mul(lam, v))
    p = forces.move(p, f_mul(h, f_add(v, f_mul(f_mul(h, phi2), r))))
    return p, f_add(v, f_mul(f_mul(h, phi1), r))


def etd2rk(p, v, h, forces):
    """ETD2RK (Cox & Matthews 2002), order 2: the float64 twin's `etd2rk` derives it."""
    f, lam, drag = forces.linear_parts(p, v)
    x = f_mul(lam, h)
    _, phi1, phi2 = exponential_weights(x)
    phi3 = phi3_weight(x, phi2)
    r = f_sub(f, f_mul(lam, v))
    w = f_add(v, f_mul(f_mul(h, phi2), r))
    pa = f_add(p, f_mul(h, w))
    va = f_add(v, f_mul(f_mul(h, phi1), r))
    d = f_sub(forces.remainder(pa, va, drag), f)
    p = forces.move(p, f_mul(h, f_add(w, f_mul(f_mul(h, phi3), d))))
    return p, f_add(v, f_mul(h, f_add(f_mul(phi1, r), f_mul(phi2, d))))


# Each integrator's step is the function above named as its scene file names it.
INTEGRATORS: dict[Integrator, Callable] = {i: globals()[i.value] for i in Integrator}
