"""How often a wall may cost the others before the master gives it up, in both modes: one
table of the numbers (`BUDGETS`) and one rule (`Tally.over`).

A wall is resynced after each breach (a divergence, or in the mixed-hardware mode a drift
beyond the tolerance) and waited for after each lag (`stragglers.py`); both cost every other
wall time, and an insider or a broken GPU can cause them every frame. So each is counted per
wall over a sliding window of frames, and the event one past the budget gives the wall up:
out of the lock-step, not resynced again, until its node joins anew (`detected_by` in
report.json's losses is the budget's name).
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass

from cavesim.core.bounded import FirstEntries

log = logging.getLogger("cavesim.master")
BREACH, LAG = "breach-budget", "lag-budget"  # report.json's `detected_by` of a wall given up
BUDGET_RANGE = (1, 10_000)  # events in a window


@dataclass(frozen=True)
class Budget:
    """At most `most` events of one wall in `window` frames; the next one gives it up."""

    most: int
    window: int  # frames

    def __post_init__(self) -> None:
        low, high = BUDGET_RANGE
        if not low <= self.most <= high:
            raise ValueError(f"a budget must allow [{low}, {high}] events, got {self.most!r}")
        if self.window < 1:
            raise ValueError(f"a budget's window must be at least 1 frame, got "
                             f"{self.window!r}")

    def to_json(self) -> dict:
        return {"most": self.most, "window_frames": self.window}


WINDOW = 600  # frames: 10 s at 60 Hz
BUDGETS = {
    # a healthy wall never diverges in the bit-exact mode and drifts past the tolerance now
    # and then in the mixed-hardware one; more than 5 resyncs in 10 s at 60 Hz is a broken
    # GPU or an insider (one made its own wall resync every frame: 150 in 400 frames)
    BREACH: Budget(5, WINDOW),
    # a wall lags now and then (a page fault, a first draw that compiles its programs, a
    # frame message sent again after a stall); six lags of --max-lag in 10 s is a straggler
    # that holds the CAVE, and costs the others at most 6 x its lag before it is given up
    LAG: Budget(5, WINDOW),
}


class Tally:
    """One budget's events of each wall over a run, and the walls it gave up."""

    def __init__(self, name: str, budget: Budget, what: str) -> None:
        """`name`: one of BUDGETS' (the flag and the loss's reason); `what`: the event, for
        the log ("breached", "lagged")."""
        self.name, self.budget, self.what = name, budget, what
        self.recent: dict[str, deque[int]] = {}  # wall -> frames of its events in the window
        self.given_up: FirstEntries[dict] = FirstEntries()

    def over(self, k: int, wall: str) -> bool:
        """Count `wall`'s event at frame k; whether it is one past the budget (then it is
        logged and recorded, and the wall's count starts over)."""
        recent, window = self.recent.setdefault(wall, deque()), self.budget.window
        recent.append(k)
        while recent[0] <= k - window:
            recent.popleft()
        if len(recent) <= self.budget.most:
            return False
        self.given_up.append({"frame": k, "node": wall, "events": len(recent),
                              "window_frames": window})
        log.warning("frame %d: %s %s %d times in %d frames (--%s %d): given up, not waited "
                    "for or resynced again, until its node joins anew; the others go on",
                    k, wall, self.what, len(recent), window, self.name, self.budget.most)
        recent.clear()
        return True

    def summary(self) -> dict:
        return {**self.budget.to_json(), "given_up": list(self.given_up),
                "given_up_total": self.given_up.total}
