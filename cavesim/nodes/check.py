"""The consistency harness: run a cluster, inject faults, and prove each one was caught.

Nodes run as child processes (node faults are passed to them as --inject); the master
runs in this process so the harness can act between frames: kill and restart a node,
or publish forged frames from a foreign session. Afterwards every fault is matched with
what the master recorded: when it was detected, which node was named, when it healed.
"""

from __future__ import annotations

import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import zenoh

from cavesim.core.errors import ClusterError
from cavesim.core.frame import FrameInput
from cavesim.core.wire import FrameMessage, SessionKeys, encode
from cavesim.core.wire.network import NetworkConfig, open_session, read_key
from cavesim.nodes.cluster import ClusterPlan, run_cluster
from cavesim.nodes.faults import NODE_FAULTS, Fault
from cavesim.nodes.launcher import LocalCluster
from cavesim.nodes.master import MasterConfig
from cavesim.nodes.record import RunRecord


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


def run_check(plan: CheckPlan, progress: Callable[[int, int], None] = lambda k, n: None
              ) -> dict:
    """Run the plan; return the JSON report (faults, detection, resyncs, final agreement)."""
    plan.out.mkdir(parents=True, exist_ok=True)
    key_file = plan.out / "session.key"
    key_file.write_text(secrets.token_hex(32))
    faults = tuple(f if f.node or f.kind == "rogue" else Fault(f.kind, f.frame, plan.walls[-1])
                   for f in plan.faults)
    node_args = ("--slow-delay", str(plan.slow_delay))
    if plan.snapshot_chunk is not None:
        node_args += ("--snapshot-chunk", str(plan.snapshot_chunk))
    master = MasterConfig(plan.walls, plan.scene, plan.frames, plan.session,
                          key=read_key(key_file), barrier_timeout=plan.barrier_timeout,
                          on_loss=plan.on_loss, check_every=plan.check_every,
                          frame_log=plan.out / "frames.log")
    cluster = ClusterPlan(master, plan.out, key_file, {wall: (*node_args, *(
        arg for f in faults if f.node == wall and f.kind in NODE_FAULTS
        for arg in ("--inject", str(f)))) for wall in plan.walls})
    harness = _Harness(faults, node_args)
    try:
        record = run_cluster(cluster, progress, harness.before_frame)
    finally:
        harness.close()
    return _report(plan, faults, record, harness.rogue_sent)


class _Harness:
    """Does the faults that come from outside the nodes, just before their frame."""

    def __init__(self, faults: tuple[Fault, ...], node_args) -> None:
        self.faults = faults
        self.node_args = node_args
        self.rogue_sent = 0
        self._rogue_session: zenoh.Session | None = None

    def before_frame(self, cluster: LocalCluster, k: int) -> None:
        for fault in self.faults:
            if fault.frame != k:
                continue
            if fault.kind == "kill":
                cluster.kill_node(fault.node)
                cluster.start_node(fault.node, extra=self.node_args)  # restarts, rejoins
            elif fault.kind == "rogue":
                self._forge(cluster, k)

    def _forge(self, cluster: LocalCluster, k: int) -> None:
        """Frames from a foreign publisher: unsigned, wrongly signed, or of another session."""
        if self._rogue_session is None:
            network = NetworkConfig(connect=(cluster.master_endpoint,))
            self._rogue_session = open_session(network)
            self._await_walls(cluster, self._rogue_session)
        session = cluster.session
        forged = FrameMessage(k + 1, FrameInput(1.0, np.eye(3)))
        for data in (encode(forged, session), encode(forged, session, b"not-the-key" * 3),
                     encode(forged, "another-session", b"not-the-key" * 3),
                     b"\x00" * 64):
            self._rogue_session.put(SessionKeys(session).frame, data)
            self.rogue_sent += 1

    def _await_walls(self, cluster: LocalCluster, rogue: zenoh.Session,
                     timeout: float = 10.0) -> None:
        """Wait until the rogue session sees every wall's liveliness token (it is connected)."""
        keys = SessionKeys(cluster.session)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            seen = {keys.node_of(reply.ok.key_expr)
                    for reply in rogue.liveliness().get(keys.alive(), timeout=1.0) if reply.ok}
            if seen >= set(cluster.nodes):
                return
        raise ClusterError(f"the rogue publisher did not reach the walls within {timeout} s")

    def close(self) -> None:
        if self._rogue_session is not None:
            self._rogue_session.close()


def _report(plan: CheckPlan, faults: tuple[Fault, ...], record: RunRecord,
            rogue_sent: int) -> dict:
    summary = record.summary()
    outcomes = [_outcome(fault, record) for fault in faults]
    return {
        "command": "check",
        "walls": list(plan.walls),
        "frames": record.frames,
        "faults": outcomes,
        "all_detected": all(o["detected_frame"] is not None for o in outcomes),
        "all_healed": all(o["healed"] for o in outcomes),
        "divergences": record.divergences.total,
        "rogue_messages_sent": rogue_sent,
        "final": summary["final"],
        "run": summary,
    }


def _outcome(fault: Fault, record: RunRecord) -> dict:
    """When the master noticed `fault`, whom it named, and when the node was whole again."""
    detected, named, healed_at = None, [], None
    if fault.kind in ("bitflip", "seed", "stale"):
        hit = next((d for d in record.divergences
                    if d.frame >= fault.frame and fault.node in d.nodes), None)
        if hit:
            detected, named = hit.frame, list(hit.nodes)
            healed_at = _resynced(record, fault.node, hit.frame)
    elif fault.kind in ("drop", "slow"):
        hit = next((s for s in record.stalls
                    if s.frame == fault.frame and fault.node in s.nodes), None)
        if hit:
            detected, named = hit.frame, sorted(hit.nodes)
            healed_at = fault.frame if record.frames > fault.frame else None
    elif fault.kind == "kill":
        hit = next((loss for loss in record.losses
                    if loss.node == fault.node and loss.frame >= fault.frame - 1), None)
        if hit:
            detected, named = hit.frame, [fault.node]
            healed_at = next((j.frame for j in record.joins
                              if j.node == fault.node and j.frame >= hit.frame),
                             _resynced(record, fault.node, hit.frame))
    elif fault.kind == "rogue":
        rejected = sum(record.node_rejected.values())
        if rejected:
            detected, healed_at = fault.frame, fault.frame
    return {"fault": str(fault), "kind": fault.kind, "frame": fault.frame, "node": fault.node,
            "detected_frame": detected, "named": named, "healed_frame": healed_at,
            "healed": healed_at is not None and record.agreed_at_the_end()}


def _resynced(record: RunRecord, node: str, frame: int) -> int | None:
    return next((r.frame for r in record.resyncs
                 if r.node == node and r.frame >= frame and r.ok), None)
