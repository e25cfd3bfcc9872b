"""A per-frame series of a run of any length in a fixed number of points (the live
particle count, the helicopter's flight log)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Generic, TypeVar

T = TypeVar("T")
CAPACITY = 4096  # points: a plot's worth, 1,000 px wide


class DecimatedSeries(Generic[T]):
    """The values of frames 1, 2, 3, ..., appended in order, kept at most `capacity` at a
    time: once full, every other point goes and the stride doubles, so point i is always
    the value of frame (i + 1) * stride. A run of up to `capacity` frames keeps every
    frame; `last` is always the latest value."""

    def __init__(self, capacity: int = CAPACITY) -> None:
        if capacity < 2 or capacity % 2:
            raise ValueError(f"capacity must be even and >= 2, got {capacity=!r}")
        self.capacity = capacity
        self.stride = 1  # frames between points
        self.count = 0  # values appended
        self.last: T | None = None
        self._points: list[T] = []

    def append(self, value: T) -> None:
        self.count += 1
        self.last = value
        if self.count % self.stride:
            return
        if len(self._points) == self.capacity:
            del self._points[::2]  # frames stride, 3 stride, ...: the rest are 2 stride apart
            self.stride *= 2
            if self.count % self.stride:
                return
        self._points.append(value)

    def frames(self) -> range:
        """The frame of each point."""
        return range(self.stride, self.stride * (len(self._points) + 1), self.stride)

    def __len__(self) -> int:
        return len(self._points)

    def __iter__(self) -> Iterator[T]:
        return iter(self._points)
