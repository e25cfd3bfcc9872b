"""An event list of a run of any length: the first entries, and how many came in all."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TypeVar

T = TypeVar("T")
LIMIT = 1000  # entries kept per list: the first say where a run went wrong, the rest count


class FirstEntries(Sequence[T]):
    """The first `limit` entries appended (a sequence of them), and `total`: all of them."""

    def __init__(self, limit: int = LIMIT) -> None:
        self.limit = limit
        self.total = 0
        self._kept: list[T] = []

    def append(self, entry: T) -> None:
        self.total += 1
        if len(self._kept) < self.limit:
            self._kept.append(entry)

    def __len__(self) -> int:
        return len(self._kept)

    def __getitem__(self, index):
        return self._kept[index]
