"""The swap barrier's book: which displaying wall drew and swapped which frame, when.

The master releases frame k's SWAP once every swap-locked wall has drawn k (or its barrier
timeout passed, a swap stall), and sends frame k + 1 once they have all swapped k (or it
gave up waiting: an incomplete frame). Each wall sends its monotonic clock with DRAWN and
SWAPPED; on one machine the clocks are one, so a released frame whose expected walls have
all swapped gives a skew (latest swap - earliest swap) and tells whether any wall swapped
before the last one had drawn (a broken barrier). Its memory does not grow with the run: the
skews go into a histogram, the stalled frames keep their first 1,000 and a count.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from cavesim.core.bounded import FirstEntries, LogHistogram
from cavesim.core.wire import DisplayMessage
from cavesim.core.wire.payloads.from_nodes import Phase

WINDOW = 120  # frames a late DRAWN or SWAPPED of a finished frame is kept


@dataclass
class SwapBook:
    walls: set[str] = field(default_factory=set)  # every wall ever swap-locked
    skews: LogHistogram = field(default_factory=LogHistogram)  # s, one per finished frame
    order_violations: int = 0  # finished frames where a swap came before the last drawing
    # frames released without every DRAWN
    stalls: FirstEntries[int] = field(default_factory=FirstEntries)
    incomplete: int = 0  # released frames the master stopped waiting for every SWAPPED of
    _expected: dict[int, frozenset[str]] = field(default_factory=dict)
    _drawn: dict[int, dict[str, int]] = field(default_factory=dict)
    _swapped: dict[int, dict[str, int]] = field(default_factory=dict)

    def drawn(self, k: int) -> set[str]:
        return set(self._drawn.get(k, ()))

    def settled(self, k: int) -> bool:
        """Whether every wall frame k's SWAP went to has said SWAPPED k (or k was never
        released, or was given up on)."""
        return k not in self._expected

    def released(self, k: int, walls: tuple[str, ...], stalled: bool) -> None:
        """Frame k's SWAP went out to `walls` (every swap-locked member)."""
        self.walls |= set(walls)
        self._expected[k] = frozenset(walls)
        if stalled:
            self.stalls.append(k)
        self._finish(k)
        for old in [f for f in (*self._drawn, *self._swapped) if f < k - WINDOW]:
            self._forget(old)

    def give_up(self, k: int) -> None:
        """The master stopped waiting for frame k's SWAPPED (a wall's swap hung or was lost)."""
        if not self.settled(k):
            self.incomplete += 1
            self._forget(k)

    def note(self, message: DisplayMessage) -> None:
        times = self._drawn if message.phase is Phase.DRAWN else self._swapped
        times.setdefault(message.frame, {})[message.node] = message.time_ns
        self._finish(message.frame)

    def _finish(self, k: int) -> None:
        walls = self._expected.get(k)
        swapped = self._swapped.get(k, {})
        if walls is None or not walls <= swapped.keys():
            return
        swaps = [swapped[w] for w in walls]
        drawn = [self._drawn.get(k, {}).get(w) for w in walls]
        self.skews.append((max(swaps) - min(swaps)) / 1e9)
        if None in drawn or min(swaps) < max(drawn):
            self.order_violations += 1
        self._forget(k)

    def _forget(self, k: int) -> None:
        for book in (self._expected, self._drawn, self._swapped):
            book.pop(k, None)

    def summary(self) -> dict:
        """report.json's "swap" section ("stalls": the first 1,000 stalled frames)."""
        return {"walls": sorted(self.walls), "frames": self.skews.count,
                "skew_ms": self.skews.percentiles_ms(),
                "order_violations": self.order_violations, "stalls": list(self.stalls),
                "stalls_total": self.stalls.total, "incomplete": self.incomplete}
