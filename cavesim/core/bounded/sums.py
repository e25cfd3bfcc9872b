"""Per-frame counts of a run of any length, summed into a fixed number of bins (the
particles of each class leaving the field's box, those the capacity dropped): unlike a
thinned series, no count is lost, only the frames it is told apart by."""

from __future__ import annotations

from cavesim.core.bounded.series import CAPACITY


class BinnedSums:
    """Counts per frame (a tuple of `width` integers), frames 1, 2, 3, ... in order, summed
    into bins of `stride` frames: bin i holds frames i * stride + 1 ... (i + 1) * stride.
    Once `capacity` bins are full, neighbours merge and the stride doubles. A run of up to
    `capacity` frames keeps every frame's counts; `totals` are always exact."""

    def __init__(self, width: int, capacity: int = CAPACITY) -> None:
        if capacity < 2 or capacity % 2:
            raise ValueError(f"capacity must be even and >= 2, got {capacity=!r}")
        self.width = width
        self.capacity = capacity
        self.stride = 1
        self.count = 0  # frames added
        self.totals = [0] * width
        self._bins: list[list[int]] = []

    def add(self, counts: tuple[int, ...]) -> None:
        if len(counts) != self.width:
            raise ValueError(f"expected {self.width} counts, got {len(counts)}")
        if self.count % self.stride == 0:  # the frame opens a bin
            if len(self._bins) == self.capacity:
                self._bins = [[a + b for a, b in zip(self._bins[i], self._bins[i + 1],
                                                     strict=True)]
                              for i in range(0, self.capacity, 2)]
                self.stride *= 2
            if self.count % self.stride == 0:
                self._bins.append([0] * self.width)
        self.count += 1
        for i, n in enumerate(counts):
            self._bins[-1][i] += n
            self.totals[i] += n

    def bins(self) -> list[list[int]]:
        """Each bin's sums, oldest first (the last may hold fewer than `stride` frames)."""
        return [list(b) for b in self._bins]

    def rates(self, frame_seconds: float) -> list[list[float]]:
        """Each bin's sums per second of the frames it holds, `frame_seconds` each."""
        return [[n / (held * frame_seconds) for n in b]
                for b, held in zip(self._bins, self._held(), strict=True)]

    def means(self) -> list[list[float]]:
        """Each bin's sums over the frames it holds: a level's mean per frame."""
        return [[n / held for n in b] for b, held in zip(self._bins, self._held(), strict=True)]

    def _held(self) -> list[int]:
        """The frames each bin holds: `stride`, the last perhaps fewer."""
        frames = [self.stride] * len(self._bins)
        if frames:
            frames[-1] = self.count - self.stride * (len(self._bins) - 1)
        return frames
