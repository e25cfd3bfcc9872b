"""A wall node's part that follows a master's run (a part of `WallNode`,
nodes/wall/process.py): it answers the master's info query with its GPU and a fresh nonce,
joins the run whose WELCOME names that nonce (starting over from the scene's start state if
it held another run, stepping with the run's engine path if it probed its own), and ends the
node, in one line, when no master is there to follow: none welcomed it within --master-wait,
its master's liveliness token went away (--on-master-loss exit, or no new master within
--master-wait), or its master has been silent MASTER_SILENCE x --master-wait.
"""

from __future__ import annotations

import logging
import secrets
import time
from typing import TYPE_CHECKING

import zenoh

from cavesim.core.errors import ClusterError
from cavesim.core.frame_cost import NO_COST
from cavesim.core.scene import Engine
from cavesim.core.wire import InfoMessage, ReportMessage, SessionKeys
from cavesim.core.wire.network import zenoh_message
from cavesim.core.wire.payloads.from_nodes import Status
from cavesim.core.wire.rejects import RejectCounter
from cavesim.gpu.engine import ParticleSystem
from nodes.lockstep import MASTER_GONE
from nodes.wall.inbox import NodeInbox, NodeView
from nodes.wall.settings import NodeConfig

if TYPE_CHECKING:
    from nodes.wall.screen import LiveDisplay

log = logging.getLogger("cavesim.node")
MASTER_SILENCE = 10  # x --master-wait: a master this long silent counts as gone


class MasterWatch:
    """Joining a master's run, and watching that master (see the module docstring). Of the
    node it uses the attributes below, `done`, `_seal` and `_publish`."""

    config: NodeConfig
    system: ParticleSystem
    view: NodeView
    rejects: RejectCounter
    keys: SessionKeys
    inbox: NodeInbox
    seed: int
    scene_digest: str
    gpu: dict
    engine_probed: bool
    started: float  # when the node started (monotonic)
    heard: float  # when the master of our run was last heard (monotonic)
    master_gone_at: float | None
    live: LiveDisplay | None

    def _answer_info(self, query: zenoh.Query, run_id: int) -> int:
        """Our GPU, whether we are swap-locked, and the nonce a WELCOME must name; the bytes
        sent."""
        swap_locked = self.live is not None and self.live.screen.swap_locked
        message = self._seal(InfoMessage.of_gpu(self.done, self.config.name, self.gpu,
                                                swap_locked, self.view.nonce,
                                                self.scene_digest, self.system.engine,
                                                self.engine_probed), run_id)
        try:
            query.reply(self.keys.info(self.config.name), message)
        except zenoh.ZError as e:  # the master asking went away
            log.info("%s: an info reply failed: %s", self.config.name, zenoh_message(e))
            return 0
        finally:
            query.drop()
        return len(message)

    def _join(self, run_id: int, scene: str, engine: Engine | None) -> None:
        """The master's WELCOME named our nonce: join its run, from the scene's start state
        if we held another run's, stepping with the run's engine path if we probed ours; a
        run of another scene ends the node (ClusterError)."""
        if scene != self.scene_digest:
            raise ClusterError(f"node {self.config.name}: the master's run {run_id:016x} is "
                               f"of scene {scene or 'none'}, this node's --scene "
                               f"{self.config.scene} is {self.scene_digest}: give every "
                               f"host the same scene file")
        previous = self.view.run_id
        if previous is not None and previous != run_id:
            log.warning("%s: a new master's run %016x replaces run %016x: starting over "
                        "from the scene's start state", self.config.name, run_id, previous)
            self._start_over()
        if previous != run_id:
            self.view.heard = 0
        if engine is not None and self.engine_probed and engine is not self.system.engine:
            log.info("%s: the run steps with %s: switching from %s", self.config.name, engine,
                     self.system.engine)
            self.system.use_engine(engine)
        self.view.run_id, self.view.nonce = run_id, secrets.randbits(64)  # nonce used up
        self.master_gone_at = None
        state = self.system.checksum()
        log.info("%s: joined run %016x at frame %d", self.config.name, run_id, self.done)
        self._publish(ReportMessage(self.done, self.config.name, state.digest, state.particles,
                                    state.emitters, NO_COST, self.rejects.total, Status.JOINED))

    def _start_over(self) -> None:
        self.system.restart(self.seed)
        if self.trajectories is not None:
            self.trajectories.restart()
        self.view.done = 0
        self.last_report = self.previous_inputs = None
        if self.live is not None:
            self.live.pending = None

    def _master_presence(self, run_id: int, up: bool) -> None:
        """Only the master of our run counts: another one's token does not hold us."""
        if run_id != self.view.run_id:
            return
        if up:
            self.master_gone_at = None
        elif self.master_gone_at is None:
            self.master_gone_at = time.monotonic()
            if self.config.on_master_loss == "wait":
                log.warning("%s: %s (run %016x); waiting up to %g s for a new master "
                            "(--on-master-loss wait)", self.config.name, MASTER_GONE,
                            self.view.run_id, self.config.master_wait)

    def _check_master(self) -> None:
        """End the node (ClusterError, one line) when no master is there to follow."""
        now, wall, wait = time.monotonic(), self.config.name, self.config.master_wait
        if self.view.run_id is None:
            if now - self.started > wait:
                hint = self.inbox.master_hint() or ("is the master running, with --session "
                                                    f"{self.config.session}?")
                raise ClusterError(f"node {wall}: no master welcomed it within {wait:g} s "
                                   f"(--master-wait): {hint}")
            return
        if self.master_gone_at is not None and self.config.on_master_loss == "exit":
            raise ClusterError(f"node {wall}: the master of run {self.view.run_id:016x} is "
                               f"gone (its liveliness token went away); leaving "
                               f"(--on-master-loss exit)")
        if self.master_gone_at is not None and now - self.master_gone_at > wait:
            raise ClusterError(f"node {wall}: the master of run {self.view.run_id:016x} is "
                               f"gone and no new master came within {wait:g} s "
                               f"(--master-wait, --on-master-loss wait)")
        if now - self.heard > MASTER_SILENCE * wait:
            raise ClusterError(f"node {wall}: nothing from the master of run "
                               f"{self.view.run_id:016x} for {now - self.heard:.0f} s "
                               f"({MASTER_SILENCE} x --master-wait); leaving")
