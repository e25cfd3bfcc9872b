"""A wall node's clock of its frame's phases (cavesim/core/frame_cost.py): the times its
report of a frame carries."""

from __future__ import annotations

import time

from cavesim.core.frame_cost import MAX_PHASE_US, PHASES

AFTER_THE_REPORT = ("report", "render")  # timed after the report they travel in went out


class FrameTimer:
    """Laps of a CPU clock (time.perf_counter): `arrived` when a frame's message is in hand,
    `lap(phase)` after each phase up to the report, `reported` once it went out and
    `rendered` once the wall was drawn. Allocates nothing per frame but the report's tuple."""

    def __init__(self) -> None:
        self._seconds = dict.fromkeys(PHASES, 0.0)
        self._mark = time.perf_counter()
        self._ready_at: float | None = None  # the frame before reported (and drawn)

    def arrived(self) -> None:
        now = time.perf_counter()
        self._seconds["input_wait"] = 0.0 if self._ready_at is None else now - self._ready_at
        self._mark = now

    def lap(self, phase: str) -> None:
        now = time.perf_counter()
        self._seconds[phase] = now - self._mark
        self._mark = now

    def cost_us(self) -> tuple[int, ...]:
        """This frame's phases so far and the frame before's report and drawing, in
        microseconds (at most MAX_PHASE_US)."""
        return tuple(min(int(self._seconds[phase] * 1e6), MAX_PHASE_US) for phase in PHASES)

    def reported(self) -> None:
        self.lap("report")
        self._ready_at = self._mark
        self._seconds["render"] = 0.0  # a frame not drawn costs nothing to draw

    def rendered(self) -> None:
        self.lap("render")
        self._ready_at = self._mark
