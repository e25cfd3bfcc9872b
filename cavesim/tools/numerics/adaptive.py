"""Dormand-Prince 5(4) with a step of its own per particle: the check on the fine reference.

The fine RK4 reference (reference.py) takes one fixed step; whether that step is small
enough is what this answers. An embedded pair estimates its own local error, so at
tolerances 1e-6 ... 1e-12 it brackets the true solution from a method and a step rule
independent of the reference, and it finds kinks in the field (trilinear cell faces, the
rotor model's seams) by rejecting steps there. Particles never interact, so each keeps its
own time and step; every pass steps the particles not yet at T.

Dormand & Prince (1980), J. Comput. Appl. Math. 6, table 2 (the RK5(4)7M pair, first same
as last); step control and error norm from Hairer, Norsett & Wanner, Solving ODEs I,
II.4 eqs. (4.11)-(4.13).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cavesim.core.errors import CavesimError
from cavesim.core.substeps import DP54_A, DP54_B4, DP54_B5, NEW_STAGES
from cavesim.core.twin.forces import ForceModel
from cavesim.core.twin.integrators import runge_kutta_stages

SAFETY, GROW_MAX, SHRINK_MAX = 0.9, 5.0, 0.2  # step factor limits (Hairer II.4)
INITIAL_STEP = 1e-3  # s: the controller corrects it within a few steps
MAX_PASSES = 2_000_000  # a particle whose step keeps shrinking is an error, not a hang


class AdaptiveError(CavesimError, RuntimeError):
    """The step controller could not reach the end time (a discontinuity in the flow)."""


@dataclass(frozen=True)
class AdaptiveRun:
    pos: np.ndarray  # (N, 3) float64 at the end time
    vel: np.ndarray
    accepted: np.ndarray  # (N,) steps accepted per particle
    rejected: np.ndarray  # (N,) steps rejected per particle

    @property
    def evaluations(self) -> np.ndarray:
        """Field evaluations per particle: the first stage, then NEW_STAGES per try."""
        return 1 + NEW_STAGES * (self.accepted + self.rejected)


def _stages(p, v, h, kp1, kv1, forces):
    """All seven stages of one step; h is (M, 1). Returns (kp, kv) lists."""
    return runge_kutta_stages(p, v, h, DP54_A[1:], forces, [kp1], [kv1])


def _combine(y, h, ks, weights):
    return y + h * sum(w * k for w, k in zip(weights, ks, strict=True) if w)


def dormand_prince(pos: np.ndarray, vel: np.ndarray, forces: ForceModel, end_time: float,
                   tolerance: float) -> AdaptiveRun:
    """Positions and velocities at `end_time` from (pos, vel) at 0, each particle's local
    error held to `tolerance` (absolute and relative, per component of (p, v))."""
    p, v = pos.astype(np.float64), vel.astype(np.float64)
    n = len(p)
    t, h = np.zeros(n), np.full(n, INITIAL_STEP)
    accepted, rejected = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
    kp1, kv1 = v.copy(), forces.acceleration(p, v)
    just_rejected = np.zeros(n, dtype=bool)
    active = np.arange(n)
    for _ in range(MAX_PASSES):
        if not len(active):
            return AdaptiveRun(p, v, accepted, rejected)
        step = np.minimum(h[active], end_time - t[active])
        last = step >= end_time - t[active]
        hs = step[:, None]
        pa, va, model = p[active], v[active], forces.of_rows(active)
        kp, kv = _stages(pa, va, hs, kp1[active], kv1[active], model)
        p5, v5 = _combine(pa, hs, kp, DP54_B5), _combine(va, hs, kv, DP54_B5)
        p4, v4 = _combine(pa, hs, kp, DP54_B4), _combine(va, hs, kv, DP54_B4)
        scale = tolerance * (1.0 + np.maximum(np.abs(np.hstack([pa, va])),
                                              np.abs(np.hstack([p5, v5]))))
        error = np.sqrt(np.mean((np.hstack([p5 - p4, v5 - v4]) / scale) ** 2, axis=1))
        ok = error <= 1.0
        done = active[ok]
        p[done], v[done] = p5[ok], v5[ok]
        kp1[done], kv1[done] = kp[-1][ok], kv[-1][ok]
        t[done] = np.where(last[ok], end_time, t[done] + step[ok])
        accepted[done] += 1
        rejected[active[~ok]] += 1
        with np.errstate(divide="ignore"):
            factor = np.clip(SAFETY * error ** -0.2, SHRINK_MAX, GROW_MAX)
        # no growth right after a rejection (Hairer II.4): it would be rejected again
        factor = np.where(just_rejected[active], np.minimum(factor, 1.0), factor)
        h[active] = step * factor
        just_rejected[active] = ~ok
        active = active[t[active] < end_time]
    raise AdaptiveError(f"Dormand-Prince at tolerance {tolerance:g} did not reach "
                        f"t = {end_time:g} s in {MAX_PASSES} passes ({len(active)} particles "
                        f"left, smallest step {h[active].min():.3g} s)")
