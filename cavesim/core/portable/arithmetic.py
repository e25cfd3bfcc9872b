"""The float32 numpy twin of the portable arithmetic (cavesim/gpu/shaders/include/
arithmetic.glsl, ARITHMETIC_PORTABLE): the same functions, bit for bit.

numpy's float32 +, -, *, / and sqrt are IEEE correctly rounded and never fused, like the
shader's `precise` operations; both flush in code (the GLSL file's header gives the rules).
f_div and f_sqrt are defined mathematically (correctly rounded), so numpy's own give their
bits, save results near 2^-126 (IEEE rounds those to the subnormal grid), which are
rounded again from float64: exact for a product, correctly rounded for a quotient after
the second rounding (Figueroa, "When is double rounding innocuous?", 1995: 53 >= 2 * 24 +
2). Every other function runs the shader's operation sequence, operation by operation.

Arrays are float32 of any shape and broadcast; a vector's components are the last axis.
Python numbers are accepted where float32 holds them exactly, other dtypes are refused: a
float64 operand would otherwise be rounded silently.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = [
    "f_add", "f_cos", "f_div", "f_dot", "f_exp", "f_ftz", "f_length", "f_log", "f_mix",
    "f_mul", "f_normalize", "f_pow", "f_sin", "f_sqrt", "f_sub",
]

_SIGN = np.uint32(0x80000000)
_MAGNITUDE = np.uint32(0x7FFFFFFF)
_SIGNIFICAND = np.uint32(0x007FFFFF)
_HIDDEN_BIT = np.uint32(0x00800000)
_INF = np.uint32(0x7F800000)
_QUIET_NAN = np.uint32(0x7FC00000).view(np.float32)
_TWO_64 = np.float64(2.0**64)


def _bits(value: int) -> np.float32:
    """The float32 with these bits: the shader's uintBitsToFloat(0x...u) constants."""
    return np.uint32(value).view(np.float32)


_HALF = np.float32(0.5)
_ONE = np.float32(1.0)
_LOG2_E = _bits(0x3FB8AA3B)
_LN2_HIGH = np.float32(0.693359375)
_LN2_LOW = _bits(0xB95E8083)
_EXP_P = [_bits(b) for b in (0x39506967, 0x3AB743CE, 0x3C088908, 0x3D2AA9C1, 0x3E2AAAAA)]
_EXP_P.append(np.float32(0.5))
_EXP_LOW = np.float32(-104.0)
_EXP_HIGH = np.float32(89.0)
_SQRT2_BITS = np.uint32(0x3FB504F3)
_LOG_Q = [_bits(b) for b in (0x3D9021BB, 0xBDEBD1B8, 0x3DEF251A, 0xBDFE5D4F, 0x3E11E9BF,
                             0xBE2AAE50, 0x3E4CCEAC, 0xBE7FFFFC, 0x3EAAAAAA)]
_TWO_OVER_PI = _bits(0x3F22F983)
_PIO2 = [np.float32(1.5703125), _bits(0x39FDA000), _bits(0x33A22000), _bits(0x2C34611A)]
_SIN_S = [_bits(b) for b in (0xB94CA1F9, 0x3C08839E, 0xBE2AAAA3)]
_COS_C = [_bits(b) for b in (0x37CCF5CE, 0xBAB6061A, 0x3D2AAAA5)]
_QUARTER = np.float32(0.25)
_FOUR = np.float32(4.0)


def _float32(x) -> np.ndarray:
    """`x` as a float32 array, refusing what would round on the way."""
    if isinstance(x, np.ndarray | np.generic):
        if x.dtype != np.float32:
            raise TypeError(f"portable arithmetic takes float32, got dtype {x.dtype}")
        return np.asarray(x)
    if isinstance(x, int | float) and not isinstance(x, bool):
        value = np.float32(x)
        if not (float(value) == x or np.isnan(x)):  # compared in float64, not float32
            raise ValueError(f"{x!r} is not a float32 value; pass np.float32({x!r})")
        return np.asarray(value)
    raise TypeError(f"portable arithmetic takes float32 arrays, got {type(x).__name__}")


def _quiet_floating_point(function):
    """numpy warns on overflow and on NaN results, which are defined results here."""

    @functools.wraps(function)
    def wrapper(*args):
        with np.errstate(all="ignore"):
            return function(*args)

    return wrapper


def _flush(x: np.ndarray) -> np.ndarray:
    bits = np.asarray(x).view(np.uint32)
    # subnormal: the magnitude, shifted past the sign, is in [2, 2^24); a zero wraps around
    subnormal = (bits << 1) - np.uint32(1) < np.uint32(0x00FFFFFF)
    if not subnormal.any():  # the common case, without a copy
        return np.asarray(x)
    return np.where(subnormal, bits & _SIGN, bits).view(np.float32)


def _quiet(x: np.ndarray) -> np.ndarray:
    return _where_rare(np.isnan(x), _QUIET_NAN, x)


def _where_rare(mask, value, x):
    """np.where for a mask that is seldom true: nothing to do when it is all false."""
    return np.where(mask, value, x) if mask.any() else np.asarray(x)


def _select(choose_first, first, second):
    """first where choose_first (0 or 1 as uint32), else second, by bit masks: np.where
    branches per element and mispredicts on a random mask, 10 times slower."""
    mask = np.uint32(0) - choose_first  # all ones or zero
    return ((first.view(np.uint32) & mask) | (second.view(np.uint32) & ~mask)).view(np.float32)


def _negate_where(negative, x):
    """-x where negative (0 or 1 as uint32), by the sign bit."""
    return (x.view(np.uint32) ^ (negative << np.uint32(31))).view(np.float32)


def _nonzero_at_most_min_normal(x: np.ndarray) -> np.ndarray:
    """Where float32 x is subnormal or +-2^-126: IEEE rounds below 2^-126 to the subnormal
    grid, which may give 2^-126 where 24 bits with an unbounded exponent give less."""
    return (x.view(np.uint32) << 1) - np.uint32(1) < np.uint32(0x01000000)


def _round_flush(exact: np.ndarray) -> np.ndarray:
    """float64 values (exact, or correctly rounded results of /, sqrt) rounded to 24 bits
    with an unbounded exponent, flushed below 2^-126, inf from 2^128: as f_div's
    arith_pack and arith_mul_tiny round."""
    rounded = np.asarray(exact.astype(np.float32))
    tiny = _nonzero_at_most_min_normal(rounded)  # the cast's subnormal rounding differs
    if tiny.any():
        scaled = (exact[tiny] * _TWO_64).astype(np.float32)  # normal unless flushed below
        kept = np.abs(scaled) >= np.float32(2.0**-62)
        zero = np.copysign(np.float32(0.0), scaled)
        rounded[tiny] = np.where(kept, scaled * np.float32(2.0**-64), zero)
    return rounded


# --- the arith_ operations: operands and results never subnormal ------------------------

def _add(a, b):
    return _flush(a + b)


def _sub(a, b):
    return _flush(a - b)


def _mul(a, b):
    product = np.asarray(a * b)
    # exponent field 0 or 1, not zero (an IEEE product that underflowed to zero is the
    # definition's zero already)
    tiny = (product.view(np.uint32) << 1) - np.uint32(1) < np.uint32(0x01FFFFFF)
    if tiny.any():
        a_tiny, b_tiny = (np.broadcast_to(v, product.shape)[tiny] for v in (a, b))
        product = product.copy()
        product[tiny] = _round_flush(a_tiny.astype(np.float64) * b_tiny.astype(np.float64))
    return product


def _scale(p, n):
    """p 2^n for positive p by the exponent field, as the shader's arith_scale."""
    bits = p.view(np.uint32)
    biased = (bits >> 23).astype(np.int32) + n
    scaled = ((biased.astype(np.uint32) << 23) | (bits & _SIGNIFICAND)).view(np.float32)
    scaled = _where_rare(biased >= 255, _INF.view(np.float32), scaled)
    return _where_rare(biased <= 0, np.float32(0.0), scaled)


def _horner(coefficients, x):
    result = coefficients[0] * x + coefficients[1]
    for coefficient in coefficients[2:]:
        result *= x  # in place: the same float32 operations, fewer fresh pages
        result += coefficient
    return result


# _exp, _log and _sin_cos_reduced use plain float32 operations, unflushed, as the shader
# does: the tiny terms they may make are absorbed (arithmetic.glsl says why).

def _exp(x):
    clamped = np.clip(x, _EXP_LOW, _EXP_HIGH)  # NaN stays NaN: replaced at the end
    n = np.floor(clamped * _LOG2_E + _HALF)
    r = (clamped - n * _LN2_HIGH) - n * _LN2_LOW
    r2 = r * r
    p = (_horner(_EXP_P, r) * r2 + r) + _ONE
    return _where_rare(np.isnan(x), _QUIET_NAN, _scale(p, n.astype(np.int32)))


def _log(x):
    bits = x.view(np.uint32)
    magnitude = bits & _MAGNITUDE
    nan = (magnitude > _INF) | ((magnitude != 0) & ((bits & _SIGN) != 0))
    zero = magnitude == 0
    inf = magnitude == _INF
    e = (bits >> 23).astype(np.int32) - 127
    one_plus_f = (bits & _SIGNIFICAND) | np.uint32(0x3F800000)
    halve = one_plus_f >= _SQRT2_BITS
    one_plus_f = one_plus_f - (halve.astype(np.uint32) << np.uint32(23))
    e = e + halve
    f = one_plus_f.view(np.float32) - _ONE
    f2 = f * f
    q = (_horner(_LOG_Q, f) * f) * f2
    fe = e.astype(np.float32)
    q = q + fe * _LN2_LOW
    q = q - _HALF * f2
    result = (f + q) + fe * _LN2_HIGH
    result = _where_rare(inf, x, result)
    result = _where_rare(zero, -_INF.view(np.float32), result)
    return _where_rare(nan, _QUIET_NAN, result)


def _sin_cos_reduced(x):
    """sin r, cos r of the reduced argument and the quadrant, as arith_sin_cos_reduced."""
    n = np.floor(x * _TWO_OVER_PI + _HALF)
    r = x
    for part in _PIO2:
        r = r - n * part
    quadrant = (n - np.floor(n * _QUARTER) * _FOUR).astype(np.uint32)
    r2 = r * r
    sin_r = (_horner(_SIN_S, r2) * r2) * r + r
    c = (_horner(_COS_C, r2) * r2) * r2
    cos_r = (c - _HALF * r2) + _ONE
    return sin_r, cos_r, quadrant


def _finite_or_zero(x):
    """x flushed, with inf and NaN replaced by 0 (their result is NaN), and where they were."""
    x = _flush(x)
    special = (x.view(np.uint32) & _MAGNITUDE) >= _INF
    return _where_rare(special, np.float32(0.0), x), special


# --- the API ---------------------------------------------------------------------------

def f_ftz(x):
    """A subnormal as a zero of its sign; anything else unchanged."""
    return _flush(_float32(x))


@_quiet_floating_point
def f_add(a, b):
    return _quiet(_add(f_ftz(a), f_ftz(b)))


@_quiet_floating_point
def f_sub(a, b):
    return _quiet(_sub(f_ftz(a), f_ftz(b)))


@_quiet_floating_point
def f_mul(a, b):
    return _quiet(_mul(f_ftz(a), f_ftz(b)))


@_quiet_floating_point
def f_div(a, b):
    """a / b correctly rounded (subnormal operands read as zero, results flushed)."""
    a, b = f_ftz(a), f_ftz(b)
    quotient = np.asarray(a / b)  # IEEE: correctly rounded but where it is subnormal
    tiny = _nonzero_at_most_min_normal(quotient)
    if tiny.any():
        a_tiny, b_tiny = (np.broadcast_to(v, quotient.shape)[tiny] for v in (a, b))
        quotient = quotient.copy()
        quotient[tiny] = _round_flush(a_tiny.astype(np.float64) / b_tiny.astype(np.float64))
    return _quiet(quotient)


@_quiet_floating_point
def f_sqrt(x):
    """sqrt(x) correctly rounded (IEEE, never subnormal); sqrt(-0) = -0, NaN below zero."""
    return _quiet(np.sqrt(f_ftz(x)))


@_quiet_floating_point
def f_exp(x):
    return _exp(f_ftz(x))


@_quiet_floating_point
def f_log(x):
    return _log(f_ftz(x))


@_quiet_floating_point
def f_pow(x, y):
    """x^y = e^(y log x), for x > 0."""
    return _exp(_mul(f_ftz(y), _log(f_ftz(x))))


@_quiet_floating_point
def f_sin(x):
    x, special = _finite_or_zero(_float32(x))
    sin_r, cos_r, quadrant = _sin_cos_reduced(x)
    value = _select(quadrant & 1, cos_r, sin_r)
    return _quiet(_where_rare(special, _QUIET_NAN, _negate_where(quadrant >> 1 & 1, value)))


@_quiet_floating_point
def f_cos(x):
    x, special = _finite_or_zero(_float32(x))
    sin_r, cos_r, quadrant = _sin_cos_reduced(x)
    value = _select(quadrant & 1, sin_r, cos_r)
    negative = (quadrant + 1) >> 1 & 1  # quadrants 1 and 2
    return _quiet(_where_rare(special, _QUIET_NAN, _negate_where(negative, value)))


@_quiet_floating_point
def f_dot(a, b):
    """((a.x b.x + a.y b.y) + a.z b.z) over the last axis (2 or 3 components)."""
    a, b = f_ftz(a), f_ftz(b)
    if a.ndim == 0 or b.ndim == 0 or a.shape[-1] != b.shape[-1] or a.shape[-1] not in (2, 3):
        raise ValueError(f"f_dot takes vectors of 2 or 3 components on the last axis, got "
                         f"shapes {a.shape} and {b.shape}")
    total = _add(_mul(a[..., 0], b[..., 0]), _mul(a[..., 1], b[..., 1]))
    if a.shape[-1] == 3:
        total = _add(total, _mul(a[..., 2], b[..., 2]))
    return _quiet(total)


def f_length(x):
    return f_sqrt(f_dot(x, x))


def f_normalize(x):
    return f_div(x, f_length(x)[..., np.newaxis])


def f_mix(a, b, t):
    """a + t (b - a); for vectors with one t per vector, pass t[..., np.newaxis]."""
    return f_add(a, f_mul(t, f_sub(b, a)))
