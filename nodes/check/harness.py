"""The consistency harness: run a cluster, inject faults, and prove each one was caught.

Nodes run as child processes (node faults are passed to them as --inject); the master
runs in this process so the harness can act between frames: kill and restart a node,
attack the session as a rogue peer (`nodes/check/rogue.py`: junk, replayed signed
traffic, an earlier run's messages, forged snapshots), or kill the master and have a new
one take the nodes over. Afterwards every fault is matched with what the master recorded:
when it was detected, which node was named, when it healed; an attack also says what was
refused and what became of the run. The master runs with the harness's --max-lag, and a
breach budget with room for the divergences the plan makes each node have.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cavesim.core.errors import ClusterError
from cavesim.core.frame import FrameInput
from cavesim.core.framelog import FRAME_LOG
from cavesim.core.scene import load_scene
from cavesim.core.wire import Credentials, FrameMessage, SessionKeys, encode
from cavesim.core.wire.credentials import TRACKER, WALL, generate
from cavesim.core.wire.network import NetworkSettings
from nodes.check.findings import check_report
from nodes.check.rogue import RoguePeer
from nodes.check.state_forgers import StateForgers
from nodes.faults import (
    CHECK_MAX_LAG,
    DIVERGENCE_GAP,
    DIVERGENCES,
    FLOOD_MESSAGES,
    FLOOD_QUERIES,
    NODE_FAULTS,
    RATE_FRAMES,
    SETTLE,
    SLOW_DELAY,
    STRAGGLE_FACTOR,
    STRAGGLER_RESTART,
    WHOLE_CLUSTER,
    Fault,
    divergence_frames,
    last_action,
)
from nodes.launch.cluster import ClusterPlan, run_cluster, started_cluster
from nodes.launch.launcher import LocalCluster, resident_mb
from nodes.lockstep import MASTER_GONE
from nodes.master.budgets import BREACH, BUDGETS, LAG, Budget
from nodes.master.link import open_master_link
from nodes.master.process import MasterConfig, run_master
from nodes.master.run_record import RunRecord

ROGUE_FAULTS = ("rogue", "replay-attack", "snapshot-forgery", "flood", "report-forgery",
                "query-replay", "tracking-replay", "second-master", "snapshot-collision",
                "oversize")  # a RoguePeer's
STATE_FORGERIES = ("snapshot-forgery", "snapshot-collision")  # served to a node's resync
REPLAYED_PER_KIND = 20  # captured frames, reports and commands played back
FORGERY_QUERIES = 50  # unsigned state queries sent with the forged snapshots
RESYNCED = 5  # frames after a forged state's last divergence before the node is measured
COLLISION_PACE = 1.2  # s at least between a collision's divergences: a node serves each
# asker one state a second (burst 2), and the victim and each forger ask once per divergence
REPLAY_SECONDS, REPLAY_MOST = 3.0, 1_000  # how long and how many queries are replayed
REPLAY_SETTLE = 1.0  # s the nodes have to count the last replayed queries before going on
EARLIER_RUN_QUERIES = 20
TRACKING_REPLAYS = 100  # tracking messages of each kind the master must refuse
SECOND_MASTER_FRAMES = 20  # frames a second master that missed the first one signs
OVERSIZE_MESSAGES, OVERSIZE_BYTES, OVERSIZE_QUERIES = 45, 64 * 2**20, 5
UNDER_LIMIT_JUNK = 1  # junk frames just under the transport's limit, sent with them


@dataclass(frozen=True)
class CheckPlan:
    walls: tuple[str, ...]
    scene: Path
    frames: int
    faults: tuple[Fault, ...]
    out: Path
    session: str = "check"
    barrier_timeout: float = 0.5
    slow_delay: float = SLOW_DELAY
    max_lag: float = CHECK_MAX_LAG
    lag_budget: Budget = BUDGETS[LAG]
    breach_budget: Budget = BUDGETS[BREACH]  # the harness adds room for its own divergences
    on_loss: str = "continue"
    check_every: int = 1
    snapshot_chunk: int | None = None  # particles per snapshot reply (None: the nodes' default)
    resync: str = "delta"  # how the nodes load a resync's state: one of RESYNC_MODES
    node_walls: Mapping[str, tuple[str, ...]] = field(default_factory=dict)  # for the report


def run_check(plan: CheckPlan, progress: Callable[[int, int], None] = lambda k, n: None
              ) -> dict:
    """Run the plan; return the JSON report (faults, detection, resyncs, final agreement)."""
    plan.out.mkdir(parents=True, exist_ok=True)
    credentials = generate()
    faults = tuple(f if f.node or f.kind in WHOLE_CLUSTER else Fault(f.kind, f.frame,
                                                                     plan.walls[-1])
                   for f in plan.faults)
    node_args = ("--slow-delay", str(plan.slow_delay), "--straggle-delay",
                 str(STRAGGLE_FACTOR * plan.max_lag), "--resync", plan.resync)
    if plan.snapshot_chunk is not None:
        node_args += ("--snapshot-chunk", str(plan.snapshot_chunk))
    master = MasterConfig(plan.walls, plan.scene, plan.frames, plan.session,
                          credentials=credentials, barrier_timeout=plan.barrier_timeout,
                          on_loss=plan.on_loss, check_every=plan.check_every,
                          frame_log=plan.out / FRAME_LOG, forensics=plan.out,
                          node_walls=plan.node_walls, max_lag=plan.max_lag,
                          lag_budget=plan.lag_budget,
                          breach_budget=with_room(plan.breach_budget, faults))
    kill = master_kill_frame(faults)
    cluster = ClusterPlan(master, plan.out, {wall: _node_arguments(faults, node_args, wall)
                                             for wall in plan.walls})
    harness = _Harness(faults, node_args, master)
    try:
        if kill is None:
            record, killed = run_cluster(cluster, progress, harness.before_frame,
                                         harness.checkpoint), None
        else:
            record, killed = _past_a_master_kill(cluster, kill, progress, harness)
    finally:
        harness.close()
    return check_report(plan.walls, faults, record, harness, killed, plan.out)


def with_room(budget: Budget, faults: tuple[Fault, ...]) -> Budget:
    """`budget`, or more: room for as many breaches as the faults the plan has one node do
    itself (each diverges once at most; a collision's are eight), so that the harness's own
    faults give no node up."""
    planned = Counter(own.node for f in faults for own in _injected(f))
    return Budget(max(budget.most, *planned.values(), 1), budget.window)


def master_kill_frame(faults: tuple[Fault, ...]) -> int | None:
    """The frame of the plan's master-kill (None without one); ValueError when a fault the
    nodes do themselves comes at or after it, or a straggler's restart (the new master's
    run numbers its frames from 1 again: a node could not tell which frame was meant)."""
    kill = next((f.frame for f in faults if f.kind == "master-kill"), None)
    late = [str(f) for f in faults if kill is not None and any(
        last_action(own) >= kill for own in _injected(f))]
    if late:
        raise ValueError(f"{', '.join(late)}: a node's own fault (and a straggler's restart, "
                         f"{STRAGGLER_RESTART} frames on) must come before the master-kill@"
                         f"{kill} (the new master's run counts frames from 1)")
    return kill


def _node_arguments(faults: tuple[Fault, ...], common: tuple[str, ...], wall: str,
                    after: int = 0) -> tuple[str, ...]:
    """`wall`'s node's arguments: the `common` ones, what it must do itself for the faults
    after frame `after` (a restarted node is not given those it has passed) and how it
    resyncs."""
    own = [str(f) for fault in faults if fault.node == wall for f in _injected(fault)
           if f.frame > after]
    return (*common, *(arg for f in own for arg in ("--inject", f)),
            *_full_resync(faults, wall))


def _full_resync(faults: tuple[Fault, ...], wall: str) -> tuple[str, ...]:
    """A wall that forged states are served to resyncs by full snapshot only (a delta
    would heal it before any snapshot was asked for); the last --resync counts."""
    if any(f.kind in STATE_FORGERIES and f.node == wall for f in faults):
        return ("--resync", "full")
    return ()


def _injected(fault: Fault) -> tuple[Fault, ...]:
    """What the node itself must do for `fault`: its own faults, the divergence whose
    resync forged snapshots are served to, and the divergences of the kinds that make
    their node diverge again and again (DIVERGENCES)."""
    if fault.kind in NODE_FAULTS:
        return (fault,)
    if fault.kind == "snapshot-forgery":
        return (Fault("bitflip", fault.frame, fault.node),)
    if fault.kind in DIVERGENCES:
        return tuple(Fault("bitflip", k, fault.node) for k in divergence_frames(fault))
    return ()


def _past_a_master_kill(plan: ClusterPlan, frame: int, progress, harness: _Harness
                        ) -> tuple[RunRecord, RunRecord]:
    """The master dies before frame `frame` (no STOP: its liveliness token just goes, as
    with kill -9); a new master on the same session, with a run of its own, must take the
    same nodes over and run the frames left (its frame k is the plan's k + frame - 1, for
    the faults and the progress). Both runs' records."""
    with started_cluster(plan) as (cluster, config):
        first = dataclasses.replace(config, frames=frame - 1,
                                    frame_log=plan.out / "frames.killed-master.log")
        with open_master_link(first) as link, cluster.watch(link.events):
            killed = run_master(first, link, progress, lambda k: harness.before_frame(
                cluster, k), harness.checkpoint, abandon=True)
        harness.master_killed(cluster)
        second = dataclasses.replace(config, frames=config.frames - frame + 1)
        with open_master_link(second) as link, cluster.watch(link.events):
            record = run_master(second, link, lambda k, live: progress(k + frame - 1, live),
                                lambda k: harness.before_frame(cluster, k + frame - 1),
                                harness.checkpoint)
    return record, killed


class _Harness:
    """Does the faults that come from outside the nodes, just before their frame."""

    def __init__(self, faults: tuple[Fault, ...], node_args, master: MasterConfig) -> None:
        self.faults = faults
        self.node_args = node_args
        self.master = master
        self.credentials: Credentials = master.credentials
        self.emitters = len(load_scene(master.scene).emitters)
        self.rogue: RoguePeer | None = None
        self.forgers: StateForgers | None = None
        self.noticed: list[str] = []  # walls whose log says they saw the master go
        # per fault (as text) that measures the nodes: their memory, log sizes and refusals
        # at its frame ("before") and at the frame "until" ("after")
        self.measured: dict[str, dict] = {}
        self.second_master: dict = {}  # what became of a second master's start
        self.record: RunRecord | None = None  # the running master's record, as it goes
        self._replaying: list[threading.Thread] = []
        self._paced: dict[str, float] = {}  # fault -> when its last divergence was sent
        # per straggler (as text): when each frame around it began (monotonic s)
        self.frame_times: dict[str, dict[int, float]] = {}

    def checkpoint(self, record: RunRecord) -> None:
        self.record = record

    def before_frame(self, cluster: LocalCluster, k: int) -> None:
        if self.rogue is None and any(f.kind in ROGUE_FAULTS for f in self.faults):
            self._connect(cluster)
        for fault in self.faults:
            if fault.kind == "straggler":
                self._straggler(fault, cluster, k)
            if fault.kind == "snapshot-collision" and k in divergence_frames(fault):
                self._pace(fault)
            if fault.kind == "query-replay" and k == divergence_frames(fault)[1]:
                self._replay_queries()
            if fault.kind == "query-replay" and k == min(divergence_frames(fault)[1]
                                                         + DIVERGENCE_GAP, self.master.frames):
                self._end_replays()  # so that the nodes' later reports count them all
            if fault.frame == k:
                self._do(fault, cluster, k)
        for measured in self.measured.values():
            if k == measured["until"]:
                measured["after"] = self._measure(cluster)

    def _connect(self, cluster: LocalCluster) -> None:
        walls = tuple(cluster.nodes)
        self.rogue = RoguePeer(cluster.master_endpoint, cluster.session, walls)
        self.rogue.await_cluster()
        self.rogue.capture()
        if any(f.kind == "query-replay" for f in self.faults):
            self.rogue.capture_queries()
        if any(f.kind in STATE_FORGERIES for f in self.faults):
            self.forgers = StateForgers(cluster.master_endpoint, cluster.session, walls)

    def _do(self, fault: Fault, cluster: LocalCluster, k: int) -> None:
        rogue = self.rogue
        match fault.kind:
            case "kill":
                cluster.kill_node(fault.node)  # restarted, it rejoins
                cluster.start_node(fault.node, extra=_node_arguments(
                    self.faults, self.node_args, fault.node, after=k))
            case "rogue":
                self._forge(cluster.session, k)
            case "replay-attack":
                self._replay(k)
            case "snapshot-forgery":
                self._measure_from(fault, cluster, k + RESYNCED)
                self.forgers.serve_forgeries(self._insiders(fault.node), self.emitters,
                                             range(k, k + DIVERGENCE_GAP))
                rogue.flood(0, FORGERY_QUERIES)
            case "snapshot-collision":
                self._measure_from(fault, cluster, divergence_frames(fault)[-1] + RESYNCED)
                self.forgers.serve_collisions(self._insiders(fault.node), fault.node,
                                              divergence_frames(fault))
            case "report-forgery":
                rogue.in_other_walls_names(self.credentials.issue(WALL, rogue.walls[0]),
                                           rogue.current_run(), k)
            case "tracking-replay":
                rogue.replay_tracking(self.credentials.issue(TRACKER, "tracker"),
                                      rogue.current_run(), TRACKING_REPLAYS)
            case "second-master":
                self.second_master = self._start_a_second_master(cluster)
                rogue.as_a_second_master(self.credentials, k, SECOND_MASTER_FRAMES)
            case "flood":
                measured = self._measure_from(fault, cluster, k + SETTLE)
                measured["seconds"] = round(rogue.flood(FLOOD_MESSAGES, FLOOD_QUERIES), 3)
            case "oversize":
                measured = self._measure_from(fault, cluster, k + SETTLE)
                started = time.monotonic()
                rogue.oversize(OVERSIZE_MESSAGES, OVERSIZE_BYTES, UNDER_LIMIT_JUNK,
                               OVERSIZE_QUERIES)
                measured["seconds"] = round(time.monotonic() - started, 3)

    def _straggler(self, fault: Fault, cluster: LocalCluster, k: int) -> None:
        """Time the frames from RATE_FRAMES before a straggler to its node's restart, and
        restart that node (given up by then: out until its node joins anew), without it."""
        restart = last_action(fault)
        if fault.frame - RATE_FRAMES <= k <= restart:
            self.frame_times.setdefault(str(fault), {})[k] = time.monotonic()
        if k == restart:
            cluster.kill_node(fault.node)
            cluster.start_node(fault.node, extra=_node_arguments(
                self.faults, self.node_args, fault.node, after=k))

    def _pace(self, fault: Fault) -> None:
        """Wait until COLLISION_PACE has passed since `fault`'s last divergence."""
        last = self._paced.get(str(fault))
        if last is not None:
            time.sleep(max(0.0, last + COLLISION_PACE - time.monotonic()))
        self._paced[str(fault)] = time.monotonic()

    def _insiders(self, node: str) -> list[Credentials]:
        """Keys of the walls other than `node`: what the insiders serving it hold."""
        return [self.credentials.issue(WALL, wall) for wall in self.rogue.walls if wall != node]

    def _forge(self, session: str, k: int) -> None:
        """Frames from a foreign publisher: unsigned, wrongly signed, or of another session."""
        forged = FrameMessage(k + 1, FrameInput(1.0, np.eye(3)))
        stranger = generate()  # another session's keys
        for what, data in (("unsigned-frame", encode(forged, session)),
                           ("wrongly-signed-frame", encode(forged, session, stranger)),
                           ("other-session-frame", encode(forged, "another-session", stranger)),
                           ("junk", b"\x00" * 64)):
            self.rogue.put(what, SessionKeys(session).frame, data)

    def _replay(self, k: int) -> None:
        """Signed traffic played back: this run's own earlier frames, reports and commands
        captured off the network; an earlier run's frame, RESYNC, STOP and report; a
        member's frame and STOP without the master's signature; a report of a frame not
        sent."""
        rogue = self.rogue
        rogue.await_cluster()  # the master may be a new one since the rogue connected
        for kind in ("frame", "report", "control"):
            rogue.replay_captured(kind, REPLAYED_PER_KIND)
        rogue.as_an_earlier_run(self.credentials, k)
        rogue.as_a_member(self.credentials.issue(WALL, rogue.walls[0]), rogue.current_run(), k)

    def _replay_queries(self) -> None:
        """The walls' captured queries played back from another thread, while the frame
        whose resync they are to starve runs; queries of an earlier run with them."""
        self.rogue.earlier_run_queries(self.credentials.issue(WALL, self.rogue.walls[0]),
                                       EARLIER_RUN_QUERIES)
        thread = threading.Thread(target=self.rogue.replay_queries, daemon=True,
                                  args=(REPLAY_SECONDS, REPLAY_MOST), name="query replay")
        thread.start()
        self._replaying.append(thread)

    def _start_a_second_master(self, cluster: LocalCluster) -> dict:
        """Start a master with the same session and keys beside the running one: it must
        refuse to start, with one line; what it said and how long it took."""
        second = dataclasses.replace(
            self.master, network=NetworkSettings(connect=(cluster.master_endpoint,)),
            frame_log=None, forensics=None, join_timeout=10.0)
        started = time.monotonic()
        try:
            with open_master_link(second) as link:
                record = run_master(second, link)
        except ClusterError as e:
            return {"refused": str(e), "seconds": round(time.monotonic() - started, 3)}
        return {"refused": None, "ran_frames": record.frames,
                "seconds": round(time.monotonic() - started, 3)}

    def _end_replays(self) -> None:
        if self._replaying:
            for thread in self._replaying:
                thread.join(REPLAY_SECONDS + 1.0)
            self._replaying.clear()
            time.sleep(REPLAY_SETTLE)  # the nodes' next reports count every one

    def _measure_from(self, fault: Fault, cluster: LocalCluster, until: int) -> dict:
        """Measure the nodes now and again before frame `until` (the last frame at most)."""
        measured = self.measured[str(fault)] = {"frame": fault.frame,
                                                "until": min(until, self.master.frames),
                                                "before": self._measure(cluster)}
        return measured

    def _measure(self, cluster: LocalCluster) -> dict:
        """Each node's resident memory and its peak so far (MB), log size (bytes) and the
        messages it refused so far (as its latest report says)."""
        refused = self.record.node_rejected if self.record else {}
        return {"rss_mb": {w: round(resident_mb(p.pid) or 0.0, 1)
                           for w, p in cluster.nodes.items()},
                "peak_rss_mb": {w: round(resident_mb(p.pid, peak=True) or 0.0, 1)
                                for w, p in cluster.nodes.items()},
                "log_bytes": {w: cluster.log_path(w).stat().st_size for w in cluster.nodes},
                "refused": {w: refused.get(w, 0) for w in cluster.nodes}}

    def master_killed(self, cluster: LocalCluster, timeout: float = 10.0) -> None:
        """Wait until every node has logged the master's loss (they notice it on liveliness)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.noticed = [w for w in cluster.nodes
                            if MASTER_GONE in cluster.log_path(w).read_text(errors="replace")]
            if len(self.noticed) == len(cluster.nodes):
                return
            time.sleep(0.05)

    def sent(self) -> dict[str, int]:
        """What the rogue peer and the state forgers sent, by what it was."""
        sent = Counter(self.rogue.sent if self.rogue else {})
        sent.update(self.forgers.sent if self.forgers else {})
        return dict(sent)

    def close(self) -> None:
        self._end_replays()
        if self.forgers is not None:
            self.forgers.close()
        if self.rogue is not None:
            self.rogue.close()
