"""Who holds the barrier: a member whose report of a frame comes more than --max-lag after
half the members' had lags. Each lag is named (the log, report.json's `lags`: frame, node,
seconds) and counted against the lag budget (`budgets.py`); the lag one past it gives the
wall up, so that the others go on at their own rate.

A lag is measured from the moment half the members had reported (the lower median: the
first of two, the second of three or four), not from the frame's publication: a scene that
is slow on every wall is the cluster's pace, not a straggler, and one wall that is fast
makes no other a straggler. One member never lags. A member still missing when the barrier
ends (evicted as silent) lagged until then; one whose node went away did not lag. The
reports' times are those at which the master's link took them (`Reported.at`), so a master
busy with something else does not make a lag.

The bookkeeping takes its times as arguments (`FrameArrivals`): the master gives it the
clock's, the tests their own.
"""

from __future__ import annotations

import logging
from collections.abc import Collection
from dataclasses import dataclass

from cavesim.core.bounded import FirstEntries
from nodes.master.budgets import LAG, Budget, Tally

log = logging.getLogger("cavesim.master")
# s. A CAVE at 60 Hz has 17 ms a frame, and a healthy wall on its own GPU reports within a
# few ms of the others. On llvmpipe the four walls of flex4_hd (projector resolution) drew
# a frame in 0.27 to 0.49 s (p50; 0.58 s at most), by their content: the walls of a healthy
# run differ by up to about a third of a second there, and the default must not give one
# of them up. One second is half the default --barrier-timeout (a lag is named before it
# is a stall) and 60 frames of a CAVE: a wall that lags it every frame holds the CAVE under
# 1 frame/s. On a CAVE whose GPUs keep 60 Hz, give --max-lag 0.1 (6 frames).
DEFAULT_MAX_LAG = 1.0


@dataclass(frozen=True)
class Lag:
    frame: int
    node: str
    seconds: float  # after half the members had reported: until its report, or the end

    def to_json(self) -> dict:
        return {"frame": self.frame, "node": self.node, "seconds": round(self.seconds, 4)}


class FrameArrivals:
    """When each member's first report of frame `frame` came."""

    def __init__(self, frame: int, members: tuple[str, ...]) -> None:
        self.frame, self.members = frame, members
        self.arrived: dict[str, float] = {}

    def reported(self, node: str, at: float) -> None:
        if node in self.members and node not in self.arrived:
            self.arrived[node] = at

    def half_in(self) -> float | None:
        """When half the members (rounded up) had reported; None until they have."""
        times = sorted(self.arrived.values())
        half = (len(self.members) + 1) // 2
        return times[half - 1] if len(times) >= half else None

    def lags(self, max_lag: float, now: float, alive: Collection[str]) -> list[Lag]:
        """The members (still up) that reported more than `max_lag` after half had, or had
        not reported by `now`, the end of the frame's barrier."""
        half = self.half_in()
        if half is None:
            return []
        return [Lag(self.frame, node, self.arrived.get(node, now) - half)
                for node in self.members
                if node in alive and self.arrived.get(node, now) - half > max_lag]


class Stragglers:
    """The lags of one run: the frame in the barrier, the lags named, the budget."""

    def __init__(self, max_lag: float, budget: Budget, lags: FirstEntries[Lag]) -> None:
        """`lags`: the run record's list to name them in."""
        if not max_lag > 0:
            raise ValueError(f"max_lag must be > 0 s, got {max_lag!r}")
        self.max_lag, self.lags = max_lag, lags
        self.tally = Tally(LAG, budget, "lagged")
        self.frame = FrameArrivals(0, ())

    def begin(self, k: int, members: tuple[str, ...]) -> None:
        """Frame k goes out to `members`."""
        self.frame = FrameArrivals(k, members)

    def reported(self, node: str, at: float) -> None:
        """A report of the frame in the barrier came from `node` at `at` (monotonic s)."""
        self.frame.reported(node, at)

    def end(self, now: float, alive: Collection[str]) -> list[str]:
        """The frame's barrier is over at `now`: name each lag; the walls past the budget,
        to give up."""
        over = []
        for lag in self.frame.lags(self.max_lag, now, alive):
            self.lags.append(lag)
            log.warning("frame %d: %s held the barrier %.3f s after half the members had "
                        "reported (--max-lag %g s)", lag.frame, lag.node, lag.seconds,
                        self.max_lag)
            if self.tally.over(lag.frame, lag.node):
                over.append(lag.node)
        return over
