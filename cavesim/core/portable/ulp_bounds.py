"""How close the portable functions come to the true values: one table of (function,
domain, bound in ULP) that tests/gpu/test_portable_arithmetic.py asserts and
docs/numerics.md quotes.

An error is measured in units in the last place of the float32 nearest the float64 value
(2^(e - 23) for a value in [2^e, 2^(e+1))), on samples drawn over each domain; f_div and
f_sqrt are correctly rounded (0.5 ULP) and tested against exact arithmetic instead.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cavesim.core import portable

Sampler = Callable[[np.random.Generator, int], tuple[np.ndarray, ...]]


@dataclass(frozen=True)
class Accuracy:
    """A function's bound on a domain: `sample` draws float32 operands over it."""

    function: str  # a name in cavesim.core.portable
    domain: str
    sample: Sampler
    reference: Callable[..., np.ndarray]  # the true value, in float64
    bound_ulp: float


def _uniform(low: float, high: float) -> Sampler:
    return lambda rng, n: (rng.uniform(low, high, n).astype(np.float32),)


def _log_uniform(low_exponent: float, high_exponent: float) -> Sampler:
    return lambda rng, n: (np.exp2(rng.uniform(low_exponent, high_exponent, n))
                           .astype(np.float32),)


def _near_multiples(step: float, last: int, ulps: int) -> Sampler:
    """Every float within `ulps` of k step, 1 <= |k| <= last: where sin or cos nears zero,
    the hardest arguments for a range reduction (the sample size is not drawn)."""

    def sample(rng, n):
        k = np.arange(1, last + 1)
        centres = np.concatenate([k, -k]) * step
        offsets = np.arange(-ulps, ulps + 1, dtype=np.int32)
        bits = centres.astype(np.float32).view(np.int32)[:, np.newaxis] + offsets
        return (bits.ravel().view(np.float32),)

    return sample


def _pow_sample(log_range: float) -> Sampler:
    """x log-uniform (normal) and y uniform with |y ln x| <= log_range."""

    def sample(rng, n):
        log_x = rng.uniform(-min(log_range, 87.0), min(log_range, 87.0), n)
        x = np.exp(log_x).astype(np.float32)
        limit = log_range / np.maximum(np.abs(np.log(x.astype(np.float64))), 1e-3)
        y = rng.uniform(-1.0, 1.0, n) * np.minimum(limit, 4.0 * log_range)
        return x, y.astype(np.float32)

    return sample


# e^x is normal for x in [ln 2^-126, ln(2^128 (1 - 2^-24))]
_EXP_LOW = math.log(2.0**-126) + 1e-6
_EXP_HIGH = 88.72283

ACCURACY = (
    Accuracy("f_exp", "x in [-87.33, 88.72] (normal results)", _uniform(_EXP_LOW, _EXP_HIGH),
             np.exp, 1.5),
    Accuracy("f_exp", "x in [-1, 1]", _uniform(-1.0, 1.0), np.exp, 1.5),
    Accuracy("f_log", "x in [2^-126, 2^128), log-uniform", _log_uniform(-126.0, 128.0),
             np.log, 1.5),
    Accuracy("f_log", "x in [0.5, 2]", _uniform(0.5, 2.0), np.log, 1.5),
    Accuracy("f_sin", "x in [-4 pi, 4 pi]", _uniform(-4 * math.pi, 4 * math.pi), np.sin, 2.0),
    Accuracy("f_cos", "x in [-4 pi, 4 pi]", _uniform(-4 * math.pi, 4 * math.pi), np.cos, 2.0),
    Accuracy("f_sin", "x within 64 ULP of k pi/2, |k| <= 8", _near_multiples(math.pi / 2, 8, 64),
             np.sin, 2.0),
    Accuracy("f_cos", "x within 64 ULP of k pi/2, |k| <= 8", _near_multiples(math.pi / 2, 8, 64),
             np.cos, 2.0),
    Accuracy("f_sin", "x within 4 ULP of k pi/2, |k| <= 5215",
             _near_multiples(math.pi / 2, 5215, 4), np.sin, 3.0),
    Accuracy("f_cos", "x within 4 ULP of k pi/2, |k| <= 5215",
             _near_multiples(math.pi / 2, 5215, 4), np.cos, 3.0),
    Accuracy("f_sin", "x in [-8192, 8192]", _uniform(-8192.0, 8192.0), np.sin, 3.0),
    Accuracy("f_cos", "x in [-8192, 8192]", _uniform(-8192.0, 8192.0), np.cos, 3.0),
    Accuracy("f_pow", "x > 0, |y ln x| <= 1", _pow_sample(1.0), np.power, 4.0),
    Accuracy("f_pow", "x > 0, |y ln x| <= 10", _pow_sample(10.0), np.power, 22.0),
    Accuracy("f_pow", "x > 0, |y ln x| <= 87", _pow_sample(87.0), np.power, 176.0),
)


def ulp_error(result: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """|result - exact| in ULP of the float32 nearest `exact` (float64)."""
    nearest = np.abs(exact).astype(np.float32)
    _, exponent = np.frexp(nearest)
    ulp = np.ldexp(1.0, exponent.astype(np.int64) - 24)
    return np.abs(result.astype(np.float64) - exact) / ulp


def measure(accuracy: Accuracy, count: int, seed: int = 0) -> float:
    """The largest error of `count` samples, in ULP."""
    operands = accuracy.sample(np.random.default_rng(seed), count)
    result = getattr(portable, accuracy.function)(*operands)
    exact = accuracy.reference(*(x.astype(np.float64) for x in operands))
    return float(ulp_error(result, exact).max())
