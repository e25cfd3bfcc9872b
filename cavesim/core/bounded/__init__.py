"""Fixed-size records of a run of any length: what the master keeps per frame must not grow
with the run (per-frame lists once took 2.4 GB over 8 h at 60 Hz).

`LogHistogram` gives percentiles within a stated relative error, `DecimatedSeries` a
per-frame series thinned to a fixed number of points, `BinnedSums` per-frame counts summed
into a fixed number of bins, `FirstEntries` the first entries of an event list and how many
came in all.
"""

from cavesim.core.bounded.first import FirstEntries
from cavesim.core.bounded.histogram import LogHistogram
from cavesim.core.bounded.series import DecimatedSeries
from cavesim.core.bounded.sums import BinnedSums

__all__ = ["BinnedSums", "DecimatedSeries", "FirstEntries", "LogHistogram"]
