"""The fixed-size records of a long run: percentiles within their stated bound of numpy's,
decimated series on the frames they name, binned sums that lose no count, first entries and
their total."""

import math

import numpy as np
import pytest

from cavesim.core.bounded import BinnedSums, DecimatedSeries, FirstEntries, LogHistogram
from cavesim.core.bounded.histogram import HIGH, LOW, RELATIVE_ERROR

QUANTILES = (0, 0.1, 1, 25, 50, 75, 90, 99, 99.9, 100)


def histogram_of(values) -> LogHistogram:
    histogram = LogHistogram()
    for value in values:
        histogram.append(float(value))
    return histogram


@pytest.mark.parametrize("values", [
    np.random.default_rng(1).lognormal(math.log(2e-3), 0.6, 100_000),  # barrier-like, s
    np.random.default_rng(2).uniform(LOW, 10.0, 20_000),  # seven decades
    np.random.default_rng(3).integers(1, 5, 5_000) * 1e-3,  # many equal values
    np.array([0.25]),
    np.array([3e-3, 1e-3]),
], ids=["lognormal", "uniform", "ties", "one", "two"])
def test_percentiles_are_within_the_stated_bound_of_numpys(values):
    histogram = histogram_of(values)
    assert RELATIVE_ERROR < 6e-4  # three significant digits
    for q in QUANTILES:
        exact = float(np.percentile(values, q))
        assert histogram.percentile(q) == pytest.approx(exact, rel=RELATIVE_ERROR, abs=0), q
    assert histogram.percentile(100) == values.max() and histogram.percentile(0) == values.min()
    assert histogram.count == len(values)


def test_values_outside_the_binned_range():
    tiny = np.array([0.0, 1e-9, 4e-7, 2e-7, 9e-7])
    histogram = histogram_of(tiny)
    for q in QUANTILES:
        assert abs(histogram.percentile(q) - np.percentile(tiny, q)) <= LOW / 2
    huge = histogram_of([1.0, HIGH * 2, HIGH * 5])
    assert huge.percentile(100) == HIGH * 5 and huge.percentile(0) == 1.0


def test_an_empty_histogram_and_bad_input():
    histogram = LogHistogram()
    assert histogram.percentile(50) is None
    for bad in (-1e-3, math.nan, math.inf):
        with pytest.raises(ValueError, match="finite and >= 0"):
            histogram.append(bad)
    with pytest.raises(ValueError, match=r"\[0, 100\]"):
        histogram.percentile(101)


@pytest.mark.parametrize("frames", [1, 7, 8, 9, 100, 1000, 4096 * 3 + 5])
def test_a_decimated_series_names_its_frames(frames):
    series = DecimatedSeries(capacity=8)
    for k in range(1, frames + 1):
        series.append(k * 10)  # the value says which frame it came from
    assert len(series) <= 8 and series.count == frames and series.last == frames * 10
    assert [v // 10 for v in series] == list(series.frames())
    assert series.frames()[0] == series.stride and series.stride & (series.stride - 1) == 0
    if frames > 8:  # full once: at least half the capacity is in use
        assert len(series) >= 4 and series.frames()[-1] > frames - 2 * series.stride
    else:
        assert list(series.frames()) == list(range(1, frames + 1))


def test_a_decimated_series_needs_an_even_capacity():
    with pytest.raises(ValueError, match="even"):
        DecimatedSeries(capacity=5)


def test_first_entries_keep_the_first_and_count_all():
    entries = FirstEntries(limit=3)
    assert not entries and entries.total == 0
    for n in range(10):
        entries.append(n)
    assert list(entries) == [0, 1, 2] and entries[-1] == 2 and len(entries) == 3
    assert entries.total == 10


def test_binned_sums_keep_every_count_as_bins_merge():
    sums = BinnedSums(2, capacity=4)
    for k in range(1, 12):
        sums.add((k, 1))
    assert sums.stride == 4 and sums.bins() == [[10, 4], [26, 4], [30, 3]]
    assert sums.totals == [66, 11] and sums.count == 11
    with pytest.raises(ValueError, match="expected 2 counts, got 3"):
        sums.add((1, 2, 3))


def test_binned_sums_give_rates_per_second_of_the_frames_each_bin_holds():
    sums = BinnedSums(1, capacity=2)
    for n in (6, 0, 3, 3, 12):  # bins of 4 frames after the merges, the last of 1
        sums.add((n,))
    assert sums.stride == 4 and sums.bins() == [[12], [12]]
    assert sums.rates(0.5) == [[6.0], [24.0]]


def test_binned_sums_give_a_levels_mean_over_the_frames_each_bin_holds():
    sums = BinnedSums(1, capacity=2)
    for level in (2, 4, 6, 8, 10):  # bins of 2 frames once merged: (2, 4), (6, 8), (10)
        sums.add((level,))
    assert sums.stride == 4 and sums.means() == [[5.0], [10.0]]  # (2+4+6+8)/4, 10/1
