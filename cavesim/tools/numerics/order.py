"""Observed order of convergence: the slope of log(error) against log(dt).

The rule, the same for every case and method:
  1. keep the dts whose float64 error is above ROUND_OFF_MARGIN times the round-off that n
     float64 steps can accumulate in positions of the case's size (n eps |x|), so round-off
     bends no point by more than ~1 %;
  2. of those, fit the FIT_POINTS finest (the asymptotic range lies at small dt);
  3. least squares through log-log points; fewer than MIN_FIT_POINTS give no order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

ROUND_OFF_MARGIN = 100.0
FIT_POINTS = 4
MIN_FIT_POINTS = 3
EPS64 = float(np.finfo(np.float64).eps)


@dataclass(frozen=True)
class OrderFit:
    order: float  # NaN when too few points lie above the round-off floor
    dts: tuple[float, ...]  # the dts fitted, finest first

    @property
    def found(self) -> bool:
        return math.isfinite(self.order)


def round_off_floor(steps: int, scale: float) -> float:
    """m: what float64 round-off can accumulate over `steps` steps in positions of `scale` m."""
    return steps * EPS64 * scale


def observed_order(dts, errors, floors) -> OrderFit:
    """The order fitted by the module's rule to errors at dts (floors: per-dt round-off)."""
    above = sorted((dt, e) for dt, e, floor in zip(dts, errors, floors, strict=True)
                   if e > ROUND_OFF_MARGIN * floor)[:FIT_POINTS]
    if len(above) < MIN_FIT_POINTS:
        return OrderFit(math.nan, tuple(dt for dt, _ in above))
    log_dt, log_error = np.log([dt for dt, _ in above]), np.log([e for _, e in above])
    slope = np.polyfit(log_dt, log_error, 1)[0]
    return OrderFit(float(slope), tuple(dt for dt, _ in above))
