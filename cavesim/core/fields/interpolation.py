"""The smooth interpolants of a gridded flow: Catmull-Rom (C1) and cubic B-spline (C2).

Why: RK4 is only second order in a trilinear field, whose gradient jumps at every cell face;
a field that is C^k across faces lets it reach order k + 2, up to its own 4 (Nordam & Duran
2020, "Numerical integrators for Lagrangian oceanography", GMD 13; Mork, Nordam & Ruhs 2025).

Both evaluate, per axis, four texels around the cell with cubic weights of the fraction t, as
a tensor product (4³ = 64 texels in 3D). The texels are not the node values: `texels` turns
the (nz, ny, nx, 3) nodes into a padded (nz+2, ny+2, nx+2, 3) array, a per-axis linear map
from n nodes to n + 2 texels, so that texel k + 1 belongs to node k and the four texels of
cell i0 are i0 … i0 + 3 on every axis, at the faces of the box as well:

  catmull_rom  the node values (Keys 1981, "Cubic convolution interpolation for digital image
               processing", IEEE TASSP 29(6), kernel a = −1/2) and one ghost node beyond each
               end by Keys' boundary rule g = 3 v0 − 3 v1 + v2 (the parabola through the three
               end nodes, continued).
               Interpolates the nodes, C1, error O(h³), reproduces quadratics.
  bspline      cubic B-spline coefficients c prefiltered so the spline interpolates the nodes
               (Unser 1999, "Splines: a perfect fit for signal and image processing", IEEE SPM
               16(6): (c[k−1] + 4 c[k] + c[k+1]) / 6 = v[k]), closed by de Boor's not-a-knot end
               condition (third derivative continuous at the second and the last-but-one node).
               Interpolates the nodes, C2, error O(h⁴) (approximation order 4), reproduces
               cubics. Chosen over the quasi-interpolant (the spline of the raw node values,
               no prefilter), which smooths the flow by O(h²): the prefilter costs once per
               scene on the CPU, nothing per sample.
  On an axis of n < 4 nodes (3 for Catmull-Rom) the end condition falls back to the polynomial
  through all n nodes (a line for n = 2), so every rule reads: the m-th difference of the
  first (last) m + 1 texels vanishes, m = min(n, 3 or 4).

The weights are kept to integer polynomials (Catmull-Rom x2, B-spline x6, the factors of the
cubic bases in Sigg & Hadwiger, GPU Gems 2 ch. 20); the texels carry the inverse of that
factor per axis (1/8 and 1/216 in 3D), so a shader multiplies by exact constants only.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cavesim.core.scene.model import FieldInterpolation

Arithmetic = Callable[[object, object], np.ndarray]


@dataclass(frozen=True)
class _Cubic:
    factor: int  # of the weights, per axis: they sum to it
    end_order: int  # the end rule's m on an axis of at least m nodes
    # the inner weights w1 = (3t − a) t² + b and w2 = (3s − a) s² + b, with s = 1 − t
    a: int
    b: int


_CUBICS = {
    FieldInterpolation.CATMULL_ROM: _Cubic(factor=2, end_order=3, a=5, b=2),
    FieldInterpolation.BSPLINE: _Cubic(factor=6, end_order=4, a=6, b=4),
}


def is_cubic(interpolation: FieldInterpolation) -> bool:
    """Whether `interpolation` samples 4 x 4 x 4 texels (else 2 x 2 x 2 nodes, trilinear)."""
    return FieldInterpolation(interpolation) in _CUBICS


def texels(velocity: np.ndarray, interpolation: FieldInterpolation) -> np.ndarray:
    """What the field texture holds: the nodes for trilinear, else the padded texels (float32).

    The per-axis maps are applied in float64 and the result rounded to float32 once.
    """
    interpolation = FieldInterpolation(interpolation)
    if not is_cubic(interpolation):
        return velocity
    out = np.asarray(velocity, dtype=np.float64)
    for axis in range(3):
        padded = axis_map(out.shape[axis], interpolation)
        out = np.moveaxis(np.tensordot(padded, out, axes=(1, axis)), 0, axis)
    return np.ascontiguousarray(out / _CUBICS[interpolation].factor ** 3, dtype=np.float32)


def axis_map(n: int, interpolation: FieldInterpolation) -> np.ndarray:
    """(n + 2, n): texels along one axis from its n node values (unscaled)."""
    order = min(n, _CUBICS[interpolation].end_order)
    end_rule = np.zeros(n + 2)
    end_rule[:order + 1] = [(-1) ** k * math.comb(order, k) for k in range(order + 1)]
    if interpolation is FieldInterpolation.CATMULL_ROM:
        # ghost = what makes the rule's difference vanish, from the nodes next to it
        ghost = -end_rule[1:n + 1] / end_rule[0]
        return np.vstack([ghost, np.eye(n), ghost[::-1]])
    system = np.zeros((n + 2, n + 2))
    rows = np.arange(n)
    system[rows, rows], system[rows, rows + 1], system[rows, rows + 2] = 1 / 6, 4 / 6, 1 / 6
    system[n], system[n + 1] = end_rule, end_rule[::-1]
    return np.linalg.solve(system, np.vstack([np.eye(n), np.zeros((2, n))]))


def weights(t: np.ndarray, interpolation: FieldInterpolation, add: Arithmetic = operator.add,
            sub: Arithmetic = operator.sub, mul: Arithmetic = operator.mul
            ) -> tuple[np.ndarray, ...]:
    """The four integer-polynomial weights of texels i0 … i0 + 3 at fractions t in [0, 1],
    in the shader's operation order (shaders/include/field.glsl cubic_weights) with the
    given arithmetic: numpy's operators, or the portable twin's f_add, f_sub, f_mul."""
    a, b = _CUBICS[interpolation].a, _CUBICS[interpolation].b
    s = sub(1, t)
    t2, s2 = mul(t, t), mul(s, s)
    inner = add(mul(sub(mul(3, t), a), t2), b), add(mul(sub(mul(3, s), a), s2), b)
    if interpolation is FieldInterpolation.BSPLINE:
        return mul(s2, s), *inner, mul(t2, t)
    return -mul(t, s2), *inner, -mul(s, t2)
