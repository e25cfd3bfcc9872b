"""The master: owns the clock and the randomness, and holds the cluster in lock-step.

A run has an id (the link's, drawn when it starts). A wall enters it in three steps: its
liveliness token appears, the master asks for its info (GPU, swap lock, a fresh nonce),
and the master's WELCOME naming that nonce makes the node start this run from the
scene's start state and report JOINED (`admission.py`); an old WELCOME cannot be replayed
(the nonce is used up). Per frame k: make the inputs once (`frame_inputs.py`: the clock's
matrix, the tracked or scripted head, the scene driver's state), publish them, wait until
every member has reported k (the barrier: on a timeout, record who is stalled and send the
frame again; a member silent past `evict_after` is evicted under --on-loss continue, or the
run ends once it has been silent `max_pause` under --on-loss pause; a member that reported
`max_lag` after half the members is named, and given up past the lag budget:
`stragglers.py`), agree on the checksums and the counters and record a divergence with what
differs in each odd node's state (`agreement.py`, desync forensics in `forensics.py`),
resync the odd nodes from a healthy one (`resyncs.py`: a node whose resyncs fail too often
is given up, and so is one that diverges past the breach budget: `budgets.py`), admit walls
that joined or fell behind, book the agreed counters (`counter_book.py`), log the frame.
Only frame k's reports are kept. It takes typed events from a link (Zenoh in a real run,
memory in the tests: `settings.py`) and leaves the rules to `nodes/lockstep.py`; it needs
no GL.

One master per session: a master that finds another's liveliness token keeps its run if it
is running, or if its run started first (the smaller run id: an id begins with its start
time), and counts the other (`other-master`), whose WELCOME its nodes refuse while it is
alive; a master still waiting for its walls beside one that started first refuses to start,
in one line naming it. Of two masters that meet, exactly one keeps the session.

In the mixed-hardware mode the vote is each member's drift from an authority instead of its
checksum (`nodes/master/tolerance.py`), no forensics run (every wall's bits differ), and the
counters kept are the authority's.
"""
from __future__ import annotations

import logging
import queue
import time
from collections.abc import Callable

from cavesim.core.clock import Clock
from cavesim.core.counters import widths
from cavesim.core.errors import ClusterError, ProtocolError
from cavesim.core.framelog import FrameLogWriter
from cavesim.core.scene import load_scene
from cavesim.core.scene.digest import scene_digest
from cavesim.core.wire import (
    Command,
    ControlMessage,
    FrameMessage,
    ReportMessage,
)
from cavesim.core.wire.envelope import run_started
from cavesim.core.wire.payloads.from_nodes import Status
from cavesim.tools.signals import signal_of
from nodes import lockstep
from nodes.lockstep import LOSS_POLICIES, Membership, Vote
from nodes.master.admission import INFO_RETRY, Admission
from nodes.master.agreement import Agreement
from nodes.master.budgets import BREACH, LAG, Tally
from nodes.master.counter_book import AGREED, AUTHORITY, CounterBook
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
from nodes.master.frame_inputs import FrameInputs
from nodes.master.resyncs import Resyncs
from nodes.master.run_record import FinalAgreement, Join, Loss, RunRecord, Stall, UserAction
from nodes.master.settings import Link, MasterConfig
from nodes.master.stragglers import Stragglers
from nodes.master.tolerance import ToleranceMode
from nodes.master.user_requests import UserRequests

log = logging.getLogger("cavesim.master")
STOP_WAIT = 5.0  # s for the nodes to leave after STOP
GONE_GRACE = 1.0  # s to hear why, when every member is gone at once


class Master:
    def __init__(self, config: MasterConfig, link: Link,
                 before_frame: Callable[[int], None] | None = None) -> None:
        if config.on_loss not in LOSS_POLICIES:
            raise ValueError(f"on_loss must be one of {LOSS_POLICIES}, got {config.on_loss!r}")
        self.config = config
        self.link = link
        self.before_frame = before_frame or (lambda k: None)
        self.scene = scene = load_scene(config.scene)
        self.frame = 0  # the frame in flight
        self.reports: dict[str, ReportMessage] = {}  # wall -> its report of `frame`
        self.last_sent: dict[str, int] = {}
        self.last_received: dict[str, int] = {}
        self.membership = Membership(config.walls)
        self.clock = Clock(config.dt, config.realtime, config.max_frame_time,
                           config.max_substeps)
        self.requests = UserRequests()  # an operator's pause, reset and stop
        self.stopping = False
        self.refused = False  # another master was there first: the nodes are its own
        self.record = RunRecord(config.walls, arithmetic=scene.arithmetic.value,
                                node_walls=dict(config.node_walls), capacity=scene.capacity,
                                counters=CounterBook(scene, config.dt, AGREED if
                                                     config.tolerance is None else AUTHORITY))
        self.record.run_id = link.run_id
        self.swaps = self.record.swaps
        self.inputs = FrameInputs(scene, config.dt, config.clock_seed, link, self.record)
        self.admission = Admission(config.walls, config.scene, scene_digest(scene), link,
                                   self.record)
        self.resyncs = Resyncs(scene.capacity, link, self.record, self._pump)
        self.tolerance = None if config.tolerance is None else ToleranceMode(
            config.tolerance, config.walls, config.check_every)
        self.record.tolerance = self.tolerance
        self.agreement = Agreement(self.record, widths(scene), config.check_every,
                                   self.tolerance, config.forensics, link.ask_blocks)
        self.stragglers = Stragglers(config.max_lag, config.lag_budget, self.record.lags)
        self.breaches = Tally(BREACH, config.breach_budget, "diverged")
        self.record.max_lag = config.max_lag
        self.record.budgets = (self.breaches, self.stragglers.tally)

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
                if report.node in self.admission.wrong_scene:
                    return  # it holds another scene: it cannot be in this run
                self.membership = self.membership.came_up(report.node)
                log.info("%s joined run %016x", report.node, self.link.run_id)
            case Reported(report) if report.status is Status.BEHIND:
                self.membership = self.membership.fell_behind(report.node)
            case Reported(report, at):
                if report.frame == self.frame:
                    self.reports[report.node] = report
                    self.stragglers.reported(report.node, at)
                if report.status is Status.STEPPED:
                    self.record.frame_cost.add(report.node, report.cost_us)
                self.last_received[report.node] = max(report.frame,
                                                      self.last_received.get(report.node, 0))
                self.record.node_rejected[report.node] = report.rejected
            case Described(info):
                self.admission.described(info, self.frame)
            case Displayed(message):
                self.swaps.note(message)
            case WallUp(wall):
                self.admission.came_up(wall)
            case WallDown(wall) if not self.stopping:
                self.admission.went_down(wall)
                self.membership, lost = self.membership.went_down(wall, self.config.on_loss)
                if lost:
                    self.record.losses.append(Loss(max(self.last_sent.values(), default=0),
                                                   wall, "liveliness"))
                    log.warning("lost node %s", wall)
            case WallDown(wall):
                self.admission.went_down(wall)
                self.membership, _ = self.membership.went_down(wall, self.config.on_loss)
            case OtherMaster(run_id, key):
                self._other_master(run_id, key)
            case ProcessEnded(_, code, failure) if code != 0 and not self.stopping:
                raise ClusterError(failure)

    def _other_master(self, run_id: int, key: str) -> None:
        """One master per session: still waiting for its walls, this master refuses to
        start beside one whose run started first (ClusterError); running, or first, it
        keeps its run (its nodes refuse the other's WELCOME while it is alive) and counts
        the other."""
        ours, session = self.link.run_id, self.config.session
        if self.frame == 0 and run_id < ours:
            self.refused = True
            raise ClusterError(f"another master's run {run_id:016x}, started first (at "
                               f"{run_started(run_id)}), is on session {session}: refusing "
                               f"to start run {ours:016x}; stop that master first")
        why = "whose nodes refuse the other" if self.frame else "which started first"
        self.link.rejects.reject(ProtocolError(
            "other-master", f"another master's run {run_id:016x} came on session {session}; "
            f"keeping run {ours:016x}, {why}"), key)

    # -- the run ---------------------------------------------------------------------------

    def wait_for_walls(self) -> None:
        """Until every wall has joined this run and said whether it is swap-locked (the
        swap barrier needs to know from frame 1)."""
        deadline = time.monotonic() + self.config.join_timeout
        while missing := self.admission.missing(self.config.walls, self.membership.alive):
            if time.monotonic() > deadline:
                hints = self.admission.hints(missing)
                raise ClusterError(f"walls {missing} did not join within "
                                   f"{self.config.join_timeout:g} s (--join-timeout): "
                                   + ("; ".join(hints) if hints else
                                      "are their nodes running with this --session? See "
                                      "their logs"))
            self.admission.ask_again(self.membership.alive)
            self._pump(min(deadline, time.monotonic() + INFO_RETRY))
        self.membership = self.membership.started()

    def run(self, progress: Callable[[int, int], None] = lambda k, live: None,
            checkpoint: Callable[[RunRecord], None] = lambda record: None) -> RunRecord:
        log_writer = None
        if self.config.frame_log is not None:
            log_writer = FrameLogWriter(self.config.frame_log, {
                "session": self.config.session, "scene": str(self.config.scene),
                "scene_digest": self.admission.scene_digest,
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
                    self.record.user_actions.append(UserAction(k, "stop", asked.by))
                    log.info("%s asked the run to end, after frame %d", asked.by or "the user",
                             k - 1)
                    break
                message = self.inputs.make(k, asked)
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
        A member silent past the limits is evicted (continue) or ends the run (pause); one
        that lagged past its budget is given up."""
        self.frame, self.reports = k, {}
        self.stragglers.begin(k, self.membership.members)
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
        done = time.monotonic()
        for node in self.stragglers.end(done, self.membership.alive):
            self._give_up(k, node, LAG)
        return done - sent

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
        """Vote on the members' checksums and counters of frame k (`agreement.py`) and
        resync the odd ones, but give up those past the breach budget."""
        vote = self.agreement.vote(k, self.membership.members, self.reports)
        # a breach is an odd node named (the tolerance mode's periodic resyncs name no one)
        over = [n for n in vote.odd if n in vote.named and self.breaches.over(k, n)]
        for node in vote.odd:
            if node not in over:
                self._resync(k, node, vote.source, vote.agreed, vote.odd)
        for node in over:
            self._give_up(k, node, BREACH)
        return vote

    def _release_swap(self, k: int) -> None:
        """The swap barrier: SWAP k once every swap-locked member has drawn k, then the
        frame lock: frame k + 1 only once they have all swapped k. Sending k + 1 earlier
        would start the first walls to swap on k + 1 while the others are still waking for
        SWAP k: on shared cores that put the swap skew's p99 at 18-20 ms (4 windows, 2
        cores); waiting for SWAPPED costs no frame rate, as a node cannot start k + 1 before
        its swap anyway. Each wait ends at the barrier timeout (a swap stall: the other
        walls must not freeze)."""
        locked = tuple(m for m in self.membership.members
                       if self.admission.swap_locked.get(m))
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

    def _resync(self, k: int, node: str, source: str, digest: str | None = None,
                odd: tuple[str, ...] = ()) -> bool:
        """Have `node` load `source`'s state of frame k (whose checksum is `digest`, by
        default the source's report), or another holder's, confirmed by a second holder
        (not one of the `odd`): healed, or failed (`resyncs.py`), and given up after
        MAX_RESYNC_FAILURES failures in a row."""
        digest = digest or self.reports[source].digest
        holders = lockstep.holders(self.membership.members, self.reports, digest, node,
                                   source, odd)
        healed = self.resyncs.resync(k, node, holders, digest, self.reports)
        if healed:
            self.membership = self.membership.healed(node)
        elif healed is None:
            self._give_up(k, node, "resync-failed")
        return bool(healed)

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
        self.admission.ask_again(self.membership.alive)


def run_master(config: MasterConfig, link: Link,
               progress: Callable[[int, int], None] = lambda k, live: None,
               before_frame: Callable[[int], None] | None = None,
               checkpoint: Callable[[RunRecord], None] | None = None,
               abandon: bool = False) -> RunRecord:
    """Run the cluster for `config.frames` frames over `link` and tell the nodes to stop
    (`abandon`: leave without a word, as a master that dies would; the harness's
    master-kill).

    Ctrl-C (or SIGTERM, SIGHUP: `cavesim.tools.signals`) ends the run early (`interrupted`,
    and which `signal`); either way the nodes are told to stop.
    `checkpoint` gets the record as the run starts and after every frame (it keeps
    report.json current).
    """
    master = Master(config, link, before_frame)
    checkpoint = checkpoint or (lambda record: None)
    try:
        checkpoint(master.record)  # from the start: a run whose walls never join has one too
        master.wait_for_walls()
        master.run(progress, checkpoint)
    except KeyboardInterrupt as interruption:
        master.record.interrupted = True
        master.record.signal = signal_of(interruption)
        log.warning("interrupted by %s at frame %d", master.record.signal,
                    master.record.frames)
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
