"""The consistency harness: run a cluster, inject faults, and prove each one was caught.

Nodes run as child processes (node faults are passed to them as --inject); the master
runs in this process so the harness can act between frames: kill and restart a node,
attack the session as a rogue peer (`nodes/check/rogue.py`: junk, replayed signed
traffic, an earlier run's messages, forged snapshots), or kill the master and have a new
one take the nodes over. Afterwards every fault is matched with what the master recorded:
when it was detected, which node was named, when it healed; an attack also says what was
refused and what became of the run.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cavesim.core.frame import FrameInput
from cavesim.core.scene import load_scene
from cavesim.core.wire import Credentials, FrameMessage, SessionKeys, encode
from cavesim.core.wire.credentials import WALL, generate
from nodes.check.findings import check_report
from nodes.check.rogue import RoguePeer
from nodes.faults import FLOOD_MESSAGES, FLOOD_QUERIES, NODE_FAULTS, Fault
from nodes.launch.cluster import ClusterPlan, run_cluster, started_cluster
from nodes.launch.launcher import LocalCluster, resident_mb
from nodes.lockstep import MASTER_GONE
from nodes.master.link import open_master_link
from nodes.master.process import MasterConfig, run_master
from nodes.master.run_record import RunRecord

WHOLE_CLUSTER = ("rogue", "replay-attack", "master-kill", "flood", "report-forgery")  # no node's
ROGUE_FAULTS = ("rogue", "replay-attack", "snapshot-forgery", "flood",
                "report-forgery")  # a RoguePeer's
REPLAYED_PER_KIND = 20  # captured frames, reports and commands played back
FORGERY_QUERIES = 50  # unsigned state queries sent with the forged snapshots
FLOOD_SETTLE = 30  # frames after a flood before the nodes are measured again


@dataclass(frozen=True)
class CheckPlan:
    walls: tuple[str, ...]
    scene: Path
    frames: int
    faults: tuple[Fault, ...]
    out: Path
    session: str = "check"
    barrier_timeout: float = 0.5
    slow_delay: float = 1.5
    on_loss: str = "continue"
    check_every: int = 1
    snapshot_chunk: int | None = None  # particles per snapshot reply (None: the nodes' default)
    resync: str = "delta"  # how the nodes load a resync's state: one of RESYNC_MODES


def run_check(plan: CheckPlan, progress: Callable[[int, int], None] = lambda k, n: None
              ) -> dict:
    """Run the plan; return the JSON report (faults, detection, resyncs, final agreement)."""
    plan.out.mkdir(parents=True, exist_ok=True)
    credentials = generate()
    faults = tuple(f if f.node or f.kind in WHOLE_CLUSTER else Fault(f.kind, f.frame,
                                                                     plan.walls[-1])
                   for f in plan.faults)
    node_args = ("--slow-delay", str(plan.slow_delay), "--resync", plan.resync)
    if plan.snapshot_chunk is not None:
        node_args += ("--snapshot-chunk", str(plan.snapshot_chunk))
    master = MasterConfig(plan.walls, plan.scene, plan.frames, plan.session,
                          credentials=credentials, barrier_timeout=plan.barrier_timeout,
                          on_loss=plan.on_loss, check_every=plan.check_every,
                          frame_log=plan.out / "frames.log", forensics=plan.out)
    kill = master_kill_frame(faults)
    injected = [(f.node, own) for f in faults if (own := _injected(f)) is not None]
    cluster = ClusterPlan(master, plan.out, {wall: (*node_args, *(
        arg for node, own in injected if node == wall for arg in ("--inject", str(own))),
        *_full_resync(faults, wall)) for wall in plan.walls})
    harness = _Harness(faults, node_args, credentials, plan.scene, plan.frames)
    try:
        if kill is None:
            record, killed = run_cluster(cluster, progress, harness.before_frame), None
        else:
            record, killed = _past_a_master_kill(cluster, kill, progress, harness)
    finally:
        harness.close()
    return check_report(plan.walls, faults, record, harness, killed, plan.out)


def master_kill_frame(faults: tuple[Fault, ...]) -> int | None:
    """The frame of the plan's master-kill (None without one); ValueError when a fault the
    nodes do themselves comes at or after it (the new master's run numbers its frames from
    1 again: a node could not tell which frame was meant)."""
    kill = next((f.frame for f in faults if f.kind == "master-kill"), None)
    late = [str(f) for f in faults if kill is not None and f.frame >= kill
            and (f.kind in NODE_FAULTS or f.kind == "snapshot-forgery")]
    if late:
        raise ValueError(f"{', '.join(late)}: a node's own fault must come before the "
                         f"master-kill@{kill} (the new master's run counts frames from 1)")
    return kill


def _full_resync(faults: tuple[Fault, ...], wall: str) -> tuple[str, ...]:
    """A wall that the forged snapshots are served to resyncs by full snapshot only (a delta
    would heal it before any snapshot was asked for); the last --resync counts."""
    if any(f.kind == "snapshot-forgery" and f.node == wall for f in faults):
        return ("--resync", "full")
    return ()


def _injected(fault: Fault) -> Fault | None:
    """What the node itself must do for `fault`: its own faults, and the divergence a
    snapshot forgery needs (the forged snapshots are served to its resync)."""
    if fault.kind in NODE_FAULTS:
        return fault
    if fault.kind == "snapshot-forgery":
        return Fault("bitflip", fault.frame, fault.node)
    return None


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
                cluster, k), abandon=True)
        harness.master_killed(cluster)
        second = dataclasses.replace(config, frames=config.frames - frame + 1)
        with open_master_link(second) as link, cluster.watch(link.events):
            record = run_master(second, link, lambda k, live: progress(k + frame - 1, live),
                                lambda k: harness.before_frame(cluster, k + frame - 1))
    return record, killed


class _Harness:
    """Does the faults that come from outside the nodes, just before their frame."""

    def __init__(self, faults: tuple[Fault, ...], node_args, credentials: Credentials,
                 scene: Path, frames: int) -> None:
        self.faults = faults
        self.node_args = node_args
        self.credentials = credentials
        self.emitters = len(load_scene(scene).emitters)
        self.frames = frames
        self.rogue: RoguePeer | None = None
        self.noticed: list[str] = []  # walls whose log says they saw the master go
        self.flood: dict = {}  # the nodes' memory and log sizes before and after a flood

    def before_frame(self, cluster: LocalCluster, k: int) -> None:
        if self.rogue is None and any(f.kind in ROGUE_FAULTS for f in self.faults):
            self.rogue = RoguePeer(cluster.master_endpoint, cluster.session,
                                   tuple(cluster.nodes))
            self.rogue.await_cluster()
            self.rogue.capture()
        for fault in self.faults:
            if fault.frame != k:
                continue
            if fault.kind == "kill":
                cluster.kill_node(fault.node)
                cluster.start_node(fault.node, extra=self.node_args)  # restarts, rejoins
            elif fault.kind == "rogue":
                self._forge(cluster.session, k)
            elif fault.kind == "replay-attack":
                self._replay(k)
            elif fault.kind == "snapshot-forgery":
                insiders = [self.credentials.issue(WALL, wall)
                            for wall in self.rogue.walls if wall != fault.node]
                self.rogue.serve_forged_snapshots(cluster.master_endpoint, insiders,
                                                  self.emitters)
                self.rogue.flood(0, FORGERY_QUERIES)
            elif fault.kind == "report-forgery":
                self.rogue.in_other_walls_names(
                    self.credentials.issue(WALL, self.rogue.walls[0]),
                    self.rogue.current_run(), k)
            elif fault.kind == "flood":
                self.flood = {"frame": k, "before": self._measure(cluster)}
                self.flood["seconds"] = round(self.rogue.flood(FLOOD_MESSAGES, FLOOD_QUERIES), 3)
        if self.flood and k == min(self.flood["frame"] + FLOOD_SETTLE, self.frames):
            self.flood["after"] = self._measure(cluster)

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

    @staticmethod
    def _measure(cluster: LocalCluster) -> dict:
        """Each node's resident memory (MB) and log size (bytes)."""
        return {"rss_mb": {w: round(resident_mb(p.pid) or 0.0, 1)
                           for w, p in cluster.nodes.items()},
                "log_bytes": {w: cluster.log_path(w).stat().st_size for w in cluster.nodes}}

    def master_killed(self, cluster: LocalCluster, timeout: float = 10.0) -> None:
        """Wait until every node has logged the master's loss (they notice it on liveliness)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.noticed = [w for w in cluster.nodes
                            if MASTER_GONE in cluster.log_path(w).read_text(errors="replace")]
            if len(self.noticed) == len(cluster.nodes):
                return
            time.sleep(0.05)

    def close(self) -> None:
        if self.rogue is not None:
            self.rogue.close()
