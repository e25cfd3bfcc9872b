"""Drift between two copies of the particle state, for CAVEs whose GPUs cannot agree on bits
(the mixed-hardware tolerance mode, `nodes/master/tolerance.py`).

In that mode every node reads a deterministic sample of its live particle records after its
step (`sample_indices`: evenly spaced, so nodes with the same live count read the same
records) and sends positions and velocities with its report; the master measures how far
each node's sample lies from the authority's (`measure_drift`). GL-free: the master and the
wire use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MAX_SAMPLE = 1024  # records of one sample: 24 KiB, a small addition to a report
DEFAULT_SAMPLE = 256  # max of 256 is about the 99.6th percentile; RMS within ~4 %
SAMPLE_DTYPE = np.dtype([("pos", "<f4", (3,)), ("vel", "<f4", (3,))])  # 24 bytes


def sample_size(size: int, live: int) -> int:
    """How many records a sample of at most `size` holds when `live` particles live."""
    return min(size, live)


def sample_indices(live: int, size: int) -> np.ndarray:
    """The stream indices a sample of at most `size` records reads from `live` particles:
    evenly spaced from the first, each at most once."""
    count = sample_size(size, live)
    return (np.arange(count, dtype=np.int64) * live) // max(count, 1)


@dataclass(frozen=True)
class DriftSample:
    """Positions and velocities of a node's sampled records (SAMPLE_DTYPE bytes), in the
    order of `sample_indices`."""

    records: bytes

    def __post_init__(self) -> None:
        count, rest = divmod(len(self.records), SAMPLE_DTYPE.itemsize)
        if rest or count > MAX_SAMPLE:
            raise ValueError(f"a drift sample is 0 to {MAX_SAMPLE} whole "
                             f"{SAMPLE_DTYPE.itemsize}-byte records, got {len(self.records)} "
                             f"bytes")

    @classmethod
    def of(cls, positions: np.ndarray, velocities: np.ndarray) -> DriftSample:
        records = np.zeros(len(positions), SAMPLE_DTYPE)
        records["pos"], records["vel"] = positions, velocities
        return cls(records.tobytes())

    def __len__(self) -> int:
        return len(self.records) // SAMPLE_DTYPE.itemsize

    def array(self) -> np.ndarray:
        return np.frombuffer(self.records, SAMPLE_DTYPE)


@dataclass(frozen=True)
class Drift:
    """How far one node's sample lies from the authority's: max and RMS of |Δposition| (m)
    and |Δvelocity| (m/s) over the sampled records, and both live counts. Without
    comparable samples (the live counts differ) the distances are infinite; a non-finite
    value on either side counts as an infinite distance."""

    position_max: float
    position_rms: float
    velocity_max: float
    velocity_rms: float
    particles: int  # the node's live count
    authority_particles: int

    @property
    def counts_differ(self) -> bool:
        return self.particles != self.authority_particles

    def exceeds(self, position: float, velocity: float) -> bool:
        """Whether this drift breaches the tolerances (or the live counts differ)."""
        return self.counts_differ or self.position_max > position \
            or self.velocity_max > velocity

    def to_json(self) -> dict:
        return {"position_max_m": rounded(self.position_max),
                "position_rms_m": rounded(self.position_rms),
                "velocity_max_m_s": rounded(self.velocity_max),
                "velocity_rms_m_s": rounded(self.velocity_rms),
                "particles": self.particles, "authority_particles": self.authority_particles}


NO_DRIFT = Drift(0.0, 0.0, 0.0, 0.0, 0, 0)


def measure_drift(sample: DriftSample, particles: int, authority: DriftSample,
                  authority_particles: int) -> Drift:
    """The drift of `sample` (of a state with `particles` live) from the authority's."""
    if particles != authority_particles or len(sample) != len(authority):
        return Drift(math.inf, math.inf, math.inf, math.inf, particles, authority_particles)
    ours, theirs = sample.array(), authority.array()
    position = _distances(ours["pos"], theirs["pos"])
    velocity = _distances(ours["vel"], theirs["vel"])
    return Drift(*_max_rms(position), *_max_rms(velocity), particles, authority_particles)


def _distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a - b| per record in float64 (a NaN or infinity on either side: infinite)."""
    distance = np.linalg.norm(a.astype(np.float64) - b.astype(np.float64), axis=1)
    return np.where(np.isfinite(distance), distance, np.inf)


def _max_rms(distances: np.ndarray) -> tuple[float, float]:
    if not len(distances):
        return 0.0, 0.0
    return float(distances.max()), float(np.sqrt(np.mean(distances ** 2)))


def rounded(value: float) -> float | None:
    """A distance for JSON, to 3 digits: None for an infinite one (no comparable samples)."""
    return float(f"{value:.3g}") if math.isfinite(value) else None
