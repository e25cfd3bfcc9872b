"""A node's clock of its frame's phases (cavesim/core/frame_cost.py): the times its
report of a frame carries."""

from __future__ import annotations

import time

from cavesim.core.frame_cost import GPU_PHASES, MAX_PHASE_US, NOT_TIMED_US, PHASES
from cavesim.gpu.engine.pass_timers import GPU_TIMED_EVERY, PassTimers
from cavesim.gpu.gl.fence import GpuFence


class FrameTimer:
    """Laps of a CPU clock (time.perf_counter): `arrived` when a frame's message is in hand,
    `lap(phase)` after each phase up to the report, `reported` once it went out and
    `rendered` once the walls were drawn. What a lap spent waiting on the GPU's `fence` goes
    to gpu_sync instead; `gpu_passes` takes the GPU timers' times once the frame is done."""

    def __init__(self, fence: GpuFence, timers: PassTimers) -> None:
        self._fence, self._timers = fence, timers
        self._seconds: dict[str, float | None] = dict.fromkeys(PHASES, 0.0)  # None: not timed
        self._mark = time.perf_counter()
        self._ready_at: float | None = None  # the frame before reported (and drawn)

    def arrived(self) -> None:
        now = time.perf_counter()
        self._seconds["input_wait"] = 0.0 if self._ready_at is None else now - self._ready_at
        self._seconds["gpu_sync"] = 0.0
        self._fence.take_waited()  # waits between frames (a snapshot served) are not ours
        self._mark = now

    def lap(self, phase: str) -> None:
        now = time.perf_counter()
        waited = self._fence.take_waited()
        self._seconds[phase] = now - self._mark - waited
        self._seconds["gpu_sync"] += waited
        self._mark = now

    def arm_gpu(self, k: int) -> None:
        """Time frame k's passes on the GPU if it is one of the sampled frames."""
        self._timers.armed = k % GPU_TIMED_EVERY == 0

    def gpu_passes(self) -> None:
        """The GPU's times of this frame's passes (after the frame's last wait); a frame
        not timed carries NOT_TIMED_US for them."""
        times = self._timers.read_us()
        for name in GPU_PHASES:
            self._seconds[name] = None if times is None else times[name] / 1e6

    def cost_us(self) -> tuple[int, ...]:
        """This frame's phases so far and the frame before's report and drawing, in
        microseconds (at most MAX_PHASE_US)."""
        return tuple(NOT_TIMED_US if (seconds := self._seconds[phase]) is None
                     else min(int(seconds * 1e6), MAX_PHASE_US) for phase in PHASES)

    def reported(self) -> None:
        self.lap("report")
        self._ready_at = self._mark
        self._seconds["render"] = 0.0  # a frame not drawn costs nothing to draw

    def rendered(self) -> None:
        self.lap("render")
        self._ready_at = self._mark
