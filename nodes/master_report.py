"""What a cluster run records: the figures and events that `report.json` holds."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class RunRecord:
    walls: tuple[str, ...]
    frames: int = 0
    interrupted: bool = False
    clamped_inputs: int = 0  # tracked wand positions pulled back into reach
    clock_dropped_seconds: float = 0.0  # real-time mode: wall time given up to hitches
    seconds: float = 0.0
    barrier_seconds: list[float] = field(default_factory=list)
    live_particles: list[int] = field(default_factory=list)
    divergences: list[dict] = field(default_factory=list)
    resyncs: list[dict] = field(default_factory=list)
    stalls: list[dict] = field(default_factory=list)
    losses: list[dict] = field(default_factory=list)
    joins: list[dict] = field(default_factory=list)
    flight_log: list[dict] = field(default_factory=list)  # helicopter scenes: per frame
    final: dict = field(default_factory=dict)  # last frame: members and whether they agree
    node_rejected: dict[str, int] = field(default_factory=dict)
    master_rejected: dict[str, int] = field(default_factory=dict)
    gpus: dict[str, dict] = field(default_factory=dict)  # wall -> what it computes on

    def flight(self, t: float, rotor, flight) -> None:
        """One frame of the helicopter: time, altitude, rotor, emission rate (1/s)."""
        rates = [e.rate * f for e, f in zip(flight.followers, rotor.emission_factors,
                                             strict=True)]
        altitude = rotor.hub[2] - flight.ground - flight.helicopter.hub_height
        self.flight_log.append({"t": round(t, 4), "altitude": round(altitude, 3),
                                "rotor_speed": round(rotor.rotor_speed, 4),
                                "induced_velocity": round(rotor.induced_velocity, 4),
                                "emission_rate": round(float(sum(rates)), 1)})

    def stall(self, frame: int, missing: list[str], sent: dict, received: dict) -> None:
        self.stalls.append({"frame": frame, "nodes": {
            n: {"last_frame_sent": sent.get(n, 0), "last_frame_received": received.get(n, 0)}
            for n in missing}})

    def loss(self, node: str, frame: int, how: str) -> None:
        self.losses.append({"frame": frame, "node": node, "detected_by": how})

    def divergence(self, frame: int, nodes: list[str], reports: dict, agreed: str) -> None:
        self.divergences.append({
            "frame": frame, "nodes": nodes, "agreed_checksum": agreed,
            "checksums": {n: r.digest for n, r in reports.items()},
            "particles": {n: r.particles for n, r in reports.items()}})

    def resync(self, frame: int, node: str, source: str, ok: bool, seconds: float) -> None:
        self.resyncs.append({"frame": frame, "node": node, "source": source, "ok": ok,
                             "seconds": round(seconds, 4)})

    def join(self, frame: int, node: str) -> None:
        self.joins.append({"frame": frame, "node": node})

    def summary(self) -> dict:
        barrier_ms = np.array(self.barrier_seconds) * 1e3
        percentile = (lambda q: round(float(np.percentile(barrier_ms, q)), 3)) \
            if len(barrier_ms) else (lambda q: None)
        return {
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
            "divergences": self.divergences,
            "resyncs": self.resyncs,
            "stalls": self.stalls,
            "losses": self.losses,
            "joins": self.joins,
            "final": self.final,
            "clamped_inputs": self.clamped_inputs,
            "clock_dropped_seconds": round(self.clock_dropped_seconds, 4),
            "flight": self.flight_log,
            "rejected_messages": {"master": self.master_rejected, "nodes": self.node_rejected},
            "gpus": {wall: self.gpus[wall] for wall in self.walls if wall in self.gpus},
        }
