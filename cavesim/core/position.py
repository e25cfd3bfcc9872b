"""A particle's position to 32 significant bits in the 40-byte record: shaders/include/
position.glsl in numpy, bit for bit in portable arithmetic.

The record holds the float32 position `pos` (hi) and per axis a signed byte `pos_low` (the
code) for what hi leaves out (low), in units of 1/256 of hi's float32 spacing. A step adds
its increment to hi + low exactly (TwoSum) and keeps the sum as a new hi + low (`move`); the
record rounds low to its byte. Steady motion then no longer loses the same float32 rounding
every step: at 1/960 s the float32 floor falls 8-70x (docs/numerics.md: the float32 floor).
"""

from __future__ import annotations

import numpy as np

from cavesim.core.portable.arithmetic import f_add, f_mul, f_sub

LOW_EXPONENT_MIN = 32  # hi's exponent field below which low is 0 (its unit is subnormal)


def _exponent_fields(hi: np.ndarray) -> np.ndarray:
    return (np.asarray(hi, np.float32).view(np.uint32) >> np.uint32(23)) & np.uint32(0xFF)


def _power_of_two(exponent_field: np.ndarray) -> np.ndarray:
    """The float32 with this exponent field and a zero significand."""
    return (exponent_field.astype(np.uint32) << np.uint32(23)).view(np.float32)


def low_part(hi: np.ndarray, code: np.ndarray) -> np.ndarray:
    """float32 low of hi (..., 3) from its codes: code * 2^(e - 158), e hi's exponent field."""
    e = _exponent_fields(hi)
    usable = e >= LOW_EXPONENT_MIN
    unit = _power_of_two(np.where(usable, e - 31, 1))
    return np.where(usable, f_mul(code.astype(np.float32), unit), np.float32(0.0))


def low_code(hi: np.ndarray, low: np.ndarray) -> np.ndarray:
    """int8 codes of low: low in units of 2^(e - 158), rounded to nearest even, 128 -> 127."""
    e = _exponent_fields(hi)
    usable = e >= LOW_EXPONENT_MIN
    with np.errstate(invalid="ignore", over="ignore"):
        units = f_mul(np.asarray(low, np.float32), _power_of_two(np.where(usable, 285 - e, 1)))
        code = np.clip(np.rint(units), -128, 127)
        return np.where(usable & np.isfinite(code), code, 0).astype(np.int8)


def two_sum(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(s, e) with a + b == s + e exactly (Knuth's TwoSum)."""
    s = f_add(a, b)
    b_virtual = f_sub(s, a)
    a_virtual = f_sub(s, b_virtual)
    return s, f_add(f_sub(a, a_virtual), f_sub(b, b_virtual))


def move(hi: np.ndarray, low: np.ndarray, dp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """hi + low + dp as a new (hi, low): position.glsl's move."""
    total, rounding = two_sum(hi, dp)
    return two_sum(total, f_add(rounding, low))


def extended_position(records: np.ndarray) -> np.ndarray:
    """float64 (N, 3): each record's position, hi + low (exact in float64)."""
    hi = records["pos"]
    return hi.astype(np.float64) + low_part(hi, records["pos_low"]).astype(np.float64)


def split_position(position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A float64 position as the record keeps it: (float32 hi, int8 code of the rest)."""
    hi = position.astype(np.float32)
    return hi, low_code(hi, (position - hi.astype(np.float64)).astype(np.float32))
