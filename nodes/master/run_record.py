"""What a cluster run records, typed: the master fills a `RunRecord` as it goes; the reports
read its events as dataclasses and `summary()` is report.json's content.

Its memory does not grow with the run's length (`cavesim.core.bounded`): the barrier's
round trips go into a histogram (percentiles within 0.058 %, the maximum exact), the live
counts and the flight log into series of at most 4,096 points (every frame of a run up to
4,096 frames, then every 2nd, 4th, ...: report.json names the stride), and each event list
keeps its first 1,000 entries and counts the rest.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

from cavesim.core.bounded import DecimatedSeries, FirstEntries, LogHistogram
from cavesim.core.drivers import FlightSample
from cavesim.core.frame_cost import NOT_TIMED_US, PHASES
from nodes.lockstep import UNCONFIRMED
from nodes.master.budgets import Tally
from nodes.master.counter_book import CounterBook
from nodes.master.stragglers import Lag
from nodes.master.swaps import SwapBook
from nodes.master.tolerance import BIT_EXACT, MIXED_HARDWARE, ToleranceMode

RENDER = PHASES.index("render")

EVENT_LISTS = ("divergences", "resyncs", "stalls", "lags", "losses", "joins", "user_actions")


@dataclass(frozen=True)
class Divergence:
    frame: int
    nodes: tuple[str, ...]  # named odd (every member when there was no majority)
    agreed: str  # the checksum the cluster kept
    checksums: dict[str, str]  # every member's
    particles: dict[str, int]
    forensics: dict | None = None  # its report's file (in the run's folder) and summary line
    # per node whose counts differed: per counter, its values and the agreed ones
    counters: dict[str, dict[str, dict]] | None = None

    def to_json(self) -> dict:
        return {"frame": self.frame, "nodes": list(self.nodes), "agreed_checksum": self.agreed,
                "checksums": self.checksums, "particles": self.particles,
                **({"forensics": self.forensics} if self.forensics else {}),
                **({"counters": self.counters} if self.counters else {})}


@dataclass(frozen=True)
class Resync:
    frame: int
    node: str
    source: str
    ok: bool
    seconds: float
    confirmer: str | None = None  # the second wall holding the state (None: there was none)

    @property
    def confirmation(self) -> str | None:
        """Who confirmed the state the node committed (None: it committed none)."""
        if not self.ok:
            return None
        return UNCONFIRMED if self.confirmer is None else f"confirmed by {self.confirmer}"

    def to_json(self) -> dict:
        return {**asdict(self), "seconds": round(self.seconds, 4),
                "confirmation": self.confirmation}


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
class UserAction:
    """A session control that took effect at `frame`, and who sent it."""

    frame: int
    action: str  # "pause", "resume", "reset" or "stop"
    by: str | None = None  # the sender's identity ("operator preview"); None: no keys

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


class LiveCounts(DecimatedSeries[int]):
    """Live particles after each frame: a decimated series, with the exact maximum (and,
    as every series, the exact last count)."""

    def __init__(self) -> None:
        super().__init__()
        self.max = 0

    def append(self, live: int) -> None:
        super().append(live)
        self.max = max(self.max, live)


class FrameCosts:
    """Per node, a histogram of each of its frame's phases (FRAME_PHASES), from the times its
    reports carry (a GPU phase of a frame not timed, NOT_TIMED_US, is left out); and one of
    its render phase over the frames it drew alone (a frame not drawn carries 0 there: a node
    that draws every 10th frame has a render p50 of 0 over all its frames)."""

    def __init__(self) -> None:
        self._walls: dict[str, tuple[LogHistogram, ...]] = {}
        self._drawn: dict[str, LogHistogram] = {}

    def add(self, wall: str, cost_us: tuple[int, ...]) -> None:
        histograms = self._walls.setdefault(wall, tuple(LogHistogram() for _ in PHASES))
        for histogram, us in zip(histograms, cost_us, strict=True):
            if us != NOT_TIMED_US:
                histogram.append(us * 1e-6)
        drawn = self._drawn.setdefault(wall, LogHistogram())
        if cost_us[RENDER] not in (0, NOT_TIMED_US):
            drawn.append(cost_us[RENDER] * 1e-6)

    def render_per_wall(self, node_walls: dict[str, tuple[str, ...]]) -> dict:
        """Per node: the walls it draws, how many of its frames drew them, and p50, p99 and
        max ms of drawing one wall over those frames (its render phase shared evenly among
        the walls it draws; None where it drew none)."""
        out = {}
        for node, histogram in self._drawn.items():
            walls = node_walls.get(node, (node,))
            ms = {q: None if v is None else round(v / len(walls), 3)
                  for q, v in histogram.percentiles_ms().items()}
            out[node] = {"walls": list(walls), "drawn_frames": histogram.count, **ms}
        return out

    def count(self, wall: str) -> int:
        """How many of `wall`'s frames were timed (on the CPU)."""
        return self._walls[wall][0].count if wall in self._walls else 0

    def to_json(self) -> dict:
        """Per wall and phase: p50, p99 and max in milliseconds."""
        return {wall: {phase: histogram.percentiles_ms()
                       for phase, histogram in zip(PHASES, histograms, strict=True)}
                for wall, histograms in self._walls.items()}


@dataclass
class RunRecord:
    walls: tuple[str, ...]
    run_id: int = 0  # the master's, in every message of the run
    frames: int = 0
    interrupted: bool = False
    signal: str | None = None  # the stopping signal that interrupted it, e.g. "SIGTERM"
    user_stopped: bool = False  # an operator's stop ended the run (the preview's Esc)
    paused_frames: int = 0  # frames the user held (dt 0)
    clamped_inputs: int = 0  # tracked wand positions pulled back into reach
    clock_dropped_seconds: float = 0.0  # real-time mode: wall time given up to hitches
    seconds: float = 0.0
    barrier_seconds: LogHistogram = field(default_factory=LogHistogram)  # one per frame
    frame_cost: FrameCosts = field(default_factory=FrameCosts)  # the walls' stepped frames
    live_particles: LiveCounts = field(default_factory=LiveCounts)  # after each frame
    divergences: FirstEntries[Divergence] = field(default_factory=FirstEntries)
    resyncs: FirstEntries[Resync] = field(default_factory=FirstEntries)
    stalls: FirstEntries[Stall] = field(default_factory=FirstEntries)
    lags: FirstEntries[Lag] = field(default_factory=FirstEntries)  # members that held the
    # barrier past --max-lag
    losses: FirstEntries[Loss] = field(default_factory=FirstEntries)
    joins: FirstEntries[Join] = field(default_factory=FirstEntries)
    user_actions: FirstEntries[UserAction] = field(default_factory=FirstEntries)
    # helicopter scenes: one per frame made (an interrupted run makes one more than it does)
    flight: DecimatedSeries[FlightSample] = field(default_factory=DecimatedSeries)
    final: FinalAgreement | None = None  # the last frame: members and whether they agree
    node_rejected: dict[str, int] = field(default_factory=dict)
    master_rejected: dict[str, int] = field(default_factory=dict)
    master_dropped: int = 0  # events the master's full queue could not take
    gpus: dict[str, dict] = field(default_factory=dict)  # wall -> what it computes on
    swaps: SwapBook = field(default_factory=SwapBook)  # the swap barrier of displaying walls
    tolerance: ToleranceMode | None = None  # the mixed-hardware mode's (None: bit-exact)
    arithmetic: str = "native"  # the scene's [simulation] arithmetic: "portable" is the same
    # bits on every GPU, "native" only on identical ones
    node_walls: dict[str, tuple[str, ...]] = field(default_factory=dict)  # as MasterConfig's
    capacity: int = 0  # the scene's particles at most
    counters: CounterBook | None = None  # the run's counters, as the walls agreed on them
    max_lag: float | None = None  # s: the master's --max-lag
    budgets: tuple[Tally, ...] = ()  # the breach and lag budgets, and whom they gave up

    def frame_done(self, k: int, barrier_seconds: float, live: int) -> None:
        """Frame k (the next one) went through the barrier in `barrier_seconds` and the
        vote, leaving `live` particles."""
        if k != self.live_particles.count + 1:
            raise ValueError(f"frames are done in order: expected frame "
                             f"{self.live_particles.count + 1}, got {k=}")
        self.barrier_seconds.append(barrier_seconds)
        self.live_particles.append(live)
        self.frames = k

    def add_flight(self, sample: FlightSample) -> None:
        """The helicopter's state of the frame just made."""
        self.flight.append(sample)

    def agreed_at_the_end(self) -> bool:
        return self.final is not None and self.final.agree

    def summary(self) -> dict:
        """report.json's content."""
        return {
            "run_id": f"{self.run_id:016x}",
            "mode": BIT_EXACT if self.tolerance is None else MIXED_HARDWARE,
            "arithmetic": self.arithmetic,
            "capacity": self.capacity,
            "frames": self.frames,
            "interrupted": self.interrupted,
            "signal": self.signal,
            "user_stopped": self.user_stopped,
            "paused_frames": self.paused_frames,
            "nodes": list(self.walls),
            "walls_of_nodes": {node: list(self.node_walls.get(node, (node,)))
                               for node in self.walls},
            "seconds": round(self.seconds, 3),
            "frames_per_second": round(self.frames / self.seconds, 2) if self.seconds else None,
            "barrier_ms": self.barrier_seconds.percentiles_ms(),
            "frame_cost_ms": self.frame_cost.to_json(),
            # the render phase over the frames each node drew, per wall it draws
            "render_ms_per_wall": self.frame_cost.render_per_wall(self.node_walls),
            "live_particles": {"last": self.live_particles.last or 0,
                               "max": self.live_particles.max},
            # after frames s, 2 s, 3 s, ... for the stride s (1 up to 4,096 frames)
            "live_per_frame": list(self.live_particles),
            "live_frames_stride": self.live_particles.stride,
            **{name: [event.to_json() for event in getattr(self, name)]
               for name in EVENT_LISTS},  # the first 1,000 of each
            "event_totals": {name: getattr(self, name).total for name in EVENT_LISTS},
            "final": self.final.to_json() if self.final is not None else {},
            "clamped_inputs": self.clamped_inputs,
            "clock_dropped_seconds": round(self.clock_dropped_seconds, 4),
            "flight": [_flight_json(f) for f in self.flight],  # frames s, 2 s, ... as above
            "flight_frames_stride": self.flight.stride,
            "rejected_messages": {"master": self.master_rejected, "nodes": self.node_rejected},
            "master_events_dropped": self.master_dropped,
            "gpus": {wall: self.gpus[wall] for wall in self.walls if wall in self.gpus},
            "swap": self.swaps.summary(),
            "max_lag_seconds": self.max_lag,
            "budgets": {tally.name: tally.summary() for tally in self.budgets},
            **({} if self.tolerance is None else {"tolerance": self.tolerance.summary()}),
            "counters": {} if self.counters is None else self.counters.summary(),
        }


def _flight_json(sample: FlightSample) -> dict:
    return {"t": round(sample.t, 4), "altitude": round(sample.altitude, 3),
            "rotor_speed": round(sample.rotor_speed, 4),
            "induced_velocity": round(sample.induced_velocity, 4),
            "emission_rate": round(sample.emission_rate, 1)}
