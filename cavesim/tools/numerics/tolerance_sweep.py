"""How accurate the reference is: Dormand-Prince 5(4) at every tolerance of `TOLERANCES`
against it, per case.

As the tolerance falls, |DP - reference| falls with it until it meets the reference's
own error and flattens there: that plateau, plus what DP still moved between its two
tightest tolerances, bounds the reference's error. Against a closed form the sweep shows
DP's own error instead, following the tolerance: a check of the pair.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from cavesim.tools.numerics.reference import AdaptiveState, Reference
from cavesim.tools.numerics.results import Row, Summary, rms_and_max


@dataclass(frozen=True)
class SweepRow:
    case: str
    tolerance: float
    accepted: float  # mean steps per particle
    accepted_max: int  # the particle that took the most
    rejected: float  # mean rejected steps per particle
    evaluations: float  # mean field evaluations per particle
    rms: float  # m, |DP - reference| at T
    max: float
    vel_rms: float  # m/s
    vel_max: float
    to_tightest_rms: float  # m, |DP - DP at the tightest tolerance|: DP's own convergence

    def to_json(self) -> dict[str, object]:
        return asdict(self)


@dataclass(frozen=True)
class ReferenceAccuracy:
    """The reference's error, read off the tightest tolerance of the sweep."""

    case: str
    rms: float  # m, |reference - DP at the tightest tolerance|
    max: float
    vel_rms: float  # m/s
    dp_moved: float  # m, RMS |DP at the next looser tolerance - DP at the tightest|
    smallest_fitted: float  # m, the smallest float64 error any order fit of the case used

    @property
    def bound(self) -> float:
        """m: RMS error of the reference at most, if DP at the tightest tolerance is off the
        truth by no more than it moved from the next looser one (it converges with tol)."""
        return self.rms + self.dp_moved

    @property
    def margin(self) -> float:
        """How many times the smallest fitted error exceeds the reference's error bound."""
        return self.smallest_fitted / self.bound if self.bound > 0 else math.inf

    def to_json(self) -> dict[str, object]:
        return {**asdict(self), "bound": self.bound, "margin": self.margin}


def sweep_rows(case: str, reference: Reference, states: list[AdaptiveState]) -> list[SweepRow]:
    """One row per tolerance, loosest first; every state ends at the reference's time. None
    for a case that runs no sweep."""
    if not states:
        return []
    states = sorted(states, key=lambda s: -s.tolerance)
    tightest = states[-1]
    rows = []
    for s in states:
        rms, largest = rms_and_max(s.pos, reference.pos)
        vel_rms, vel_max = rms_and_max(s.vel, reference.vel)
        rows.append(SweepRow(case, s.tolerance, float(s.accepted.mean()),
                             int(s.accepted.max()), float(s.rejected.mean()),
                             float(s.evaluations.mean()), rms, largest, vel_rms, vel_max,
                             rms_and_max(s.pos, tightest.pos)[0]))
    return rows


def reference_accuracy(rows: list[SweepRow], smallest_fitted: float) -> ReferenceAccuracy:
    """The reference's error from a case's sweep rows (loosest first)."""
    tightest = rows[-1]
    return ReferenceAccuracy(tightest.case, tightest.rms, tightest.max, tightest.vel_rms,
                             rows[-2].to_tightest_rms, smallest_fitted)


def smallest_fitted_error(case: str, rows: list[Row], summaries: list[Summary]) -> float:
    """m: the smallest float64 error among the points the case's order fits used."""
    fitted = {(s.integrator, dt) for s in summaries if s.case == case for dt in s.fit_dts}
    errors = [r.twin_rms for r in rows
              if r.case == case and (r.integrator, r.dt_label) in fitted]
    return min(errors) if errors else math.nan
