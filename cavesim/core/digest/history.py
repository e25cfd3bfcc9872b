"""Which frame's fold-1 items sit in which slot of a node's history ring.

A node copies its fold-1 items (one per block of the state, 16 bytes each) into a ring of
HISTORY_FRAMES slots after every frame, so that on a divergence the master can ask both
nodes since when the blocks of the differing records differ. This is the ring's
bookkeeping; the items themselves stay where the node keeps them (on the GPU).
"""

from __future__ import annotations

from dataclasses import dataclass

HISTORY_FRAMES = 64  # frames a node remembers: 64 x 612 items x 16 B = 627 KB at 1M particles


@dataclass(frozen=True)
class HistoryEntry:
    frame: int
    particles: int  # the live counts of that frame's state: which items were live
    emitters: int
    slot: int


class HistoryRing:
    """Frames -> slots, the newest HISTORY_FRAMES frames kept. Keeping frame k again (the
    state of k was replaced by a resync) reuses its slot; keeping k drops any frame after
    it (a history the node no longer holds)."""

    def __init__(self, slots: int = HISTORY_FRAMES) -> None:
        if slots < 1:
            raise ValueError(f"a history ring needs at least one slot, got {slots=}")
        self.slots = slots
        self._entries: dict[int, HistoryEntry] = {}  # by frame, oldest first

    def keep(self, frame: int, particles: int, emitters: int) -> int:
        """The slot to write frame `frame`'s items to, now recorded with its counts."""
        again = self._entries[frame].slot if frame in self._entries else None
        for later in [f for f in self._entries if f >= frame]:
            self._free(later)
        used = {entry.slot for entry in self._entries.values()}
        if again is not None:
            slot = again
        elif len(used) == self.slots:
            slot = self._free(min(self._entries))
        else:
            slot = min(set(range(self.slots)) - used)
        self._entries[frame] = HistoryEntry(frame, particles, emitters, slot)
        return slot

    def up_to(self, frame: int) -> list[HistoryEntry]:
        """The kept frames at or before `frame`, oldest first."""
        return sorted((e for f, e in self._entries.items() if f <= frame),
                      key=lambda e: e.frame)

    def clear(self) -> None:
        """Forget every frame (the node starts a run over)."""
        self._entries.clear()

    def _free(self, frame: int) -> int:
        return self._entries.pop(frame).slot
