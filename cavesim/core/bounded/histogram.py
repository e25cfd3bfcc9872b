"""Percentiles of a long run's durations (the barrier's round trip, the swap skew) from a
histogram of fixed size, in place of a list of every value."""

from __future__ import annotations

import math

import numpy as np

LOW, HIGH = 1e-6, 1e3  # s: the range binned within the relative error
BINS_PER_DECADE = 2000
DECADES = round(math.log10(HIGH / LOW))
BINS = DECADES * BINS_PER_DECADE
# a value in [edge, edge * ratio) is read as the bin's geometric middle, edge * sqrt(ratio)
RELATIVE_ERROR = 10 ** (0.5 / BINS_PER_DECADE) - 1  # 5.76e-4: 3 significant digits


class LogHistogram:
    """Counts of non-negative values in log-spaced bins, and the exact count, min and max.

    `percentile(q)` is numpy's default (linear) percentile of the values appended, within
    RELATIVE_ERROR (0.058 %) of it for values in [1 us, 1000 s); values under 1 us are read
    within 0.5 us, values from 1000 s on as the maximum. q = 0 and q = 100 are exact (the min
    and max). Memory: 18,002 counters (144 KB), however many values come.
    """

    def __init__(self) -> None:
        self._counts = np.zeros(BINS + 2, dtype=np.int64)  # [under LOW, BINS..., from HIGH]
        self.count = 0
        self.min = math.inf
        self.max = -math.inf

    def append(self, value: float) -> None:
        """Count one value (list-like, so a caller that kept a list of values keeps working)."""
        if not value >= 0.0 or value == math.inf:
            raise ValueError(f"a histogram value must be finite and >= 0, got {value=!r}")
        if value < LOW:
            index = 0
        else:
            index = min(BINS + 1, 1 + int(math.log10(value / LOW) * BINS_PER_DECADE))
        self._counts[index] += 1
        self.count += 1
        self.min = min(self.min, value)
        self.max = max(self.max, value)

    def percentile(self, q: float) -> float | None:
        """The q-th percentile (0..100) as numpy interpolates it, None without values."""
        if not 0 <= q <= 100:
            raise ValueError(f"a percentile must be in [0, 100], got {q=!r}")
        if not self.count:
            return None
        rank = (self.count - 1) * q / 100
        below = math.floor(rank)
        cumulative = np.cumsum(self._counts)
        low = self._value_of_rank(below, cumulative)
        high = self._value_of_rank(min(below + 1, self.count - 1), cumulative)
        return low + (rank - below) * (high - low)

    def percentiles_ms(self) -> dict[str, float | None]:
        """p50, p99 and max in milliseconds, to the microsecond (a report's figures)."""
        return {name: None if (value := self.percentile(q)) is None else round(value * 1e3, 3)
                for name, q in (("p50", 50), ("p99", 99), ("max", 100))}

    def _value_of_rank(self, rank: int, cumulative: np.ndarray) -> float:
        """The rank-th smallest value (0-based), within the error bound."""
        if rank == 0:
            return self.min
        if rank == self.count - 1:
            return self.max
        index = int(np.searchsorted(cumulative, rank, side="right"))
        if index == 0:
            middle = LOW / 2
        elif index == BINS + 1:
            middle = self.max
        else:
            middle = LOW * 10 ** ((index - 0.5) / BINS_PER_DECADE)
        return min(max(middle, self.min), self.max)
