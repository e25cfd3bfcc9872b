"""How the adaptive tracer method (TracerMethod.RK45) divides a frame into substeps.

Dormand-Prince 5(4) steps a tracer through the frame's step h in substeps of h / 2^level.
A substep whose error estimate (the largest component of h_s * sum (b5 - b4) k, in metres)
exceeds the scene's `tracer_tolerance` is taken again at half the size; one at least
GROWTH_MARGIN times under it lets the next substep double, where the doubled substep starts
on a whole multiple of its own size. The smallest substep, level MAX_LEVEL, is always taken.
So every substep starts and ends on a multiple of h / UNITS, exact in float32, and the frame
ends exactly at h: no substep is cut short to land there, and every node and twin makes the
same choices from the same bits. Each substep advances by the fifth-order solution (local
extrapolation); its last stage is the next substep's first (first same as last).

The GPU's code is `trace` in shaders/include/tracers.glsl (TRACER_RK45); the twins' are
`rk45` in cavesim/core/twin/tracers.py and cavesim/core/portable/tracers.py.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cavesim.core.operations import Operations

# (forces, rows, p, dp) -> p + dp for the points of `rows` (the portable twin carries their
# low parts in forces.position_low, as position.glsl's move does)
RowsMove = Callable[[object, np.ndarray, np.ndarray, np.ndarray], np.ndarray]

# Dormand & Prince (1980), J. Comput. Appl. Math. 6, table 2: the RK5(4)7M pair, first same as
# last (its last row of A is its fifth-order weights B5); B4 the embedded fourth-order ones
DP54_C = (0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0)
DP54_A = (
    (),
    (1 / 5,),
    (3 / 40, 9 / 40),
    (44 / 45, -56 / 15, 32 / 9),
    (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729),
    (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656),
    (35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84),
)
DP54_B5 = (35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0.0)
DP54_B4 = (5179 / 57600, 0.0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40)

MAX_LEVEL = 6  # the smallest substep is the frame's step / 2^MAX_LEVEL
UNITS = 2**MAX_LEVEL  # substep starts and sizes are whole multiples of h / UNITS
# Every attempt is taken or halves the next: at most UNITS taken, and every halving but
# MAX_LEVEL of them follows a doubling, which only a taken substep makes
MAX_ATTEMPTS = 2 * UNITS + MAX_LEVEL
GROWTH_MARGIN = 32.0  # 2^5: how much the error estimate grows when the substep doubles
STAGES = len(DP54_C)  # 7, the last the next substep's first
NEW_STAGES = STAGES - 1  # flow samples per attempt
ERROR_WEIGHTS = tuple(b5 - b4 for b5, b4 in zip(DP54_B5, DP54_B4, strict=True))
TABLEAU_UNIFORM_VEC4S = 7  # tracers.glsl's rk45_tableau: A's rows 2..7, then ERROR_WEIGHTS


def tableau(dtype=np.float32) -> np.ndarray:
    """The coefficients in `dtype` (the GPU's: float32), in the order tracers.glsl's
    rk45_tableau holds them: A's rows for stages 2 to 7 (21 coefficients), then
    ERROR_WEIGHTS (7)."""
    flat = [a for row in DP54_A[1:] for a in row] + list(ERROR_WEIGHTS)
    assert len(flat) == 4 * TABLEAU_UNIFORM_VEC4S
    return np.array(flat, dtype=dtype)


def stage_nodes(dtype=np.float32) -> np.ndarray:
    """c of each stage in `dtype`: where in its substep the stage takes the flow."""
    return np.array(DP54_C, dtype=dtype)


@dataclass(frozen=True)
class SubstepCounts:
    """What the adaptive tracers did in one frame."""

    tracers: int  # tracers stepped
    taken: int  # substeps taken, summed over them
    retaken: int  # substeps refused and taken again at half the size
    most: int  # the most substeps one tracer took

    @classmethod
    def of(cls, taken: np.ndarray, retaken: np.ndarray) -> SubstepCounts:
        """From per-tracer counts."""
        return cls(len(taken), int(taken.sum()), int(retaken.sum()), int(taken.max(initial=0)))


NO_SUBSTEPS = SubstepCounts(0, 0, 0, 0)  # a frame without tracers


def adaptive_trace(p: np.ndarray, h, forces, tolerance, ops: Operations, move: RowsMove,
                   coefficients: np.ndarray, nodes: np.ndarray,
                   record: Callable[[SubstepCounts], None] | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """One frame's step h of tracers at p (N, 3): `trace` of tracers.glsl (TRACER_RK45) in
    the arithmetic of `ops` and `move`, with `coefficients` in `tableau`'s order and the
    stage `nodes`, both in p's dtype. The tracers still stepping step together; each
    keeps its own level and progress. Returns (p, v): v the flow at the end, where the last
    substep took it. `record` gets the frame's counts."""
    dtype = p.dtype.type
    h, tolerance, unit = dtype(h), dtype(tolerance), dtype(1.0 / UNITS)
    p = p.copy()
    n = len(p)
    k_first = forces.flow(p, np.zeros(n, dtype=dtype))
    done, level = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
    taken, retaken = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
    for _ in range(MAX_ATTEMPTS):
        active = np.flatnonzero(done < UNITS)
        if not len(active):
            break
        rows = forces.of_rows(active)
        units = UNITS >> level[active]
        share = ops.mul(units.astype(dtype), unit)
        start = ops.mul(done[active].astype(dtype), unit)
        sub_h = ops.mul(share, h)[:, None]
        pa = p[active]
        k = [k_first[active]]
        for s in range(1, STAGES):
            row = s * (s - 1) // 2
            total = np.zeros_like(pa)
            for j in range(s):
                total = ops.add(total, ops.mul(coefficients[row + j], k[j]))
            increment = ops.mul(sub_h, total)
            when = ops.add(start, ops.mul(nodes[s], share))
            k.append(rows.flow(ops.add(pa, increment), when))
        estimate = np.zeros_like(pa)
        for weight, kj in zip(coefficients[-STAGES:], k, strict=True):
            estimate = ops.add(estimate, ops.mul(weight, kj))
        error = np.abs(ops.mul(sub_h, estimate)).max(axis=1)
        ok = (error <= tolerance) | (level[active] == MAX_LEVEL)
        moved = active[ok]
        p[moved] = move(forces, moved, pa[ok], increment[ok])
        k_first[moved] = k[-1][ok]
        done[moved] += units[ok]
        taken[moved] += 1
        grows = (ok & (level[active] > 0) & (ops.mul(dtype(GROWTH_MARGIN), error) <= tolerance)
                 & (done[active] % (2 * units) == 0))
        level[active[grows]] -= 1
        level[active[~ok]] += 1
        retaken[active[~ok]] += 1
    if record is not None:
        record(SubstepCounts.of(taken, retaken))
    return p, k_first
