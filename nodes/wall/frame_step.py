"""A wall node's frames (a part of `WallNode`, nodes/wall/process.py): frame k steps the
state, takes its checksum (the frame's one wait) and the frame's counters, keeps the checksum
tree's history, and reports k with the phases' times; a repeated frame repeats the report; a
frame ahead of ours reports BEHIND (at most every BEHIND_EVERY) and waits for a resync, and
so does our next frame when a newer one came after it (the master went on without us: a
member never gets frame k + 1 before it reported k), so that a node left out of the
lock-step (evicted, given up) does not step every frame queued behind the others' and takes
the master's STOP when it comes. The node's own injected faults act here
(`nodes/faults.py`), and the trajectories follow each step after its report.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from typing import TYPE_CHECKING

from cavesim.core.counters import entries
from cavesim.core.digest.shape import PARTICLES
from cavesim.core.drift import DriftSample
from cavesim.core.errors import ProtocolError, TrajectoryError
from cavesim.core.frame import FrameInput
from cavesim.core.frame_cost import NO_COST
from cavesim.core.record_diff import field_bit
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene_frame import SceneFrame
from cavesim.core.trajectories import TrajectoryRecording
from cavesim.core.wire import FrameMessage, ReportMessage
from cavesim.core.wire.payloads.from_nodes import Status
from cavesim.core.wire.rejects import RejectCounter
from cavesim.gpu.engine import ParticleSystem
from nodes.faults import bitflip_target, inflated
from nodes.wall.drift_sample import DRIFT_FAULTS, read_drift_sample
from nodes.wall.frame_timer import FrameTimer
from nodes.wall.inbox import NodeView
from nodes.wall.settings import NodeConfig

if TYPE_CHECKING:
    from cavesim.core.drivers.scene_driver import SceneDriver
    from cavesim.gpu.render.painter import WallPainter
    from nodes.wall.screen import LiveDisplay

log = logging.getLogger("cavesim.node")
BEHIND_EVERY = 1.0  # s between two BEHIND reports


class FrameStep:
    """Stepping and reporting the master's frames (see the module docstring). Of the node
    it uses the attributes below, `done`, `_fault` (a due injected fault) and `_publish`."""

    config: NodeConfig
    system: ParticleSystem
    view: NodeView
    rejects: RejectCounter
    driver: SceneDriver
    timer: FrameTimer
    live: LiveDisplay | None
    painter: WallPainter | None
    seed: int
    last_report: ReportMessage | None
    previous_inputs: FrameInput | None
    behind_said: float
    trajectories: TrajectoryRecording | None

    def _on_frame(self, message: FrameMessage) -> None:
        k = message.frame
        if k == self.done and self.last_report is not None:
            self._publish(dataclasses.replace(self.last_report, status=Status.REPEATED))
        elif self.done < k < self.view.heard:  # a newer frame is out: the run went on
            self._behind(self.view.heard)
        elif k == self.done + 1:
            if self._fault("drop", k):  # lose this copy; the master's retransmit gets through
                log.warning("%s: fault: dropped frame %d", self.config.name, k)
                return
            self.timer.arrived()
            try:
                scene = self.driver.decode(message.params)
            except ProtocolError as e:
                self.rejects.reject(e, f"frame {k}")
                return
            self.timer.lap("decode")
            self.timer.arm_gpu(k)
            self._step(k, message.inputs, scene, message.reset)
            if self.live is not None:
                self.live.show(k, message, scene)
                self.timer.rendered()
            elif self.painter is not None and k % self.config.render_every == 0:
                self.painter.paint(k, message, scene)
                self.timer.rendered()
        elif k > self.done + 1:
            self._behind(k)

    def _behind(self, k: int) -> None:
        """Frame k is ahead of ours: ask the master for a resync (at most every second)."""
        now = time.monotonic()
        if now - self.behind_said < BEHIND_EVERY:
            return
        self.behind_said = now
        log.info("%s: frame %d is ahead of our frame %d; asking for a resync",
                 self.config.name, k, self.done)
        state = self.system.checksum()
        self._publish(ReportMessage(self.done, self.config.name, state.digest, state.particles,
                                    state.emitters, NO_COST, self.rejects.total, Status.BEHIND),
                      keep=False)

    def _step(self, k: int, inputs: FrameInput, scene: SceneFrame, reset: bool) -> None:
        if reset:  # the master's reset: the scene's start state, then this frame's step
            self.system.restart(self.seed)
            if self.trajectories is not None:
                self.trajectories.restart()
        used = inputs
        if self._fault("stale", k) and self.previous_inputs is not None:
            used = FrameInput(inputs.dt, self.previous_inputs.random_transform)
        self.system.step(used, scene)
        self.timer.lap("step")
        if self._fault("bitflip", k) and self.system.live_count:
            self._flip_one_bit()
        for kind, perturb in DRIFT_FAULTS.items():
            if self._fault(kind, k):
                perturb(self.system)
                log.warning("%s: fault: %s at frame %d", self.config.name, kind, k)
        self.previous_inputs = inputs
        self.view.done = k
        state = self.system.checksum()
        self.timer.lap("checksum")
        self.timer.gpu_passes()
        self.system.keep_history(k)
        self.timer.lap("history")
        if self._fault("slow", k):
            time.sleep(self.config.slow_delay)
        if self._fault("straggler", k):
            log.warning("%s: fault: every frame from %d on takes %g s more", self.config.name,
                        k, self.config.straggle_delay)
        if any(f.kind == "straggler" and f.frame <= k for f in self.config.faults):
            time.sleep(self.config.straggle_delay)
        counted = entries(self.system.counters())  # read after the checksum's wait
        if self._fault("inflate", k):
            counted = inflated(counted)
            log.warning("%s: fault: reported %s counters at frame %d", self.config.name,
                        "inflated" if counted else "no (this scene counts none), so no", k)
        self._publish(ReportMessage(k, self.config.name, state.digest, state.particles,
                                    state.emitters, self.timer.cost_us(), self.rejects.total,
                                    sample=self._sample(), counters=counted))
        self.timer.reported()
        if self.trajectories is not None:  # after the report: the barrier does not wait on it
            self._follow_trajectories(k, used.dt)

    def _follow_trajectories(self, k: int, dt: float) -> None:
        """Follow frame k's step. A lost stream drops the file, not the run; a write that
        fails (OutputError) ends the node, and so the run, as every failed write does."""
        try:
            self.trajectories.after_step(k, dt, self.system)
        except TrajectoryError as e:
            log.error("%s: frame %d: %s; trajectories.parquet is not written",
                      self.config.name, k, e)
            self.trajectories = None

    def finish_trajectories(self) -> None:
        """The run is over (STOP): give trajectories.parquet its footer and its name."""
        if self.trajectories is not None:
            path = self.trajectories.finish()
            log.info("%s: wrote %s (%d rows)", self.config.name, path,
                     self.trajectories.recorder.rows)

    def _flip_one_bit(self) -> None:
        """Flip the bit `bitflip_target` names, in that one record (patched on the GPU)."""
        target = bitflip_target(self.system.live_count)
        record = bytearray(self.system.read_records(PARTICLES, [target.particle]))
        record[target.word * 4 + target.bit // 8] ^= 1 << target.bit % 8
        self.system.begin_patch()
        self.system.write_particle_chunk(target.particle, bytes(record))
        self.system.commit_load()
        field, bit = field_bit(PARTICLE_DTYPE, target.word, target.bit)
        log.warning("%s: fault: flipped bit %d of particle %d's %s", self.config.name, bit,
                    target.particle, field.name)

    def _sample(self) -> DriftSample | None:
        """The mixed-hardware mode's drift sample of the state we hold (else None)."""
        if not self.config.drift_sample:
            return None
        return read_drift_sample(self.system, self.config.drift_sample)
