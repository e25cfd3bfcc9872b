"""What a cluster run records, typed: the master fills a `RunRecord` as it goes; the reports
read its events as dataclasses and `summary()` is report.json's content."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from cavesim.core.drivers import FlightSample
from cavesim.nodes.swaps import SwapBook


@dataclass(frozen=True)
class Divergence:
    frame: int
    nodes: tuple[str, ...]  # named odd (every member when there was no majority)
    agreed: str  # the checksum the cluster kept
    checksums: dict[str, str]  # every member's
    particles: dict[str, int]

    def to_json(self) -> dict:
        return {"frame": self.frame, "nodes": list(self.nodes), "agreed_checksum": self.agreed,
                "checksums": self.checksums, "particles": self.particles}


@dataclass(frozen=True)
class Resync:
    frame: int
    node: str
    source: str
    ok: bool
    seconds: float

    def to_json(self) -> dict:
        return {**asdict(self), "seconds": round(self.seconds, 4)}


@dataclass(frozen=True)
class Stall:
    frame: int
    nodes: dict[str, tuple[int, int]]  # missing node -> (last frame sent, last received)

    def to_json(self) -> dict:
        return {"frame": self.frame, "nodes": {
            n: {"last_frame_sent": sent, "last_frame_received": received}
            for n, (sent, received) in self.nodes.items()}}


@dataclass(frozen=True)
class Loss:
    frame: int
    node: str
    detected_by: str

    def to_json(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Join:
    frame: int
    node: str

    def to_json(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class FinalAgreement:
    frame: int
    members: tuple[str, ...]
    all_walls_in: bool
    agree: bool
    lost: tuple[str, ...] = ()  # walls out of the lock-step at the end: lost for good

    def to_json(self) -> dict:
        return {**asdict(self), "members": list(self.members), "lost": list(self.lost)}


@dataclass
class RunRecord:
    walls: tuple[str, ...]
    run_id: int = 0  # the master's, in every message of the run
    frames: int = 0
    interrupted: bool = False
    clamped_inputs: int = 0  # tracked wand positions pulled back into reach
    clock_dropped_seconds: float = 0.0  # real-time mode: wall time given up to hitches
    seconds: float = 0.0
    barrier_seconds: list[float] = field(default_factory=list)
    live_particles: list[int] = field(default_factory=list)
    divergences: list[Divergence] = field(default_factory=list)
    resyncs: list[Resync] = field(default_factory=list)
    stalls: list[Stall] = field(default_factory=list)
    losses: list[Loss] = field(default_factory=list)
    joins: list[Join] = field(default_factory=list)
    flight: list[FlightSample] = field(default_factory=list)  # helicopter scenes: per frame
    final: FinalAgreement | None = None  # the last frame: members and whether they agree
    node_rejected: dict[str, int] = field(default_factory=dict)
    master_rejected: dict[str, int] = field(default_factory=dict)
    master_dropped: int = 0  # events the master's full queue could not take
    gpus: dict[str, dict] = field(default_factory=dict)  # wall -> what it computes on
    swaps: SwapBook = field(default_factory=SwapBook)  # the swap barrier of displaying walls

    def agreed_at_the_end(self) -> bool:
        return self.final is not None and self.final.agree

    def summary(self) -> dict:
        """report.json's content."""
        barrier_ms = np.array(self.barrier_seconds) * 1e3
        percentile = (lambda q: round(float(np.percentile(barrier_ms, q)), 3)) \
            if len(barrier_ms) else (lambda q: None)
        return {
            "run_id": f"{self.run_id:016x}",
            "frames": self.frames,
            "interrupted": self.interrupted,
            "nodes": list(self.walls),
            "seconds": round(self.seconds, 3),
            "frames_per_second": round(self.frames / self.seconds, 2) if self.seconds else None,
            "barrier_ms": {"p50": percentile(50), "p99": percentile(99),
                           "max": percentile(100)},
            "live_particles": {"last": self.live_particles[-1] if self.live_particles else 0,
                               "max": max(self.live_particles, default=0)},
            "live_per_frame": list(self.live_particles),  # after frame 1, 2, ...
            "divergences": [d.to_json() for d in self.divergences],
            "resyncs": [r.to_json() for r in self.resyncs],
            "stalls": [s.to_json() for s in self.stalls],
            "losses": [loss.to_json() for loss in self.losses],
            "joins": [j.to_json() for j in self.joins],
            "final": self.final.to_json() if self.final is not None else {},
            "clamped_inputs": self.clamped_inputs,
            "clock_dropped_seconds": round(self.clock_dropped_seconds, 4),
            "flight": [_flight_json(f) for f in self.flight],
            "rejected_messages": {"master": self.master_rejected, "nodes": self.node_rejected},
            "master_events_dropped": self.master_dropped,
            "gpus": {wall: self.gpus[wall] for wall in self.walls if wall in self.gpus},
            "swap": self.swaps.summary(),
        }


def _flight_json(sample: FlightSample) -> dict:
    return {"t": round(sample.t, 4), "altitude": round(sample.altitude, 3),
            "rotor_speed": round(sample.rotor_speed, 4),
            "induced_velocity": round(sample.induced_velocity, 4),
            "emission_rate": round(sample.emission_rate, 1)}
