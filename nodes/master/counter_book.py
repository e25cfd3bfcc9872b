"""The master's book of the run's counters: every row of cavesim/core/counters.py the scene
counts, kept as its row says, from the counts the members agreed on each frame
(`nodes/lockstep.py` `agree_counts`), never from one wall's word alone; in the
mixed-hardware mode, whose walls' bits differ, from the authority's (said in report.json).

Per row it keeps a total (events), the first frame each value was nonzero, the values of
every frame summed into bins of a doubling stride (`BinnedSums`: no count is lost, only the
frames it is told apart by; a level's bins say the mean of their frames), and the largest
value with its frame; and how many frames no member counted it (`frames_not_counted`: an
engine path that cannot count there) or its counters did not agree (`frames_unagreed`). A
row's notice is logged once, at the first frame it is nonzero, and kept for `cavesim run`'s
terminal (`notices`). report.json's `counters` section is `summary()`: per row, keyed by
its name, and beside them how the values were chosen, the frame's seconds (for rates) and,
per wall, the counter entries its reports carried that the run does not count
(`unknown_ids_skipped`).
"""

from __future__ import annotations

import logging
from collections import Counter as Tally
from collections.abc import Collection, Mapping

from cavesim.core.bounded import BinnedSums
from cavesim.core.counters import Counter, Keep, counted_rows
from cavesim.core.scene.model import Scene

log = logging.getLogger("cavesim.master")

AGREED, AUTHORITY = "agreed", "authority"  # counters.values_from
SECTION_KEYS = ("values_from", "frame_seconds", "unknown_ids_skipped")  # beside the rows


class RowBook:
    """One counter over a run: what its row keeps."""

    def __init__(self, row: Counter, scene: Scene) -> None:
        self.row = row
        self.names = row.value_names(scene)
        width = len(self.names)
        self.bins = BinnedSums(width)
        self.first: list[int | None] = [None] * width
        self.largest: list[tuple[int, int | None]] = [(0, None)] * width
        self.not_counted = self.unagreed = 0

    def add(self, k: int, values: tuple[int, ...] | None) -> bool:
        """Frame k's agreed values (None: none agreed); whether they are its first nonzero."""
        if values is None or len(values) != len(self.names):
            values = (0,) * len(self.names)
        first = any(values) and not any(f is not None for f in self.first)
        self.bins.add(values)
        for i, n in enumerate(values):
            if n and self.first[i] is None:
                self.first[i] = k
            if n > self.largest[i][0]:
                self.largest[i] = (n, k)
        return first

    def summary(self) -> dict:
        """report.json's entry: what the row keeps, a class's values keyed by its name."""
        row, keeps = self.row, self.row.keeps

        def shaped(values: list):
            if row.per_class:
                return dict(zip(self.names, values, strict=True))
            return values[0] if row.values == 1 else list(values)

        out: dict = {"id": row.id, "label": row.label, "unit": row.unit,
                     "events": row.events}
        if row.per_class:
            out["classes"] = list(self.names)
        if Keep.TOTAL in keeps:
            out["total"] = shaped(self.bins.totals)
        if Keep.FIRST in keeps:
            out["first_frame"] = shaped(self.first)
        if Keep.LARGEST in keeps:
            out["largest"] = shaped([n for n, _ in self.largest])
            out["largest_frame"] = shaped([k for _, k in self.largest])
        if Keep.BINNED in keeps:
            # per bin of `per_frame_stride` frames (1 up to 4,096 frames); none while every
            # value was 0, so that a quiet row does not grow the report
            # (a level's: the mean of its frames in each bin)
            seen = any(largest for largest, _ in self.largest)
            bins = self.bins.bins() if row.events else [
                [round(v, 2) for v in b] for b in self.bins.means()]
            out["per_frame"] = [shaped(b) for b in bins] if seen else []
            out["per_frame_stride"] = self.bins.stride
        out["frames_not_counted"] = self.not_counted
        out["frames_unagreed"] = self.unagreed
        return out


class CounterBook:
    """The run's counters (see the module docstring)."""

    def __init__(self, scene: Scene, frame_seconds: float, values_from: str = AGREED) -> None:
        self.scene = scene
        self.frame_seconds = frame_seconds  # the master's dt
        self.values_from = values_from
        self.rows = {row.id: RowBook(row, scene) for row in counted_rows(scene)}
        assert not {book.row.name for book in self.rows.values()} & set(SECTION_KEYS)
        self.skipped: Tally[str] = Tally()
        self.notices: list[str] = []
        if values_from == AUTHORITY:
            log.info("mixed-hardware mode: the counters kept are the authority's (its walls' "
                     "bits, and so their counts, may differ)")

    def add(self, k: int, counts: Mapping[int, tuple[int, ...]],
            unagreed: Collection[int] = ()) -> None:
        """Frame k's agreed counters by id; `unagreed`: ids counted without agreement."""
        for id_, book in self.rows.items():
            values = counts.get(id_)
            if values is None:
                book.unagreed += id_ in unagreed
                book.not_counted += id_ not in unagreed
            if book.add(k, values) and book.row.notice is not None:
                notice = book.row.notice(self.scene, k, values)
                log.warning("%s", notice)
                self.notices.append(notice)

    def skip(self, skipped: Mapping[str, int]) -> None:
        """Counter entries each wall reported that the run does not count."""
        self.skipped.update(skipped)

    def summary(self) -> dict:
        """report.json's `counters`: each row by name, and how its values were chosen."""
        return {"values_from": self.values_from,
                "frame_seconds": round(self.frame_seconds, 9),
                "unknown_ids_skipped": dict(sorted(self.skipped.items())),
                **{book.row.name: book.summary() for book in self.rows.values()}}
