"""The master: owns the clock and the randomness, and holds the cluster in lock-step.

Per frame k: draw the inputs once, publish them, wait until every member has reported k
(the barrier: on a timeout, log who is stalled and send the frame again), compare the
checksums, name the odd nodes by majority and resync them from a healthy node, admit
nodes that joined late, log the frame. Membership comes from liveliness tokens; a wall
that comes up is asked, without waiting, which GPU it computes on (for the report).
"""

from __future__ import annotations

import logging
import queue
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import zenoh

from cavesim.engine import FrameInput
from cavesim.errors import ClusterError, ProtocolError
from cavesim.framelog import FrameLogWriter
from cavesim.helicopter.flight import (
    WAND_LIMIT,
    Flight,
    clamp_wand,
    heading_of,
    pitch_quaternion,
    tilt_of,
    wand_at,
)
from cavesim.random_texture import draw_transform
from cavesim.scene import load_scene
from cavesim.wire import (
    Command,
    ControlMessage,
    FrameMessage,
    InfoMessage,
    ReportMessage,
    SessionKeys,
    TrackingMessage,
    WandState,
    decode,
    encode,
)
from cavesim.wire.messages import Status
from cavesim.wire.network import NetworkConfig
from cavesim.wire.rejects import RejectCounter
from cavesim.wire.snapshot import transfer_seconds
from nodes.clock import Clock
from nodes.master_report import RunRecord
from nodes.script import ScriptedView

log = logging.getLogger("cavesim.master")
LOSS_POLICIES = ("continue", "pause")
INFO_TIMEOUT = 10.0  # s a wall has to say which GPU it computes on
RESYNC_MARGIN = 5.0  # s beyond a snapshot's transfer: the RESYNC command, the node's report


@dataclass(frozen=True)
class MasterConfig:
    walls: tuple[str, ...]
    scene: Path
    frames: int
    session: str = "default"
    network: NetworkConfig = NetworkConfig()
    key: bytes | None = None
    dt: float = 1 / 60
    clock_seed: int = 0
    barrier_timeout: float = 2.0
    join_timeout: float = 60.0
    on_loss: str = "continue"  # drop a lost node and go on, or "pause" until it is back
    check_every: int = 1
    frame_log: Path | None = None
    realtime: bool = False  # pace frames by the wall clock (see nodes/clock.py)
    max_frame_time: float = 0.1
    max_substeps: int = 4


@dataclass
class Membership:
    members: list[str] = field(default_factory=list)  # in lock-step, in wall order
    alive: set[str] = field(default_factory=set)
    lost: set[str] = field(default_factory=set)  # lost while a member; must resync to return


class Master:
    def __init__(self, config: MasterConfig, session: zenoh.Session,
                 before_frame: Callable[[int], None] | None = None) -> None:
        self.config = config
        self.keys = SessionKeys(config.session)
        self.session = session
        self.before_frame = before_frame or (lambda k: None)
        scene = load_scene(config.scene)
        self.texture_size = scene.random_texture_size
        # a resync may take as long as the largest state the scene holds takes to stream
        self.resync_seconds = transfer_seconds(scene.capacity) + RESYNC_MARGIN
        self.flight = Flight(scene) if scene.helicopter is not None else None
        self.timeline = scene.helicopter.timeline if scene.helicopter is not None else ()
        self.matrix_rng = np.random.Generator(np.random.PCG64(config.clock_seed))
        self.events: queue.Queue = queue.Queue()
        self.reports: dict[tuple[int, str], ReportMessage] = {}
        self.last_sent: dict[str, int] = {}
        self.last_received: dict[str, int] = {}
        self.rejects = RejectCounter("master")
        self.state = Membership()
        self.clock = Clock(config.dt, config.realtime, config.max_frame_time,
                           config.max_substeps)
        self.view = ScriptedView()
        self.tracked: TrackingMessage | None = None
        self.stopping = False
        self.record = RunRecord(config.walls)

    def declare(self) -> list:
        put = self.events.put
        self.frame_publisher = self.session.declare_publisher(self.keys.frame, express=True)
        self.control_publisher = self.session.declare_publisher(self.keys.control, express=True)
        return [
            self.session.declare_subscriber(self.keys.report(), lambda s: put(("report", s))),
            self.session.declare_subscriber(self.keys.tracking, lambda s: put(("tracking", s))),
            self.session.liveliness().declare_subscriber(self.keys.alive(),
                                                         lambda s: put(("alive", s)),
                                                         history=True),
        ]

    # -- events ----------------------------------------------------------------------------

    def _pump(self, until: float) -> None:
        """Handle events until the monotonic deadline `until` (at least one wait)."""
        try:
            kind, sample = self.events.get(timeout=max(0.0, until - time.monotonic()))
        except queue.Empty:
            return
        if kind == "alive":
            self._on_alive(self.keys.node_of(sample.key_expr),
                           sample.kind == zenoh.SampleKind.PUT)
            return
        if kind == "info":  # a zenoh Reply: a sample, or the queryable's error
            if sample.ok is None:
                log.warning("an info query failed: %s", sample.err.payload.to_string())
                return
            sample = sample.ok
        try:
            message = decode(sample.payload.to_bytes(), self.config.session, self.config.key)
        except ProtocolError as e:
            self.rejects.reject(e, str(sample.key_expr))
            return
        if kind == "tracking":
            self._on_tracking(message, str(sample.key_expr))
            return
        sender = self.keys.node_of(sample.key_expr)
        expected = InfoMessage if kind == "info" else ReportMessage
        if not isinstance(message, expected) or message.node != sender \
                or sender not in self.config.walls:
            self.rejects.reject(ProtocolError("unexpected", f"{type(message).__name__} from "
                                              f"{sender!r} on a {kind} key"),
                                str(sample.key_expr))
            return
        if kind == "info":
            self.record.gpus[sender] = message.gpu()
            return
        self.reports[(message.frame, message.node)] = message
        self.last_received[message.node] = message.frame
        self.record.node_rejected[message.node] = message.rejected

    def _on_tracking(self, message, key: str) -> None:
        if isinstance(message, TrackingMessage):
            self.tracked = message  # sampled once, when the next frame is made
        else:
            self.rejects.reject(ProtocolError("unexpected", f"a {type(message).__name__} on "
                                              "the tracking key"), key)

    def _on_alive(self, node: str, alive: bool) -> None:
        if node not in self.config.walls:
            return
        if alive:
            self.state.alive.add(node)
            self.session.get(self.keys.info(node), lambda reply: self.events.put(
                ("info", reply)), timeout=INFO_TIMEOUT)  # a callback: returns at once
            return
        self.state.alive.discard(node)
        if node in self.state.members and not self.stopping:
            self.record.loss(node, max(self.last_sent.values(), default=0), "liveliness")
            log.warning("lost node %s", node)
            self.state.lost.add(node)
            if self.config.on_loss == "continue":
                self.state.members.remove(node)

    # -- the run ---------------------------------------------------------------------------

    def wait_for_walls(self) -> None:
        deadline = time.monotonic() + self.config.join_timeout
        while set(self.config.walls) - self.state.alive:
            if time.monotonic() > deadline:
                missing = sorted(set(self.config.walls) - self.state.alive)
                raise ClusterError(f"walls {missing} did not come up within "
                                   f"{self.config.join_timeout:g} s (--join-timeout); see "
                                   f"their logs")
            self._pump(deadline)
        self.state.members = list(self.config.walls)

    def run(self, progress: Callable[[int, int], None] = lambda k, live: None) -> RunRecord:
        log_writer = None
        if self.config.frame_log is not None:
            log_writer = FrameLogWriter(self.config.frame_log, {
                "session": self.config.session, "scene": str(self.config.scene),
                "walls": list(self.config.walls), "clock_seed": self.config.clock_seed})
        started = time.monotonic()
        try:
            for k in range(1, self.config.frames + 1):
                self.clock.wait_for_frame()
                self.before_frame(k)
                message = self._make_frame(k)
                latency = self._barrier(k, encode(message, self.config.session, self.config.key))
                self.record.barrier_seconds.append(latency)
                digest, live = self._agree(k)
                self._admit_joiners(k, digest)
                if log_writer is not None:
                    log_writer.append(message, digest, live)
                self.record.frames = k
                self.record.live_particles.append(live)
                progress(k, live)
        finally:
            self.record.seconds = time.monotonic() - started
            self.record.clock_dropped_seconds = self.clock.dropped_seconds
            if log_writer is not None:
                log_writer.close()
        self._record_final_agreement()
        return self.record

    def _make_frame(self, k: int) -> FrameMessage:
        """Frame k's inputs, drawn and sampled once: the clock's matrix, the tracked head
        and wand (or the script's when no tracker has spoken), the scene parameters."""
        t = k * self.config.dt
        tracked = self.tracked
        head = tracked.head if tracked else self.view.head(t)
        wand = tracked.wand if tracked else WandState()
        matrix = draw_transform(self.matrix_rng, self.texture_size)
        inputs = FrameInput(self.config.dt, matrix)
        if self.flight is None:
            return FrameMessage(k, inputs, wand, self.view.hover_params(t), head)
        if tracked:
            position, tilt = self._reachable(wand.position), tilt_of(wand.orientation)
            heading = heading_of(wand.orientation)
        else:
            position, tilt = wand_at(self.timeline, t)
            wand, heading = WandState(tuple(position), pitch_quaternion(tilt)), 0.0
        rotor = self.flight.advance(self.config.dt, position, tilt, heading)
        self.record.flight(t, rotor, self.flight)
        return FrameMessage(k, inputs, wand, rotor.to_params(), head)

    def _reachable(self, position) -> tuple[float, float, float]:
        """A tracked wand position within WAND_LIMIT of the room's origin (warned if not)."""
        clamped, changed = clamp_wand(position)
        if changed:
            self.record.clamped_inputs += 1
            log.warning("wand position %s is outside +-%g m: clamped to %s", position,
                        WAND_LIMIT, clamped)
        return clamped

    def _record_final_agreement(self) -> None:
        last = self.record.frames
        digests = {n: self.reports[(last, n)].digest for n in self.state.members
                   if (last, n) in self.reports}
        self.record.final = {"frame": last, "members": list(self.state.members),
                             "all_walls_in": set(digests) == set(self.config.walls),
                             "agree": len(set(digests.values())) == 1}

    def stop(self, wait: float = 5.0) -> None:
        """Tell every node to STOP, and wait (on liveliness) until they have left."""
        self.stopping = True
        self._control(ControlMessage(self.record.frames, Command.STOP))
        deadline = time.monotonic() + wait
        while self.state.alive and time.monotonic() < deadline:
            self._pump(deadline)

    def _publish_frame(self, k: int, data: bytes) -> None:
        self.frame_publisher.put(data)
        for node in self.state.members:
            self.last_sent[node] = k

    def _control(self, message: ControlMessage) -> None:
        self.control_publisher.put(encode(message, self.config.session, self.config.key))

    def _barrier(self, k: int, data: bytes) -> float:
        """Publish frame k and wait until every member reported it; the seconds it took."""
        sent = time.monotonic()
        self._publish_frame(k, data)
        deadline = sent + self.config.barrier_timeout
        while missing := [n for n in self.state.members if (k, n) not in self.reports]:
            if time.monotonic() < deadline:
                self._pump(deadline)
                continue
            self.record.stall(k, missing, self.last_sent, self.last_received)
            log.warning("frame %d: stalled on %s", k, ", ".join(missing))
            healthy = [n for n in self.state.members if (k, n) in self.reports]
            for node in missing:
                if healthy and node in self.state.lost and node in self.state.alive:
                    self._resync(k, node, healthy[0])
            self._publish_frame(k, data)
            deadline = time.monotonic() + self.config.barrier_timeout
        if not self.state.members:
            raise ClusterError(f"frame {k}: every wall node is gone")
        return time.monotonic() - sent

    def _agree(self, k: int) -> tuple[str, int]:
        """Compare the members' checksums of frame k; resync the odd ones. Agreed digest."""
        reports = {n: self.reports[(k, n)] for n in self.state.members}
        reference = reports[self.state.members[0]]
        if k % self.config.check_every != 0:
            return reference.digest, reference.particles
        votes = Counter(r.digest for r in reports.values())
        digest, count = votes.most_common(1)[0]
        majority = count * 2 > len(reports)
        if not majority:  # two nodes, or an even split: name all, keep the first wall's state
            digest = reference.digest
        stale = [n for n, r in reports.items() if r.digest != digest]
        if stale:
            named = stale if majority else list(reports)
            self.record.divergence(k, named, reports, digest)
            log.warning("frame %d: divergence, odd node(s): %s", k, ", ".join(named))
            source = next(n for n, r in reports.items() if r.digest == digest)
            for node in stale:
                self._resync(k, node, source)
        agreed = next(r for r in reports.values() if r.digest == digest)
        return digest, agreed.particles

    def _resync(self, k: int, node: str, source: str) -> bool:
        """Have `node` load `source`'s snapshot of frame k; wait for its RESYNCED report."""
        started = time.monotonic()
        self.reports.pop((k, node), None)
        self._control(ControlMessage(k, Command.RESYNC, node, source))
        deadline = started + self.resync_seconds
        while time.monotonic() < deadline:
            report = self.reports.get((k, node))
            if report is not None and report.status is Status.RESYNCED:
                ok = report.digest == self.reports[(k, source)].digest
                self.record.resync(k, node, source, ok, time.monotonic() - started)
                if ok:
                    self.state.lost.discard(node)
                return ok
            self._pump(deadline)
        self.record.resync(k, node, source, False, time.monotonic() - started)
        return False

    def _admit_joiners(self, k: int, digest: str) -> None:
        """Alive walls that are not members (late, or back after a loss) enter by resync."""
        for node in [n for n in self.config.walls if n in self.state.alive
                     and n not in self.state.members]:
            source = next(n for n in self.state.members if self.reports[(k, n)].digest == digest)
            if self._resync(k, node, source):
                self.state.members = [n for n in self.config.walls
                                      if n in self.state.members or n == node]
                self.record.join(k, node)


def main(config: MasterConfig, progress: Callable[[int, int], None] = lambda k, live: None,
         before_frame: Callable[[int], None] | None = None) -> RunRecord:
    """Run the cluster for `config.frames` frames and tell the nodes to stop."""
    if config.on_loss not in LOSS_POLICIES:
        raise ValueError(f"on_loss must be one of {LOSS_POLICIES}, got {config.on_loss!r}")
    with zenoh.open(config.network.zenoh_config()) as session:
        master = Master(config, session, before_frame)
        declarations = master.declare()
        try:
            master.wait_for_walls()
            master.run(progress)
        except KeyboardInterrupt:
            master.record.interrupted = True
            log.warning("interrupted at frame %d", master.record.frames)
        finally:
            master.stop()
            master.record.master_rejected = dict(master.rejects.counts)
            for declaration in reversed(declarations):
                declaration.undeclare()
    return master.record
