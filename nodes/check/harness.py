"""The consistency harness: run a cluster, inject faults, and prove each one was caught.

Nodes run as child processes (node faults are passed to them as --inject); the master
runs in this process so the harness can act between frames: kill and restart a node,
attack the session as a rogue peer (`nodes/check/rogue.py`: junk, replayed signed
traffic, an earlier run's messages, forged snapshots and counts, session controls under a
wall's key), or kill the master and have a new one take the nodes over. Afterwards every
fault is matched with what the master recorded: when it was detected, which node was named,
when it healed; an attack also says what was refused and what became of the run. The
master runs with the harness's --max-lag, and a breach budget with room for the
divergences the plan makes each node have.
"""

from __future__ import annotations

import dataclasses
import logging
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
from nodes.check.count_forgery import CountForgery
from nodes.check.findings import check_report
from nodes.check.node_plan import (
    STATE_FORGERIES,
    master_kill_frame,
    node_arguments,
    resync_roles,
    with_room,
)
from nodes.check.rogue import RoguePeer
from nodes.check.state_forgers import StateForgers
from nodes.faults import (
    CHECK_MAX_LAG,
    COLLISIONS,
    CONTROL_REQUESTS,
    DIVERGENCE_GAP,
    FLOOD_MESSAGES,
    FLOOD_QUERIES,
    RATE_FRAMES,
    RESYNCED,
    SETTLE,
    SLOW_DELAY,
    STRAGGLE_FACTOR,
    WHOLE_CLUSTER,
    Fault,
    divergence_frames,
    last_action,
)
from nodes.launch.cluster import ClusterPlan, run_cluster, started_cluster
from nodes.launch.launcher import LocalCluster, resident_mb
from nodes.lockstep import MASTER_GONE, NODE_UP
from nodes.master.budgets import BREACH, BUDGETS, LAG, Budget
from nodes.master.link import ZenohMasterLink, open_master_link
from nodes.master.process import MasterConfig, run_master
from nodes.master.run_record import RunRecord

log = logging.getLogger("cavesim.check")
ROGUE_FAULTS = ("rogue", "replay-attack", "snapshot-forgery", "flood", "report-forgery",
                "query-replay", "tracking-replay", "second-master", "snapshot-collision",
                "oversize", "colliding-source", "control-forgery", "count-forgery")
# a RoguePeer's
REPLAYED_PER_KIND = 20  # captured frames, reports and commands played back
FORGERY_QUERIES = 50  # unsigned state queries sent with the forged snapshots
COLLISION_PACE = 1.2  # s at least between a collision's divergences: a node serves each
# asker one state a second (burst 2), and the victim and each forger ask once or twice per
# divergence
REPLAY_SECONDS, REPLAY_MOST = 3.0, 1_000  # how long and how many queries are replayed
EARLIER_RUN_QUERIES = 20
TRACKING_REPLAYS = 100  # tracking messages of each kind the master must refuse
NODE_START = 60.0  # s a restarted node has to come up
SECOND_MASTER_FRAMES = 20  # frames a second master that missed the first one signs
OVERSIZE_MESSAGES, OVERSIZE_BYTES, OVERSIZE_QUERIES = 45, 64 * 2**20, 5
UNDER_LIMIT_JUNK = 1  # junk frames just under the transport's limit, sent with them
REFUSAL_WAIT = 5.0  # s at most a frame waits for the master to count a forged control


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
    cluster = ClusterPlan(master, plan.out, {
        wall: node_arguments(faults, node_args, wall, plan.walls) for wall in plan.walls})
    harness = _Harness(faults, node_args, master)
    try:
        if kill is None:
            record, killed = run_cluster(cluster, progress, harness.before_frame,
                                         harness.checkpoint, harness.attach), None
        else:
            record, killed = _past_a_master_kill(cluster, kill, progress, harness)
    finally:
        harness.close()
    return check_report(plan.walls, faults, record, harness, killed, plan.out)


Counted = Callable[[dict[str, int], dict[str, int]], bool]  # (refused before, now) -> due


def _all_refused(messages: int) -> Counted:
    """Due once the nodes together refused `messages` more than before."""
    return lambda before, now: sum(now.values()) - sum(before.values()) >= messages


def _each_refused(messages: int) -> Counted:
    """Due once every node refused `messages` more than before."""
    return lambda before, now: all(n - before.get(w, 0) >= messages for w, n in now.items())


def _victim_refused(node: str) -> Counted:
    """Due once `node` refused something more than before."""
    return lambda before, now: now.get(node, 0) > before.get(node, 0)


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
            harness.attach(link)
            killed = run_master(first, link, progress, lambda k: harness.before_frame(
                cluster, k), harness.checkpoint, abandon=True)
        if killed.interrupted:  # a stopping signal: no new master, and the nodes end now
            cluster.stop(at_once=True)
            return RunRecord(config.walls, interrupted=True, signal=killed.signal), killed
        harness.master_killed(cluster)
        second = dataclasses.replace(config, frames=config.frames - frame + 1)
        with open_master_link(second) as link, cluster.watch(link.events):
            harness.attach(link)
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
        self.count_forgeries: dict[str, CountForgery] = {}  # per fault (as text)
        self.record: RunRecord | None = None  # the running master's record, as it goes
        self.link: ZenohMasterLink | None = None  # the running master's link
        # per control-forgery: each request it sent, and whether the master counted it refused
        self.forged_controls: dict[str, list[dict]] = {}
        self._replaying: list[threading.Thread] = []
        self._paced: dict[str, float] = {}  # fault -> when its last divergence was sent
        self._counted: dict[str, Counted] = {}  # fault -> when its second measurement is due
        # per straggler (as text): when each frame around it began (monotonic s)
        self.frame_times: dict[str, dict[int, float]] = {}

    def checkpoint(self, record: RunRecord) -> None:
        self.record = record

    def attach(self, link: ZenohMasterLink) -> None:
        """The running master's link (a new master's after a master-kill)."""
        self.link = link

    def before_frame(self, cluster: LocalCluster, k: int) -> None:
        if self.rogue is None and any(f.kind in ROGUE_FAULTS for f in self.faults):
            self._connect(cluster)
        for fault in self.faults:
            if fault.kind == "straggler":
                self._straggler(fault, cluster, k)
            if fault.kind in COLLISIONS and k in divergence_frames(fault):
                self._pace(fault)
            if fault.kind == "query-replay" and k == divergence_frames(fault)[1]:
                self._replay_queries()
            if fault.kind == "query-replay" and k == min(divergence_frames(fault)[1]
                                                         + DIVERGENCE_GAP, self.master.frames):
                self._end_replays()  # so that the nodes' later reports count them all
            if fault.kind == "control-forgery" and 0 <= k - fault.frame < len(CONTROL_REQUESTS):
                self._forge_control(fault, k)
            if fault.frame == k:
                self._do(fault, cluster, k)
        for fault, measured in self.measured.items():
            if "after" not in measured and k >= measured["until"]:
                self._measure_after(fault, measured, cluster, k)

    def _connect(self, cluster: LocalCluster) -> None:
        walls = tuple(cluster.nodes)
        self.rogue = RoguePeer(cluster.master_endpoint, cluster.session, walls)
        self.rogue.await_cluster()
        self.rogue.capture()
        if any(f.kind == "query-replay" for f in self.faults):
            self.rogue.capture_queries()
        if any(f.kind in STATE_FORGERIES for f in self.faults):
            self.forgers = StateForgers(cluster.master_endpoint, cluster.session, walls)
        for fault in self.faults:
            if fault.kind in COLLISIONS:  # from the start: long declared when they forge
                source, confirmer = resync_roles(fault, self.master.walls)
                as_source = fault.kind == "colliding-source"
                insiders = [self.credentials.issue(WALL, source)] if as_source \
                    else self._insiders(fault.node)
                self.forgers.serve_collisions(insiders, fault.node, divergence_frames(fault),
                                              confirmer, as_source)

    def _do(self, fault: Fault, cluster: LocalCluster, k: int) -> None:
        rogue = self.rogue
        match fault.kind:
            case "kill":
                self._restart(cluster, fault.node, k)  # it rejoins
            case "rogue":
                self._forge(cluster.session, k)
            case "replay-attack":
                self._replay(k)
            case "snapshot-forgery":
                self._measure_from(fault, cluster, k + RESYNCED, _victim_refused(fault.node))
                self.forgers.serve_forgeries(self._insiders(fault.node), self.emitters,
                                             range(k, k + DIVERGENCE_GAP))
                rogue.flood(0, FORGERY_QUERIES)
            case "snapshot-collision" | "colliding-source":
                self._measure_from(fault, cluster, divergence_frames(fault)[-1] + RESYNCED)
            case "report-forgery":
                rogue.in_other_walls_names(self.credentials.issue(WALL, rogue.walls[0]),
                                           rogue.current_run(), k)
            case "count-forgery":
                forgery = self.count_forgeries[str(fault)] = CountForgery(
                    rogue, self.credentials.issue(WALL, fault.node),
                    cluster.nodes[fault.node].pid, k)
                forgery.start()
            case "tracking-replay":
                rogue.replay_tracking(self.credentials.issue(TRACKER, "tracker"),
                                      rogue.current_run(), TRACKING_REPLAYS)
            case "second-master":
                self.second_master = self._start_a_second_master(cluster)
                rogue.as_a_second_master(self.credentials, k, SECOND_MASTER_FRAMES)
            case "flood":
                measured = self._measure_from(fault, cluster, k + SETTLE,
                                              _all_refused(FLOOD_MESSAGES))
                measured["seconds"] = round(rogue.flood(FLOOD_MESSAGES, FLOOD_QUERIES), 3)
            case "oversize":
                measured = self._measure_from(fault, cluster, k + SETTLE,
                                              _each_refused(UNDER_LIMIT_JUNK))
                started = time.monotonic()
                rogue.oversize(OVERSIZE_MESSAGES, OVERSIZE_BYTES, UNDER_LIMIT_JUNK,
                               OVERSIZE_QUERIES)
                measured["seconds"] = round(time.monotonic() - started, 3)

    def _forge_control(self, fault: Fault, k: int) -> None:
        """Frame k's request of a control-forgery (pause, reset, then stop: one a frame),
        with the first wall's key; frame k is made only once the master's link has counted
        it refused or taken it (REFUSAL_WAIT at most), so that a request it took would act
        on frame k."""
        link, request = self.link, CONTROL_REQUESTS[k - fault.frame]
        before = link.rejects.counts.get("not-an-operator", 0)
        sent_ns = self.rogue.controls_as_a_wall(self.credentials.issue(WALL, self.rogue.walls[0]),
                                                link.run_id, request)
        deadline = time.monotonic() + REFUSAL_WAIT
        while not (refused := link.rejects.counts.get("not-an-operator", 0) > before) \
                and (link.controller is None or link.controller.message.sent_ns != sent_ns) \
                and time.monotonic() < deadline:
            time.sleep(0.005)
        self.forged_controls.setdefault(str(fault), []).append(
            {"frame": k, "request": request, "refused": refused})

    def _restart(self, cluster: LocalCluster, node: str, k: int) -> None:
        """Kill `node`'s process and start a new one, and wait (NODE_START at most) until
        it is up and announced: the master then admits it within a few frames, where its
        start (seconds on a busy machine) would race the run's end."""
        log_file = cluster.log_path(node)
        logged = log_file.stat().st_size if log_file.exists() else 0
        cluster.kill_node(node)
        cluster.start_node(node, extra=node_arguments(self.faults, self.node_args, node,
                                                       self.master.walls, after=k))
        deadline = time.monotonic() + NODE_START
        while time.monotonic() < deadline and cluster.nodes[node].poll() is None:
            with open(log_file, "rb") as file:
                file.seek(logged)
                if NODE_UP.encode() in file.read():
                    return
            time.sleep(0.05)

    def _straggler(self, fault: Fault, cluster: LocalCluster, k: int) -> None:
        """Time the frames from RATE_FRAMES before a straggler to its node's restart, and
        restart that node (given up by then: out until its node joins anew), without it."""
        restart = last_action(fault)
        if fault.frame - RATE_FRAMES <= k <= restart:
            self.frame_times.setdefault(str(fault), {})[k] = time.monotonic()
        if k == restart:
            self._restart(cluster, fault.node, k)

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
            # each replayed query taken by the walls asked: their next reports count it
            if open_queries := self.rogue.await_answered():
                log.warning("%d replayed queries were not taken by the walls", open_queries)

    def _measure_from(self, fault: Fault, cluster: LocalCluster, until: int,
                      counted: Counted | None = None) -> dict:
        """Measure the nodes now and again before frame `until` (the last frame at most),
        or, with `counted`, before the first frame from then on at which the nodes' reports
        say they counted what the fault sent (`counted(before, now)`; the last frame at
        most): what a node counts reaches the master with its next report, however busy
        the machine. `until` becomes the frame of the second measurement."""
        measured = self.measured[str(fault)] = {"frame": fault.frame,
                                                "until": min(until, self.master.frames),
                                                "before": self._measure(cluster)}
        if counted is not None:
            self._counted[str(fault)] = counted
        return measured

    def _measure_after(self, fault: str, measured: dict, cluster: LocalCluster,
                       k: int) -> None:
        now = self._measure(cluster)
        counted = self._counted.get(fault)
        if counted is None or counted(measured["before"]["refused"], now["refused"]) \
                or k >= self.master.frames:
            measured["after"], measured["until"] = now, k

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
        for forgery in self.count_forgeries.values():
            forgery.join()
        if self.forgers is not None:
            self.forgers.close()
        if self.rogue is not None:
            self.rogue.close()
