"""The new particles a full capacity dropped, per frame, as the run's nodes count them
(`cavesim.gpu.engine.drops`): the master keeps the agreed node's count of each frame and
says so once, at the first frame that dropped any. The count follows from the agreed
state of the frame before and the frame's inputs, so every node that agrees holds it."""

from __future__ import annotations

import logging

from cavesim.core.bounded import BinnedSums

log = logging.getLogger("cavesim.master")

REPORT_KEY = "capacity_drops"  # report.json's section


class CapacityDropBook:
    """Drops in all, the first frame that had any, and each frame's (binned past 4,096
    frames) as dropped particles per second of simulated time."""

    def __init__(self, capacity: int, frame_seconds: float) -> None:
        self.capacity = capacity
        self.frame_seconds = frame_seconds  # the master's dt
        self.frames = BinnedSums(1)
        self.first: tuple[int, int] | None = None  # (frame, particles dropped in it)

    def add(self, k: int, dropped: int) -> None:
        """Frame k's count from the node holding the agreed state."""
        self.frames.add((dropped,))
        if dropped and self.first is None:
            self.first = (k, dropped)
            log.warning("%s", self.notice)

    @property
    def notice(self) -> str | None:
        """The one line that says the capacity dropped particles; None while it has not."""
        if self.first is None:
            return None
        k, dropped = self.first
        return (f"capacity full: {dropped:,} new particles dropped at frame {k} (the scene "
                f"holds {self.capacity:,}); report.json counts every frame's "
                f"({REPORT_KEY}.dropped_per_second)")

    def summary(self) -> dict:
        """report.json's capacity_drops."""
        k, dropped = self.first or (None, 0)
        return {
            "capacity": self.capacity,
            "total": self.frames.totals[0],
            "first_frame": k,
            "dropped_at_first_frame": dropped,
            # per bin of `bin_frames` frames (1 up to 4,096 frames), new particles dropped
            # per second of simulated time; none in a run that dropped nothing, whose report
            # then grows no faster than before (its final write fits the space checkpoints
            # keep in reserve)
            "dropped_per_second": [round(rate, 1)
                                   for (rate,) in self.frames.rates(self.frame_seconds)]
            if self.first is not None else [],
            "bin_frames": self.frames.stride,
            "bin_seconds": round(self.frames.stride * self.frame_seconds, 6),
        }
