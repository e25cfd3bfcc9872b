"""Operands for the portable arithmetic tests: random bits of every class, values spread
over all exponents, each function's working range, every pair of special values, and the
hard cases of each function (results at the flush boundary, near overflow, quotients and
roots near a rounding midpoint)."""

import math

import numpy as np

_SPECIAL_BITS = np.array([
    0x00000000,  # 0
    0x00000001, 0x00000002, 0x00400000, 0x007FFFFF,  # subnormals
    0x00800000, 0x00800001, 0x00FFFFFF, 0x01000000,  # min normal and its neighbours
    0x0C800000, 0x20000000, 0x1F800000,  # 2^-102, 2^-63, 2^-64
    0x33800000, 0x3F000000, 0x3F800000, 0x3F800001, 0x3FC00000, 0x40000000, 0x40490FDB,
    0x3FB504F3, 0x3FB504F2,  # 2^-24, 0.5, 1, 1 + ulp, 1.5, 2, pi, sqrt 2 and below
    0x42B17218, 0x42B20000, 0xC2AEAC50, 0xC2D00000,  # 88.72, 89, -87.34, -104
    0x5F800000, 0x7F000000, 0x7F7FFFFE, 0x7F7FFFFF,  # 2^64, 2^127, max float
    0x7F800000, 0x7FC00000, 0x7F800001, 0x7FC12345,  # inf, NaN, signalling, payload
], dtype=np.uint32)
SPECIALS = np.concatenate([_SPECIAL_BITS, _SPECIAL_BITS | np.uint32(0x80000000)]
                          ).view(np.float32)
MIN_NORMAL = 2.0**-126
MAX_FLOAT = float(np.finfo(np.float32).max)

# where each function's arguments usually lie: (low, high) of a uniform draw
WORKING_RANGE = {
    "f_exp": (-110.0, 100.0), "f_log": (0.0, 100.0), "f_pow": (0.0, 20.0),
    "f_sin": (-50.0, 50.0), "f_cos": (-50.0, 50.0), "f_sqrt": (0.0, 100.0),
}


def random_bits(rng, shape):
    return rng.integers(0, 2**32, size=shape, dtype=np.uint64).astype(np.uint32).view(
        np.float32)


def spread(rng, shape):
    """Normal floats of random sign with an exponent uniform over all of them."""
    exponent = rng.integers(1, 255, size=shape, dtype=np.uint32)
    significand = rng.integers(0, 2**23, size=shape, dtype=np.uint32)
    sign = rng.integers(0, 2, size=shape, dtype=np.uint32)
    return ((sign << 31) | (exponent << 23) | significand).view(np.float32)


def operands(function, count, seed=0):
    """(count, 3, 3) float32 operands for probes/arithmetic.glsl's `function`."""
    with np.errstate(all="ignore"):  # hard cases near max float make infs on purpose
        return _operands(function, count, np.random.default_rng(seed))


def _operands(function, count, rng):
    low, high = WORKING_RANGE.get(function, (-4.0, 4.0))
    parts = [random_bits(rng, (count // 4, 3, 3)), spread(rng, (count // 4, 3, 3)),
             rng.uniform(low, high, (count // 4, 3, 3)).astype(np.float32),
             _special_pairs(rng)]
    for case in _HARD_CASES.get(function, ()):
        a, b = case(rng, count // 16)
        hard = rng.uniform(-4, 4, (len(a), 3, 3)).astype(np.float32)
        hard[:, 0, :] = a[:, np.newaxis]
        hard[:, 1, :] = b[:, np.newaxis]
        parts.append(hard)
    return np.concatenate(parts)


def _special_pairs(rng):
    """Every special as a with every special as b; c and the other components random."""
    a, b = np.meshgrid(SPECIALS, SPECIALS, indexing="ij")
    pairs = rng.choice(SPECIALS, size=(a.size, 3, 3))
    pairs[:, 0, :] = a.ravel()[:, np.newaxis]
    pairs[:, 1, :] = b.ravel()[:, np.newaxis]
    return pairs


def _around(value, ulps, rng, n):
    """Floats within `ulps` ULP of `value` (float64, or one per float), as float32."""
    centre = np.asarray(value, dtype=np.float64).astype(np.float32).view(np.int32)
    return (centre + rng.integers(-ulps, ulps + 1, n).astype(np.int32)).view(np.float32)


def _significands(rng, n):
    return rng.uniform(1.0, 2.0, n)


def _quotients_near(target, rng, n):
    """a, b with a / b within a few ULP of `target`: b in [2, 4), a = target b rounded."""
    b = (2.0 * _significands(rng, n)).astype(np.float32)
    t = _around(target, 64, rng, n).astype(np.float64)
    return (t * b).astype(np.float32), b


def _quotients_near_midpoints(rng, n):
    """a / b within a tiny fraction of an ULP of a rounding midpoint, and exact quotients."""
    b = _significands(rng, n).astype(np.float32)
    midpoint = (2 * rng.integers(2**23, 2**24, n) + 1) * 2.0**-24  # 25 bits, odd
    near = (b.astype(np.float64) * midpoint).astype(np.float32)
    small = rng.integers(1, 2**12, n).astype(np.float32) * rng.integers(1, 2**12, n)
    exact = small.astype(np.float32)
    divisor = rng.integers(1, 2**12, n).astype(np.float32)
    half = n // 2
    return (np.concatenate([near[:half], exact[half:]]),
            np.concatenate([b[:half], divisor[half:]]))


def _products_near(target, rng, n):
    """a, b with a b within a few ULP of `target`: a near sqrt(target)."""
    a = (_significands(rng, n) * math.sqrt(target)).astype(np.float32)
    t = _around(target, 64, rng, n).astype(np.float64)
    return a, (t / a.astype(np.float64)).astype(np.float32)


def _products_in_the_band(rng, n):
    """a b just below 2^-126, where hardware rounding rules part (tininess before or after
    rounding, the subnormal grid)."""
    a = (_significands(rng, n) * 2.0**-63).astype(np.float32)
    t = MIN_NORMAL * (1.0 - rng.uniform(0.0, 2.0**-22, n))
    return a, (t / a.astype(np.float64)).astype(np.float32)


def _sums_near_min_normal(rng, n):
    """a + b in the subnormals or just above: a, -b near 2^-126 and 2^-125."""
    a = _around(1.5 * MIN_NORMAL, 2**22, rng, n)
    b = -_around(MIN_NORMAL, 2**21, rng, n)
    return a, b


def _roots_near_midpoints(rng, n):
    """x with sqrt(x) near a rounding midpoint, and perfect squares."""
    root = (2 * rng.integers(2**23, 2**24, n) + 1) * 2.0**-24
    scale = np.exp2(2.0 * rng.integers(-60, 60, n))
    near = (root * root * scale).astype(np.float32)
    squares = (rng.integers(1, 2**12, n).astype(np.float64) ** 2).astype(np.float32)
    half = n // 2
    return np.concatenate([near[:half], squares[half:]]), np.zeros(n, np.float32)


def _tiny(rng, n):
    """Normal floats of random sign from 2^-126 to 2^-20: their squares underflow."""
    sign = rng.choice([-1.0, 1.0], n)
    return (sign * np.exp2(rng.uniform(-126.0, -20.0, n))).astype(np.float32)


def _unary(sampler):
    return lambda rng, n: (sampler(rng, n), np.zeros(n, np.float32))


_HARD_CASES = {
    "f_add": [_sums_near_min_normal],
    "f_sub": [lambda rng, n: (lambda a, b: (a, -b))(*_sums_near_min_normal(rng, n))],
    "f_mul": [_products_in_the_band, lambda rng, n: _products_near(MIN_NORMAL, rng, n),
              lambda rng, n: _products_near(MAX_FLOAT, rng, n)],
    "f_div": [_quotients_near_midpoints, lambda rng, n: _quotients_near(MIN_NORMAL, rng, n),
              lambda rng, n: _quotients_near(MAX_FLOAT, rng, n)],
    "f_sqrt": [_roots_near_midpoints],
    "f_exp": [_unary(lambda rng, n: _around(math.log(MIN_NORMAL), 4096, rng, n)),
              _unary(lambda rng, n: _around(math.log(MAX_FLOAT), 4096, rng, n)),
              _unary(lambda rng, n: _around(0.0, 2**30, rng, n)), _unary(_tiny)],
    "f_log": [_unary(lambda rng, n: _around(1.0, 4096, rng, n)),
              _unary(lambda rng, n: _around(math.sqrt(2.0), 4096, rng, n))],
    "f_sin": [_unary(lambda rng, n: _around(rng.integers(-16, 17, n) * math.pi / 2, 64, rng, n)),
              _unary(_tiny)],
    "f_cos": [_unary(lambda rng, n: _around(rng.integers(-16, 17, n) * math.pi / 2, 64, rng, n)),
              _unary(_tiny)],
    "f_pow": [lambda rng, n: (_around(1.0, 4096, rng, n),
                              rng.uniform(-1000, 1000, n).astype(np.float32))],
}
