"""The master: owns the clock and the randomness, and holds the cluster in lock-step.

A run has an id (the link's, drawn when it starts). A wall enters it in three steps: its
liveliness token appears, the master asks for its info (GPU, swap lock, a fresh nonce),
and the master's WELCOME naming that nonce makes the node start this run from the
scene's start state and report JOINED; an old WELCOME cannot be replayed (the nonce is
used up). Per frame k: draw the inputs once (the clock's matrix, the tracked or scripted
head, the scene driver's state), publish them, wait until every member has reported k
(the barrier: on a timeout, record who is stalled and send the frame again; a member
silent past `evict_after` is evicted under --on-loss continue, or the run ends once it
has been silent `max_pause` under --on-loss pause), vote on the checksums, find out what
differs in each odd node's state (desync forensics, `nodes/master/forensics.py`: it and a
healthy node are asked for their checksum trees and the differing records; the result goes
to divergences/frame_<k>.json and the log), resync the odd nodes from a healthy one (a
node whose resyncs fail MAX_RESYNC_FAILURES times in a row is given up), admit walls that
joined or fell behind, log the frame. Only frame k's reports are kept. It takes typed
events from a link (Zenoh in a real run, memory in the tests) and leaves the rules to
`nodes/lockstep.py`; it needs no GL.

One master per session: a master that finds another's liveliness token before its first
frame refuses to start; one already running keeps its run and counts the other
(`other-master`), whose WELCOME its nodes refuse.

In the mixed-hardware mode the vote is each member's drift from an authority instead of its
checksum (`nodes/master/tolerance.py`), and no forensics run: every wall's bits differ.
"""

from __future__ import annotations

import logging
import queue
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Protocol

import numpy as np

from cavesim.core.clock import Clock
from cavesim.core.counters import BY_ID, widths
from cavesim.core.drivers import DriverStep, driver_for
from cavesim.core.errors import ClusterError, ProtocolError
from cavesim.core.frame import FrameInput
from cavesim.core.framelog import FrameLogWriter
from cavesim.core.random_texture import draw_transform
from cavesim.core.scene import load_scene
from cavesim.core.scene.digest import scene_digest
from cavesim.core.tracking.scripted_head import ScriptedHead
from cavesim.core.wire import (
    BlockReply,
    BlockRequest,
    Command,
    ControlMessage,
    Credentials,
    FrameMessage,
    InfoMessage,
    ReportMessage,
    TrackingMessage,
    WandState,
)
from cavesim.core.wire.network import NetworkSettings
from cavesim.core.wire.payloads.from_nodes import Status
from cavesim.core.wire.payloads.poses import MAX_TRACKING_AGE
from cavesim.core.wire.rejects import RejectCounter
from cavesim.core.wire.snapshot import transfer_seconds
from nodes import lockstep
from nodes.lockstep import LOSS_POLICIES, Membership, Vote
from nodes.master.counter_book import AGREED, AUTHORITY, CounterBook
from nodes.master.engine_choice import EngineChoice
from nodes.master.events import (
    Described,
    Displayed,
    Event,
    OtherMaster,
    ProcessEnded,
    Reported,
    WallDown,
    WallUp,
)
from nodes.master.forensics import (
    ForensicsError,
    Side,
    failed_report,
    investigate,
    write_report,
)
from nodes.master.run_record import (
    Divergence,
    FinalAgreement,
    Join,
    Loss,
    Resync,
    RunRecord,
    Stall,
    UserAction,
)
from nodes.master.tolerance import Tolerance, ToleranceMode
from nodes.master.user_requests import Asked, UserRequests

log = logging.getLogger("cavesim.master")
RESYNC_MARGIN = 5.0  # s beyond a snapshot's transfer: the RESYNC command, the node's report
STOP_WAIT = 5.0  # s for the nodes to leave after STOP
INFO_RETRY = 2.0  # s before a wall that is up but has not joined is asked again
MAX_RESYNC_FAILURES = 3  # in a row: then the wall is given up until its node joins anew
GONE_GRACE = 1.0  # s to hear why, when every member is gone at once


@dataclass(frozen=True)
class MasterConfig:
    walls: tuple[str, ...]  # the members: one node each, named after its wall or its own
    scene: Path
    frames: int
    session: str = "default"
    network: NetworkSettings = NetworkSettings()
    credentials: Credentials | None = None  # master.key: signs frames and commands
    dt: float = 1 / 60
    clock_seed: int = 0
    barrier_timeout: float = 2.0
    join_timeout: float = 60.0
    on_loss: str = "continue"  # drop a lost node and go on, or "pause" until it is back
    evict_after: float = 10.0  # s a member may stay silent in the barrier (continue)
    max_pause: float = 300.0  # s the barrier holds for a silent member (pause)
    check_every: int = 1
    tolerance: Tolerance | None = None  # mixed hardware: drift from an authority, not bits
    frame_log: Path | None = None
    forensics: Path | None = None  # the run's folder: divergences/frame_<k>.json go there
    realtime: bool = False  # pace frames by the wall clock (see cavesim/core/clock.py)
    max_frame_time: float = 0.1
    max_substeps: int = 4
    node_walls: Mapping[str, tuple[str, ...]] = field(default_factory=dict)  # a node's walls,
    # for the report, where it draws others than the one named after it


class Link(Protocol):
    """The master's side of the wire (`nodes/master/link.py`, or a test's memory)."""

    events: queue.Queue[Event]
    run_id: int
    rejects: RejectCounter  # the messages it refused, by reason
    dropped: int  # events its full queue could not take
    tracking: TrackingMessage | None  # the latest tracker message with a pose
    controller: TrackingMessage | None  # the latest with session controls (a preview's)

    def send(self, message: FrameMessage | ControlMessage) -> None: ...

    def ask_info(self, wall: str) -> None: ...

    def sender_hint(self, wall: str) -> str | None: ...

    def ask_blocks(self, wall: str, request: BlockRequest) -> BlockReply | None:
        """`wall`'s checked reply to a block request (None: refused, or none in time)."""


class Master:
    def __init__(self, config: MasterConfig, link: Link,
                 before_frame: Callable[[int], None] | None = None) -> None:
        if config.on_loss not in LOSS_POLICIES:
            raise ValueError(f"on_loss must be one of {LOSS_POLICIES}, got {config.on_loss!r}")
        self.config = config
        self.link = link
        self.before_frame = before_frame or (lambda k: None)
        self.scene = scene = load_scene(config.scene)
        self.scene_digest = scene_digest(scene)  # every wall must hold this scene
        self.texture_size = scene.random_texture_size
        self.driver = driver_for(scene)
        # a resync may take as long as the largest state the scene holds takes to stream
        self.resync_seconds = transfer_seconds(scene.capacity) + RESYNC_MARGIN
        self.matrix_rng = np.random.Generator(np.random.PCG64(config.clock_seed))
        self.frame = 0  # the frame in flight
        self.reports: dict[str, ReportMessage] = {}  # wall -> its report of `frame`
        self.last_sent: dict[str, int] = {}
        self.last_received: dict[str, int] = {}
        self.membership = Membership(config.walls)
        self.clock = Clock(config.dt, config.realtime, config.max_frame_time,
                           config.max_substeps)
        self.head = ScriptedHead()
        self.requests = UserRequests()  # the preview's pause, reset and quit
        self.paused = False
        self.steps = 0  # of simulation time since the start or the last reset
        self.last_step: DriverStep | None = None  # the scene's state a paused frame holds
        self.tracking_quiet = False  # the latest tracking message is older than allowed
        self.stopping = False
        self.refused = False  # another master was there first: the nodes are its own
        self.engines = EngineChoice(config.walls)  # the path of the nodes that probed theirs
        self.counter_widths = widths(scene)  # the counters this run's walls report
        self.record = RunRecord(config.walls, arithmetic=scene.arithmetic.value,
                                node_walls=dict(config.node_walls), capacity=scene.capacity,
                                counters=CounterBook(scene, config.dt, AGREED if
                                                     config.tolerance is None else AUTHORITY))
        self.record.run_id = link.run_id
        self.swap_locked: dict[str, bool] = {}  # per wall, from its info answer
        self.swaps = self.record.swaps
        self.up: set[str] = set()  # walls whose liveliness token is there
        self.asked: dict[str, float] = {}  # wall -> when its info was last asked for
        self.resync_failures: dict[str, int] = {}  # wall -> failed resyncs in a row
        self.wrong_scene: dict[str, str] = {}  # wall -> the line refusing its other scene
        self.tolerance = None if config.tolerance is None else ToleranceMode(
            config.tolerance, config.walls, config.check_every)
        self.record.tolerance = self.tolerance

    # -- events ----------------------------------------------------------------------------

    def _pump(self, until: float) -> None:
        """Handle the next event, waiting for one until the monotonic deadline `until`."""
        try:
            event = self.link.events.get(timeout=max(0.0, until - time.monotonic()))
        except queue.Empty:
            return
        self._handle(event)

    def _handle(self, event: Event) -> None:
        match event:
            case Reported(report) if report.status is Status.JOINED:
                if report.node in self.wrong_scene:
                    return  # it holds another scene: it cannot be in this run
                self.membership = self.membership.came_up(report.node)
                log.info("%s joined run %016x", report.node, self.link.run_id)
            case Reported(report) if report.status is Status.BEHIND:
                self.membership = self.membership.fell_behind(report.node)
            case Reported(report):
                if report.frame == self.frame:
                    self.reports[report.node] = report
                if report.status is Status.STEPPED:
                    self.record.frame_cost.add(report.node, report.cost_us)
                self.last_received[report.node] = max(report.frame,
                                                      self.last_received.get(report.node, 0))
                self.record.node_rejected[report.node] = report.rejected
            case Described(info):
                self._welcome(info)
            case Displayed(message):
                self.swaps.note(message)
            case WallUp(wall):
                self.up.add(wall)
                self._ask_info(wall)
            case WallDown(wall) if not self.stopping:
                self.up.discard(wall)
                self.membership, lost = self.membership.went_down(wall, self.config.on_loss)
                if lost:
                    self.record.losses.append(Loss(max(self.last_sent.values(), default=0),
                                                   wall, "liveliness"))
                    log.warning("lost node %s", wall)
            case WallDown(wall):
                self.up.discard(wall)
                self.membership, _ = self.membership.went_down(wall, self.config.on_loss)
            case OtherMaster(run_id, key):
                self._other_master(run_id, key)
            case ProcessEnded(_, code, failure) if code != 0 and not self.stopping:
                raise ClusterError(failure)

    def _other_master(self, run_id: int, key: str) -> None:
        """One master per session: before its first frame, this master refuses to start
        beside another (ClusterError); once running, it keeps its run (its nodes refuse the
        other's WELCOME while it is alive) and counts the other."""
        ours, session = self.link.run_id, self.config.session
        if self.frame == 0:
            self.refused = True
            raise ClusterError(f"another master's run {run_id:016x} is on session {session}: "
                               f"refusing to start run {ours:016x}; stop that master first")
        self.link.rejects.reject(ProtocolError(
            "other-master", f"another master's run {run_id:016x} came on session {session}; "
            f"keeping run {ours:016x}, whose nodes refuse the other"), key)

    def _ask_info(self, wall: str) -> None:
        self.asked[wall] = time.monotonic()
        self.link.ask_info(wall)  # the answer comes as an event

    def _ask_again(self) -> None:
        """Walls that are up but have not joined: ask again (a lost query, a slow start)."""
        now = time.monotonic()
        for wall in self.up - self.membership.alive:
            if now - self.asked.get(wall, 0.0) >= INFO_RETRY:
                self._ask_info(wall)

    def _welcome(self, info: InfoMessage) -> None:
        """A wall described itself: note its GPU and swap lock, and welcome it into the run
        with its own nonce and the run's scene (it then starts this run and reports JOINED;
        a wall of another scene is refused here, and refuses the WELCOME); a node that
        probed its engine path waits for the run's (`engine_choice.py`)."""
        self.swap_locked[info.node] = info.swap_locked
        if info.scene != self.scene_digest:
            refusal = (f"wall {info.node} holds scene {info.scene or 'none'}, this run's "
                       f"scene {self.config.scene} is {self.scene_digest}: give every host "
                       f"the same scene file")
            if self.wrong_scene.get(info.node) != refusal:
                log.error("master: %s", refusal)
            self.wrong_scene[info.node] = refusal
        else:
            self.wrong_scene.pop(info.node, None)
        for ready in self.engines.described(info, started=self.frame > 0):
            engine = self.engines.welcome_engine(ready)
            self.record.gpus[ready.node] = ready.gpu() | (
                {} if engine is None else {"engine": engine.value})
            self.link.send(ControlMessage(self.frame, Command.WELCOME, ready.node,
                                          digest=self.scene_digest, nonce=ready.nonce,
                                          engine=engine))

    # -- the run ---------------------------------------------------------------------------

    def wait_for_walls(self) -> None:
        """Until every wall has joined this run and said whether it is swap-locked (the
        swap barrier needs to know from frame 1)."""
        deadline = time.monotonic() + self.config.join_timeout
        while missing := sorted((set(self.config.walls) - self.membership.alive)
                                | (set(self.config.walls) - set(self.swap_locked))):
            if time.monotonic() > deadline:
                hints = [hint for wall in missing if (hint := self.wrong_scene.get(wall)
                                                      or self.link.sender_hint(wall))]
                raise ClusterError(f"walls {missing} did not join within "
                                   f"{self.config.join_timeout:g} s (--join-timeout): "
                                   + ("; ".join(hints) if hints else
                                      "are their nodes running with this --session? See "
                                      "their logs"))
            self._ask_again()
            self._pump(min(deadline, time.monotonic() + INFO_RETRY))
        self.membership = self.membership.started()

    def run(self, progress: Callable[[int, int], None] = lambda k, live: None,
            checkpoint: Callable[[RunRecord], None] = lambda record: None) -> RunRecord:
        log_writer = None
        if self.config.frame_log is not None:
            log_writer = FrameLogWriter(self.config.frame_log, {
                "session": self.config.session, "scene": str(self.config.scene),
                "scene_digest": self.scene_digest,
                "walls": list(self.config.walls), "clock_seed": self.config.clock_seed,
                "frames": self.config.frames, "dt": self.config.dt})
        started = time.monotonic()
        try:
            for k in range(1, self.config.frames + 1):
                self.clock.wait_for_frame()
                self.before_frame(k)
                asked = self.requests.take(self.link.controller)
                if asked.quit:
                    self.record.user_stopped = True
                    log.info("the user asked the run to end, after frame %d", k - 1)
                    break
                message = self._make_frame(k, asked)
                barrier = self._barrier(k, message)
                vote = self._agree(k)
                self.record.counters.add(k, vote.counts.agreed, vote.counts.unagreed)
                self._admit_joiners(k, vote)
                self._release_swap(k)
                if log_writer is not None:
                    log_writer.append(message, vote.agreed, vote.particles)
                self.record.frame_done(k, barrier, vote.particles)
                progress(k, vote.particles)
                self.record.seconds = time.monotonic() - started
                checkpoint(self.record)
        finally:
            self.record.seconds = time.monotonic() - started
            self.record.clock_dropped_seconds = self.clock.dropped_seconds
            if log_writer is not None:
                log_writer.close()
        self._record_final_agreement()
        return self.record

    def _make_frame(self, k: int, asked: Asked) -> FrameMessage:
        """Frame k's inputs, drawn and sampled once: the clock's matrix, the tracked head
        (or the script's when no tracker has spoken), and the scene driver's state.

        A reset starts the scene over: a new driver at simulation time 0, and the frame
        tells every node to go back to the start state before it steps (its step is the
        scene's first, also in a pause, which then holds that state). A paused frame holds
        simulation time: dt is 0, which leaves every particle where it is and emits none,
        and the scene's state is the last frame's; the frame still goes through the
        barrier, so the checksums keep proving the walls equal, the head still moves, and
        the frame log keeps one record per frame."""
        if asked.reset:
            self.driver, self.steps = driver_for(self.scene), 0
            self.record.user_actions.append(UserAction(k, "reset"))
            log.info("frame %d: the user reset the scene", k)
        paused = asked.paused and self.last_step is not None  # a pause holds a state made
        if paused != self.paused:
            self.paused = paused
            self.record.user_actions.append(UserAction(k, "pause" if paused else "resume"))
        tracked = self._tracked()
        if paused and not asked.reset:
            self.record.paused_frames += 1
            step, dt = self.last_step, 0.0
        else:
            self.steps += 1
            step, dt = self.driver.advance(self.steps * self.config.dt, self.config.dt,
                                           tracked.wand if tracked else None), self.config.dt
            self.record.clamped_inputs += step.clamped
            self.last_step = step
        if step.flight is not None:
            self.record.add_flight(step.flight)
        inputs = FrameInput(dt, draw_transform(self.matrix_rng, self.texture_size))
        head = tracked.head if tracked else self.head.at(self.steps * self.config.dt)
        return FrameMessage(k, inputs, step.wand, self.driver.encode(step.frame), head,
                            asked.reset)

    def _tracked(self) -> TrackingMessage | None:
        """The latest tracking message, or None before any. One sent longer ago than
        MAX_TRACKING_AGE (the tracker went quiet) keeps its head but releases the wand:
        no button stays pressed and no stick stays pushed after the tracker stops."""
        tracked = self.link.tracking
        if tracked is None:
            return None
        quiet = time.time() - tracked.sent_ns / 1e9 > MAX_TRACKING_AGE
        if quiet != self.tracking_quiet:
            self.tracking_quiet = quiet
            if quiet:
                log.warning("tracking went quiet (nothing for %.0f s): the head holds its "
                            "last pose, the wand is released", MAX_TRACKING_AGE)
            else:
                log.info("tracking is back")
        return replace(tracked, wand=WandState()) if quiet else tracked

    def _record_final_agreement(self) -> None:
        last = self.record.frames
        reports = self.reports if self.frame == last else {}
        members = self.membership.members
        digests = {n: reports[n].digest for n in members if n in reports}
        self.record.final = FinalAgreement(last, members,
                                           set(digests) == set(self.config.walls),
                                           len(set(digests.values())) == 1,
                                           tuple(w for w in self.config.walls
                                                 if w not in members))

    def stop(self, wait: float = STOP_WAIT) -> None:
        """Tell every node to STOP, and wait (on liveliness) until they have left (a master
        refused beside another says nothing). The STOP names the newest frame sent (a node
        refuses a command older than that as a replay), which is one past the last done
        when the run was interrupted in a barrier."""
        self.stopping = True
        if self.refused:
            return  # not a word to the other master's nodes
        self.link.send(ControlMessage(self.frame, Command.STOP))
        deadline = time.monotonic() + wait
        while self.membership.alive and time.monotonic() < deadline:
            self._pump(deadline)

    def _send_frame(self, k: int, message: FrameMessage) -> None:
        self.link.send(message)
        for node in self.membership.members:
            self.last_sent[node] = k

    def _barrier(self, k: int, message: FrameMessage) -> float:
        """Publish frame k and wait until every member reported it; the seconds it took.
        A member silent past the limits is evicted (continue) or ends the run (pause)."""
        self.frame, self.reports = k, {}
        sent = time.monotonic()
        self._send_frame(k, message)
        deadline = sent + self.config.barrier_timeout
        while missing := lockstep.missing(self.membership.members, self.reports):
            if time.monotonic() < deadline:
                self._pump(deadline)
                continue
            self.record.stalls.append(Stall(k, {
                n: (self.last_sent.get(n, 0), self.last_received.get(n, 0)) for n in missing}))
            log.warning("frame %d: stalled on %s", k, ", ".join(missing))
            for node, source in lockstep.stall_resyncs(self.membership, self.reports):
                self._resync(k, node, source)
            self._hold_or_evict(k, time.monotonic() - sent)
            self._send_frame(k, message)
            deadline = time.monotonic() + self.config.barrier_timeout
        if not self.membership.members:
            self._say_why_all_are_gone(k)
        return time.monotonic() - sent

    def _say_why_all_are_gone(self, k: int) -> None:
        """Every member left: give a node process that failed the moment it takes its
        watcher to say so (its own error line is the one to tell), then end the run."""
        deadline = time.monotonic() + GONE_GRACE
        while time.monotonic() < deadline:
            self._pump(deadline)  # a failed process's ProcessEnded raises its line
        raise ClusterError(f"frame {k}: every wall node is gone")

    def _hold_or_evict(self, k: int, silent: float) -> None:
        """The members still missing have been silent `silent` seconds in frame k."""
        missing = lockstep.missing(self.membership.members, self.reports)
        if self.config.on_loss == "pause":
            if silent >= self.config.max_pause:
                raise ClusterError(f"frame {k}: {', '.join(missing)} silent for {silent:.0f} s "
                                   f"under --on-loss pause (--max-pause "
                                   f"{self.config.max_pause:g} s): the run ends")
            return
        if silent < self.config.evict_after:
            return
        for node in missing:
            self.membership = self.membership.evicted(node)
            self.record.losses.append(Loss(k, node, "barrier"))
            log.warning("frame %d: evicted %s, silent for %.1f s (--evict-after)", k, node,
                        silent)

    def _agree(self, k: int) -> Vote:
        """Vote on the members' checksums of frame k and on their counters (in the
        mixed-hardware mode: their drift from the authority, whose counters are kept) and
        resync the odd ones."""
        members, reports, counted = self.membership.members, self.reports, self.counter_widths
        compare = k % self.config.check_every == 0
        self.record.counters.skip(lockstep.skipped_counters(members, reports, counted))
        if self.tolerance is None:
            vote = lockstep.vote(members, reports, compare, counted)
        else:
            vote = self.tolerance.vote(k, members, reports, compare)
            vote = replace(vote, counts=lockstep.reported_counts(reports[vote.source], counted))
        if vote.named:
            log.warning("frame %d: divergence, odd node(s): %s", k, ", ".join(vote.named))
            disputes = self._disputed_counts(k, vote)
            forensics = self._investigate(k, vote) if self.tolerance is None else None
            self.record.divergences.append(Divergence(
                k, vote.named, vote.agreed, {n: reports[n].digest for n in members},
                {n: reports[n].particles for n in members}, forensics, disputes))
        for node in vote.odd:  # the tolerance mode's periodic resyncs name no one
            self._resync(k, node, vote.source, vote.agreed)
        for node in () if self.tolerance is None else self.tolerance.over_budget:
            self._give_up(k, node, "breach-budget")
        return vote

    def _disputed_counts(self, k: int, vote: Vote) -> dict[str, dict[str, dict]] | None:
        """Each node whose counters differ from the agreed ones: a line in the log, and per
        counter both values for the divergence record (None: no counter was disputed)."""
        disputed: dict[str, dict[str, dict]] = {}
        for dispute in vote.counts.disputes:
            name = BY_ID[dispute.counter].name
            log.warning("frame %d: %s counted %s %s, the agreed count is %s", k, dispute.node,
                        name, list(dispute.values), list(dispute.agreed))
            disputed.setdefault(dispute.node, {})[name] = {"values": list(dispute.values),
                                                           "agreed": list(dispute.agreed)}
        return disputed or None

    def _investigate(self, k: int, vote: Vote) -> dict | None:
        """What differs between each odd node's state and the agreed one (before the resync
        replaces it): divergences/frame_<k>.json, a line in the log; the file and the
        first odd node's line for the record. None without a folder for the reports, or
        when every odd node holds the agreed state (its counts differed)."""
        odd = [node for node in vote.odd if self.reports[node].digest != vote.agreed]
        if self.config.forensics is None or not odd:
            return None
        reference = Side(vote.source, vote.agreed)
        found, started = [], time.monotonic()
        for node in odd:
            odd = Side(node, self.reports[node].digest)
            try:
                report = investigate(k, odd, reference, self.link.ask_blocks)
            except ForensicsError as e:
                report = failed_report(k, odd, reference, str(e))
            log.warning("%s", report["summary"])
            found.append(report)
        path = write_report(self.config.forensics, found[0], found[1:])
        return {"file": str(path.relative_to(self.config.forensics)),
                "summary": found[0]["summary"],
                "seconds": round(time.monotonic() - started, 4)}

    def _release_swap(self, k: int) -> None:
        """The swap barrier: SWAP k once every swap-locked member has drawn k, then the
        frame lock: frame k + 1 only once they have all swapped k. Sending k + 1 earlier
        would start the first walls to swap on k + 1 while the others are still waking for
        SWAP k: on shared cores that put the swap skew's p99 at 18-20 ms (4 windows, 2
        cores); waiting for SWAPPED costs no frame rate, as a node cannot start k + 1 before
        its swap anyway. Each wait ends at the barrier timeout (a swap stall: the other
        walls must not freeze)."""
        locked = tuple(m for m in self.membership.members if self.swap_locked.get(m))
        if not locked:
            return
        deadline = time.monotonic() + self.config.barrier_timeout
        while missing := set(locked) - self.swaps.drawn(k):
            if time.monotonic() >= deadline:
                log.warning("frame %d: released without DRAWN from %s", k,
                            ", ".join(sorted(missing)))
                break
            self._pump(deadline)
        self.swaps.released(k, locked, stalled=bool(missing))
        self.link.send(ControlMessage(k, Command.SWAP))
        deadline = time.monotonic() + self.config.barrier_timeout
        while not self.swaps.settled(k):
            if time.monotonic() >= deadline:
                log.warning("frame %d: going on without SWAPPED from every wall", k)
                self.swaps.give_up(k)
                break
            self._pump(deadline)

    def _resync(self, k: int, node: str, source: str, digest: str | None = None) -> bool:
        """Have `node` load `source`'s state of frame k (whose checksum is `digest`, by
        default the source's report); wait for its RESYNCED report. A node whose resyncs
        fail MAX_RESYNC_FAILURES times in a row is given up."""
        started = time.monotonic()
        digest = digest or self.reports[source].digest
        self.reports.pop(node, None)
        self.link.send(ControlMessage(k, Command.RESYNC, node, source, digest))
        deadline = started + self.resync_seconds
        ok = None
        while ok is None and time.monotonic() < deadline:
            ok = lockstep.resync_outcome(self.reports.get(node), digest)
            if ok is None:
                self._pump(deadline)
        ok = bool(ok)
        self.record.resyncs.append(Resync(k, node, source, ok, time.monotonic() - started))
        if ok:
            self.resync_failures.pop(node, None)
            self.membership = self.membership.healed(node)
            return True
        self.resync_failures[node] = failures = self.resync_failures.get(node, 0) + 1
        if failures >= MAX_RESYNC_FAILURES:
            self.resync_failures.pop(node)
            self._give_up(k, node, "resync-failed")
            log.warning("frame %d: gave %s up after %d failed resyncs", k, node, failures)
        return False

    def _give_up(self, k: int, node: str, reason: str) -> None:
        """`node` is out of the lock-step, and lost, until its node joins anew."""
        if node in self.membership.members:
            self.record.losses.append(Loss(k, node, reason))
        self.membership = self.membership.gave_up(node)

    def _admit_joiners(self, k: int, vote: Vote) -> None:
        """Walls that joined or fell behind, but are not members, enter by resync."""
        for node in self.membership.joiners():
            source = lockstep.agreeing_source(self.membership.members, self.reports,
                                              vote.agreed)
            if self._resync(k, node, source, vote.agreed):
                self.membership = self.membership.admitted(node)
                self.record.joins.append(Join(k, node))
        self._ask_again()


def run_master(config: MasterConfig, link: Link,
               progress: Callable[[int, int], None] = lambda k, live: None,
               before_frame: Callable[[int], None] | None = None,
               checkpoint: Callable[[RunRecord], None] | None = None,
               abandon: bool = False) -> RunRecord:
    """Run the cluster for `config.frames` frames over `link` and tell the nodes to stop
    (`abandon`: leave without a word, as a master that dies would; the harness's
    master-kill).

    Ctrl-C ends the run early (`interrupted`); either way the nodes are told to stop.
    `checkpoint` gets the record as the run starts and after every frame (it keeps
    report.json current).
    """
    master = Master(config, link, before_frame)
    checkpoint = checkpoint or (lambda record: None)
    try:
        checkpoint(master.record)  # from the start: a run whose walls never join has one too
        master.wait_for_walls()
        master.run(progress, checkpoint)
    except KeyboardInterrupt:
        master.record.interrupted = True
        log.warning("interrupted at frame %d", master.record.frames)
    finally:
        if not abandon:
            master.stop()
        master.record.master_rejected = dict(link.rejects.counts)
        master.record.master_dropped = link.dropped
    return master.record


def main(config: MasterConfig,
         progress: Callable[[int, int], None] = lambda k, live: None,
         checkpoint: Callable[[RunRecord], None] | None = None) -> RunRecord:
    """`cavesim master`: the master as a process of its own, over Zenoh."""
    from nodes.master.link import open_master_link

    with open_master_link(config) as link:
        return run_master(config, link, progress, checkpoint=checkpoint)
