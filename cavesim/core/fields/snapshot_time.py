"""Where a time-series field stands in time at each stage of a frame's step.

A field given as snapshots at times t_0 < t_1 < ... is linear in time between two
neighbours. An integrator evaluates the flow at the start of its step, half way through
(RK2, RK4) or at its end (Verlet, RK4, ETD2RK's second stage), so the master gives each
of those three stages its own pair and weight: the flow at stage s is
    mix(snapshot[pair[s]], snapshot[pair[s] + 1], weight[s])
on the GPU (shaders/include/field.glsl) and in both twins. Before t_0 the first snapshot
holds, after the last one the last. The master computes these in float64 from its clock
and sends them as float32 (determinism rule 1); every node and twin uses those bits.
"""

from __future__ import annotations

import bisect
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from cavesim.core.errors import ProtocolError
from cavesim.core.operations import Operations

START, MIDDLE, END = 0, 1, 2  # the stages of a step at which a flow is evaluated
STAGE_FRACTIONS = (0.0, 0.5, 1.0)  # of the step, at START, MIDDLE and END
STAGE_OF_FRACTION = dict(zip(STAGE_FRACTIONS, (START, MIDDLE, END), strict=True))
FIELD_TIME_PARAMS = 6  # three pairs, then three weights, at the end of a frame's parameters
# The flow u at points (N, 3) at a stage of the step, or at a fraction (N,) of it for each
# point (an adaptive tracer's substeps): what the twins' force models hold
FlowSampler = Callable[[np.ndarray, int | np.ndarray], np.ndarray]


@dataclass(frozen=True)
class FieldTime:
    """The snapshot pair and the weight of its second snapshot at each stage of a step."""

    pairs: tuple[int, int, int]  # index of each stage's first snapshot
    weights: tuple[float, float, float]  # in [0, 1], float32 values

    def encode(self) -> tuple[float, ...]:
        return tuple(np.asarray((*self.pairs, *self.weights), dtype=np.float32).tolist())

    @classmethod
    def decode(cls, params: Sequence[float], snapshots: int) -> FieldTime:
        """From a frame's last FIELD_TIME_PARAMS parameters, for a series of `snapshots`."""
        pairs, weights = params[:3], params[3:]
        last = snapshots - 2
        if not all(p == int(p) and 0 <= p <= last for p in pairs):
            raise ProtocolError("bad-params", f"field time pairs {list(pairs)}: expected whole "
                                              f"numbers from 0 to {last}")
        if not all(0.0 <= w <= 1.0 for w in weights):  # NaN fails too
            raise ProtocolError("bad-params", f"field time weights {list(weights)}: expected "
                                              "numbers from 0 to 1")
        return cls(tuple(int(p) for p in pairs), tuple(float(w) for w in weights))


FIRST_SNAPSHOT = FieldTime((0, 0, 0), (0.0, 0.0, 0.0))  # a frame that says no time: t_0


def field_time_at(times: Sequence[float], t: float, dt: float) -> FieldTime:
    """Where the series `times` (s, increasing, at least two) stands at each stage of the
    step from t to t + dt: the pair whose interval holds the stage's time, and the weight."""
    pairs, weights = [], []
    last = len(times) - 2
    for fraction in STAGE_FRACTIONS:
        at = t + fraction * dt
        pair = min(max(bisect.bisect_right(times, at) - 1, 0), last)
        start, end = times[pair], times[pair + 1]
        pairs.append(pair)
        weights.append(min(max((at - start) / (end - start), 0.0), 1.0))
    weights32 = np.asarray(weights, dtype=np.float32).tolist()
    return FieldTime(tuple(pairs), tuple(weights32))


def places_in_step(field_time: FieldTime, fraction: np.ndarray, snapshots: int,
                   ops: Operations) -> tuple[np.ndarray, np.ndarray]:
    """Each point's pair and weight at `fraction` (N,) of the step: field.glsl's flow_in_step,
    in `ops`' arithmetic. The place pair + weight runs linearly in time from stage to stage
    (START to MIDDLE, MIDDLE to END), as it does within one interval of the series."""
    dtype = fraction.dtype.type
    pairs, weights = np.array(field_time.pairs), np.array(field_time.weights, dtype=dtype)
    half = (fraction > 0.5).astype(np.intp)  # START's half or MIDDLE's
    local = ops.sub(ops.mul(dtype(2.0), fraction), half.astype(dtype))
    span = ops.add((pairs[half + 1] - pairs[half]).astype(dtype),
                   ops.sub(weights[half + 1], weights[half]))
    place = ops.add(weights[half], ops.mul(local, span))
    whole = np.floor(place)
    pair, weight = pairs[half] + whole.astype(np.intp), ops.sub(place, whole)
    beyond = pair > snapshots - 2
    return np.where(beyond, snapshots - 2, pair), np.where(beyond, dtype(1.0), weight)
