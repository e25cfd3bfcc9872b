"""The master's mixed-hardware tolerance mode: for a CAVE whose GPUs round differently, so
that their bits can never agree and the bit barrier would call every frame a divergence.

One wall is the authority. At each compared frame every node's report carries a drift sample
(`cavesim/core/drift.py`); a node whose checksum is not the authority's is measured against
the authority's sample, and one that drifted beyond the tolerances, or holds another live
count, breaches: it is named and resynced from the authority at once. Every `resync_every`
frames each node whose bits differ from the authority's is resynced from it, which also
bounds the drift of the particles no sample sees.

Both are bounded, as their samples may be wrong or forged. A breach counts against the
breach budget of either mode (`budgets.py`: past it the node is given up, not resynced
again); the periodic resyncs are one per node every `resync_every` frames. A report whose
sample is missing or of the wrong size is refused and counted per node (the first of each
node's refusals is logged): it is not compared in that frame, and never ends the run.
Without a checksum vote this is weaker than the bit-exact mode, so it is named in the log
and in report.json, with the drift per node over time, the breaches and the resyncs
(`ToleranceMode.summary`).

The rules are pure (`judge`); `ToleranceMode` keeps the record. `nodes/master/process.py`
carries out the resyncs the vote names, as for a bit-exact divergence.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass

from cavesim.core.bounded import DecimatedSeries, FirstEntries
from cavesim.core.drift import (
    DEFAULT_SAMPLE,
    MAX_SAMPLE,
    NO_DRIFT,
    Drift,
    measure_drift,
    rounded,
    sample_size,
)
from cavesim.core.wire import ReportMessage
from nodes.lockstep import Vote

log = logging.getLogger("cavesim.master")
BIT_EXACT, MIXED_HARDWARE = "bit-exact", "mixed-hardware tolerance"  # report.json's "mode"
DEFAULT_RESYNC_EVERY = 120  # frames: 2 s at 60 Hz
RESYNC_EVERY_RANGE = (1, 100_000)
# about one pixel of a 3 m wall 1,920 pixels wide (1.6 mm): a drift below it cannot show at a
# seam; over 3x the 0.61 mm that every position moved one ULP up in every frame drifted by
# between two 120-frame resyncs of the brownout demo (llvmpipe; docs/guide/mixed-hardware.md)
DEFAULT_POSITION_TOLERANCE = 2e-3  # m
# a velocity difference that carries a particle past the position tolerance in 0.2 s
DEFAULT_VELOCITY_TOLERANCE = 1e-2  # m/s
TOLERANCE_RANGE = (1e-9, 1e3)  # m and m/s
DRIFT_POINTS = 1024  # per node: the drift series is decimated beyond this many comparisons


@dataclass(frozen=True)
class Tolerance:
    """The mode's settings: `authority` (a wall), resync every `resync_every` frames,
    samples of `sample` records, tolerances in m and m/s."""

    authority: str
    resync_every: int = DEFAULT_RESYNC_EVERY
    sample: int = DEFAULT_SAMPLE
    position: float = DEFAULT_POSITION_TOLERANCE
    velocity: float = DEFAULT_VELOCITY_TOLERANCE

    def __post_init__(self) -> None:
        low, high = RESYNC_EVERY_RANGE
        if not low <= self.resync_every <= high:
            raise ValueError(f"resync_every must be in [{low}, {high}] frames, got "
                             f"{self.resync_every!r}")
        if not 1 <= self.sample <= MAX_SAMPLE:
            raise ValueError(f"sample must be in [1, {MAX_SAMPLE}] records, got "
                             f"{self.sample!r}")
        low, high = TOLERANCE_RANGE
        for name in ("position", "velocity"):
            if not low <= getattr(self, name) <= high:
                raise ValueError(f"the {name} tolerance must be in [{low}, {high}], got "
                                 f"{getattr(self, name)!r}")

    def to_json(self) -> dict:
        return {"authority": self.authority, "resync_every_frames": self.resync_every,
                "sample_records": self.sample, "position_tolerance_m": self.position,
                "velocity_tolerance_m_s": self.velocity}


@dataclass(frozen=True)
class Judgement:
    """One frame under the tolerance mode: whom to resync from `vote.source` (the acting
    authority), and why."""

    vote: Vote  # odd: breached and periodic resyncs; named: the breached
    drifts: dict[str, Drift]  # per compared node (not the authority)
    periodic: tuple[str, ...]  # due for the periodic resync: bits not the authority's
    refused: dict[str, str]  # node -> why its sample could not be compared


def acting_authority(tolerance: Tolerance, members: tuple[str, ...]) -> str:
    """The authority, or while it is out of the lock-step the first member."""
    return tolerance.authority if tolerance.authority in members else members[0]


def judge(k: int, members: tuple[str, ...], reports: Mapping[str, ReportMessage],
          tolerance: Tolerance, compare: bool = True) -> Judgement:
    """Frame k's outcome: each member's drift from the acting authority (`compare`), the
    breaches, and the periodic resyncs due at k. A report that must be compared but carries
    no sample, or one of another size than the master's --drift-sample, is refused (and
    when it is the authority's, no one is compared)."""
    authority = acting_authority(tolerance, members)
    held = reports[authority]
    others = tuple(m for m in members if m != authority)
    drifts: dict[str, Drift] = {}
    refused: dict[str, str] = {}
    if compare:
        drifts = {node: NO_DRIFT for node in others if reports[node].digest == held.digest}
        differing = [node for node in others if node not in drifts]
        if differing and (problem := sample_problem(k, held, tolerance.sample)):
            refused[authority] = problem
            differing = []
        for node in differing:
            if problem := sample_problem(k, reports[node], tolerance.sample):
                refused[node] = problem
            else:
                drifts[node] = measure_drift(reports[node].sample, reports[node].particles,
                                             held.sample, held.particles)
    breached = tuple(n for n, d in drifts.items()
                     if d.exceeds(tolerance.position, tolerance.velocity))
    due = k % tolerance.resync_every == 0
    periodic = tuple(n for n in others if due and n not in breached
                     and reports[n].digest != held.digest)
    odd = tuple(m for m in members if m in breached or m in periodic)
    return Judgement(Vote(held.digest, held.particles, authority, odd, breached), drifts,
                     periodic, refused)


def sample_problem(k: int, report: ReportMessage, size: int) -> str | None:
    """Why the report's drift sample cannot be compared (None: it is of the size the master
    expects)."""
    if report.sample is None:
        return (f"frame {k}: {report.node}'s report carries no drift sample; in the "
                f"mixed-hardware mode every node must sample its state: start it with "
                f"--mixed-hardware (cavesim node)")
    expected = sample_size(size, report.particles)
    if len(report.sample) != expected:
        return (f"frame {k}: {report.node} sampled {len(report.sample)} of its "
                f"{report.particles} live records, the master expects {expected} "
                f"(--drift-sample {size}): give the master and every node the same "
                f"--drift-sample")
    return None


@dataclass(frozen=True)
class Breach:
    frame: int
    node: str
    authority: str
    drift: Drift

    def to_json(self) -> dict:
        return {"frame": self.frame, "node": self.node, "authority": self.authority,
                **self.drift.to_json()}


class NodeDrift:
    """One node's drift from the authority at each comparison of a run of any length: a
    decimated series of (frame, drift), the exact worst of the finite values, how many
    comparisons found its bits equal to the authority's and how many could not measure a
    distance (other live counts, or a NaN)."""

    def __init__(self) -> None:
        self.series: DecimatedSeries[tuple[int, Drift]] = DecimatedSeries(DRIFT_POINTS)
        self.position_max = self.velocity_max = 0.0
        self.bit_equal = self.incomparable = 0

    def add(self, k: int, drift: Drift) -> None:
        self.series.append((k, drift))
        self.bit_equal += drift is NO_DRIFT
        if not math.isfinite(drift.position_max + drift.velocity_max):
            self.incomparable += 1
            return
        self.position_max = max(self.position_max, drift.position_max)
        self.velocity_max = max(self.velocity_max, drift.velocity_max)

    def to_json(self) -> dict:
        points = [(k, d.to_json()) for k, d in self.series]
        columns = ("position_max_m", "position_rms_m", "velocity_max_m_s", "velocity_rms_m_s")
        return {"comparisons": self.series.count, "bit_equal": self.bit_equal,
                "incomparable": self.incomparable,
                "worst": {"position_max_m": rounded(self.position_max),
                          "velocity_max_m_s": rounded(self.velocity_max)},
                "stride": self.series.stride,  # comparisons between two points
                "frames": [k for k, _ in points],
                **{column: [d[column] for _, d in points] for column in columns}}


class ToleranceMode:
    """The tolerance mode of one run: its votes, and what report.json says of them."""

    def __init__(self, tolerance: Tolerance, walls: tuple[str, ...],
                 compare_every: int = 1) -> None:
        if tolerance.authority not in walls:
            raise ValueError(f"the authority {tolerance.authority!r} is not one of the walls "
                             f"{', '.join(walls)}")
        self.tolerance = tolerance
        self.compare_every = compare_every  # frames (the master's --check-every)
        self.drift = {wall: NodeDrift() for wall in walls}
        self.breaches: FirstEntries[Breach] = FirstEntries()
        self.periodic_resyncs = 0
        self.handovers: FirstEntries[dict] = FirstEntries()  # acting authority changes
        self.refused_samples: Counter[str] = Counter()
        self._acting = tolerance.authority

    def vote(self, k: int, members: tuple[str, ...], reports: Mapping[str, ReportMessage],
             compare: bool = True) -> Vote:
        """Frame k's vote: the acting authority's state; odd, the nodes to resync from it;
        named, the breached."""
        judgement = judge(k, members, reports, self.tolerance, compare)
        for node, problem in judgement.refused.items():
            if not self.refused_samples[node]:
                log.warning("%s; refused (its later refusals are counted in report.json)",
                            problem)
            self.refused_samples[node] += 1
        authority = judgement.vote.source
        if authority != self._acting:
            log.warning("frame %d: %s acts as the authority (the authority %s is %s)", k,
                        authority, self.tolerance.authority,
                        "back" if authority == self.tolerance.authority else "out")
            self.handovers.append({"frame": k, "from": self._acting, "to": authority})
            self._acting = authority
        for node, drift in judgement.drifts.items():
            self.drift[node].add(k, drift)
        for node in judgement.vote.named:
            drift = judgement.drifts[node]
            self.breaches.append(Breach(k, node, authority, drift))
            log.warning("frame %d: %s breached the tolerance against the authority %s: "
                        "position max %.3g m (tolerance %g), velocity max %.3g m/s "
                        "(tolerance %g), live %d / %d", k, node, authority,
                        drift.position_max, self.tolerance.position, drift.velocity_max,
                        self.tolerance.velocity, drift.particles, drift.authority_particles)
        self.periodic_resyncs += len(judgement.periodic)
        return judgement.vote

    def summary(self) -> dict:
        """report.json's "tolerance": the settings, drift per node, breaches, resyncs."""
        return {**self.tolerance.to_json(),
                "compared_every_frames": self.compare_every,
                "drift": {wall: drift.to_json() for wall, drift in self.drift.items()
                          if wall != self.tolerance.authority or drift.series.count},
                "breaches": [b.to_json() for b in self.breaches],
                "breach_total": self.breaches.total,
                "periodic_resyncs": self.periodic_resyncs,
                "authority_handovers": list(self.handovers),
                "refused_samples": dict(sorted(self.refused_samples.items()))}

