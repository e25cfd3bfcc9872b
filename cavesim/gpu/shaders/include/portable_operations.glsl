// Portable arithmetic, part 1 (arithmetic.glsl says what the mode is): flushing, the three
// correctly rounded operations +, -, *, and division and square root made exact by integer
// remainders. Included by arithmetic.glsl only, in ARITHMETIC_PORTABLE; twin:
// cavesim/core/portable/arithmetic.py.
#pragma once

// Constants are exact: float bit patterns (macros: glslang refuses uintBitsToFloat in a
// const initializer) or decimals that float32 holds exactly, never folded expressions.
const uint ARITH_SIGN = 0x80000000u;
const uint ARITH_MAGNITUDE = 0x7fffffffu;
const uint ARITH_EXPONENT = 0x7f800000u;
const uint ARITH_SIGNIFICAND = 0x007fffffu;
const uint ARITH_HIDDEN_BIT = 0x00800000u;
const uint ARITH_INF = 0x7f800000u;
const uint ARITH_QUIET_NAN = 0x7fc00000u;
const float ARITH_TWO_24 = 16777216.0;          // 2^24
#define ARITH_TWO_MINUS_23 uintBitsToFloat(0x34000000u)   // 2^-23
#define ARITH_TWO_MINUS_24 uintBitsToFloat(0x33800000u)   // 2^-24
#define ARITH_TWO_MINUS_25 uintBitsToFloat(0x33000000u)   // 2^-25
#define ARITH_TWO_MINUS_102 uintBitsToFloat(0x0c800000u)  // 2^-102

// --- flushing and the three correctly rounded operations -----------------------------

// A subnormal (exponent field 0) as a zero of its sign; anything else unchanged.
float f_ftz(float x) {
    uint bits = floatBitsToUint(x);
    return (bits & ARITH_EXPONENT) == 0u ? uintBitsToFloat(bits & ARITH_SIGN) : x;
}

vec2 f_ftz(vec2 x) {
    return vec2(f_ftz(x.x), f_ftz(x.y));
}

vec3 f_ftz(vec3 x) {
    return vec3(f_ftz(x.x), f_ftz(x.y), f_ftz(x.z));
}

// Every NaN as the one quiet NaN: GPUs return different NaN bits for the same operation.
float arith_quiet(float x) {
    return (floatBitsToUint(x) & ARITH_MAGNITUDE) > ARITH_INF ? uintBitsToFloat(ARITH_QUIET_NAN)
                                                               : x;
}

// The arith_ operations take operands that are not subnormal and return results that are
// not; a sum or difference below 2^-126 is exact (Hauser 1996), so flushing the hardware's
// result (subnormal, or already flushed with its sign kept) meets the definition.
float arith_add(float a, float b) {
    precise float sum = a + b;
    return f_ftz(sum);
}

float arith_sub(float a, float b) {
    precise float difference = a - b;
    return f_ftz(difference);
}

// A product below 2^-126 is rounded differently by each hardware (to the subnormal grid;
// flushed when tiny before rounding; when tiny after rounding). Products below 2^-125, or
// flushed to zero, are therefore computed again, the smaller operand scaled by 2^24: that
// product is normal and rounded to 24 bits unless the true one is below 2^-150, so it is
// flushed (below 2^-102) or scaled back exactly.
float arith_mul_tiny(float a, float b) {
    uint sign = (floatBitsToUint(a) ^ floatBitsToUint(b)) & ARITH_SIGN;
    bool a_smaller = abs(a) < abs(b);
    precise float a_scaled = a_smaller ? a * ARITH_TWO_24 : a;
    precise float b_scaled = a_smaller ? b : b * ARITH_TWO_24;
    precise float product = a_scaled * b_scaled;
    if (abs(product) < ARITH_TWO_MINUS_102) {
        return uintBitsToFloat(sign);
    }
    precise float scaled_back = product * ARITH_TWO_MINUS_24;
    return scaled_back;
}

float arith_mul(float a, float b) {
    precise float product = a * b;
    // exponent field 0 or 1: a zero, a subnormal, or below 2^-125 (an `if`, not `?:`, so
    // that a GPU can skip the rare case instead of computing it always)
    if ((floatBitsToUint(product) & 0x7f000000u) == 0u) {
        product = arith_mul_tiny(a, b);
    }
    return product;
}

float f_add(float a, float b) {
    return arith_quiet(arith_add(f_ftz(a), f_ftz(b)));
}

vec2 f_add(vec2 a, vec2 b) {
    return vec2(f_add(a.x, b.x), f_add(a.y, b.y));
}

vec3 f_add(vec3 a, vec3 b) {
    return vec3(f_add(a.x, b.x), f_add(a.y, b.y), f_add(a.z, b.z));
}

float f_sub(float a, float b) {
    return arith_quiet(arith_sub(f_ftz(a), f_ftz(b)));
}

vec2 f_sub(vec2 a, vec2 b) {
    return vec2(f_sub(a.x, b.x), f_sub(a.y, b.y));
}

vec3 f_sub(vec3 a, vec3 b) {
    return vec3(f_sub(a.x, b.x), f_sub(a.y, b.y), f_sub(a.z, b.z));
}

float f_mul(float a, float b) {
    return arith_quiet(arith_mul(f_ftz(a), f_ftz(b)));
}

vec2 f_mul(vec2 a, vec2 b) {
    return vec2(f_mul(a.x, b.x), f_mul(a.y, b.y));
}

vec3 f_mul(vec3 a, vec3 b) {
    return vec3(f_mul(a.x, b.x), f_mul(a.y, b.y), f_mul(a.z, b.z));
}

vec2 f_mul(float a, vec2 b) {
    return vec2(f_mul(a, b.x), f_mul(a, b.y));
}

vec3 f_mul(float a, vec3 b) {
    return vec3(f_mul(a, b.x), f_mul(a, b.y), f_mul(a, b.z));
}

vec2 f_mul(vec2 a, float b) {
    return vec2(f_mul(a.x, b), f_mul(a.y, b));
}

vec3 f_mul(vec3 a, float b) {
    return vec3(f_mul(a.x, b), f_mul(a.y, b), f_mul(a.z, b));
}

// --- division and square root: an estimate, made exact by integer remainders ----------
//
// Newton-Raphson gives the 25 leading bits of the quotient or root within a few units;
// the remainder of that candidate is computed exactly in 32-bit uint arithmetic (modulo
// 2^32, exact since it is far below 2^31 in magnitude), and the candidate is corrected
// until 0 <= remainder < divisor (Markstein's idea, with integers where he has an FMA).
// So the estimate's own rounding never shows, and the result is correctly rounded.

// sign | (exponent, significand) after rounding: the 24-bit significand `kept` (hidden bit
// included) with its round bit and sticky bit, rounded to nearest even; a carry out moves
// the exponent. Flushed below 2^-126, inf from 2^128.
float arith_pack(uint sign, int biased_exponent, uint kept, bool round_bit, bool sticky) {
    kept += uint(round_bit && (sticky || (kept & 1u) != 0u));
    if (kept == 0x01000000u) {
        kept = ARITH_HIDDEN_BIT;
        biased_exponent += 1;
    }
    if (biased_exponent >= 255) {
        return uintBitsToFloat(sign | ARITH_INF);
    }
    if (biased_exponent <= 0) {
        return uintBitsToFloat(sign);
    }
    return uintBitsToFloat(sign | (uint(biased_exponent) << 23) | (kept & ARITH_SIGNIFICAND));
}

// 1/d for d in [1, 2) within 1.5e-7 relative: a bit-pattern guess (5% off) and three
// Newton steps y (2 - d y).
float arith_reciprocal_estimate(float d) {
    precise float y = uintBitsToFloat(0x7ef311c3u - floatBitsToUint(d));
    for (int step = 0; step < 3; ++step) {
        precise float error = 2.0 - d * y;
        y = y * error;
    }
    return y;
}

// 1/sqrt(u) for u in [1, 4) within 1.5e-7 relative: the bit-pattern guess 0x5f3759df and
// three Newton steps y (3/2 - u/2 y^2).
float arith_inverse_root_estimate(float u) {
    precise float y = uintBitsToFloat(0x5f3759dfu - (floatBitsToUint(u) >> 1));
    for (int step = 0; step < 3; ++step) {
        precise float error = 1.5 - 0.5 * u * y * y;
        y = y * error;
    }
    return y;
}

// a / b correctly rounded: Q = floor(A 2^24 / B) of the significands A >= B (25 bits: 24
// and the round bit) with remainder R = A 2^24 - Q B (the sticky bit).
float f_div(float a, float b) {
    uint a_bits = floatBitsToUint(a);
    uint b_bits = floatBitsToUint(b);
    uint sign = (a_bits ^ b_bits) & ARITH_SIGN;
    uint a_exponent = (a_bits >> 23) & 0xffu;
    uint b_exponent = (b_bits >> 23) & 0xffu;
    uint a_significand = a_bits & ARITH_SIGNIFICAND;
    uint b_significand = b_bits & ARITH_SIGNIFICAND;
    bool a_nan = a_exponent == 255u && a_significand != 0u;
    bool b_nan = b_exponent == 255u && b_significand != 0u;
    if (a_nan || b_nan || (a_exponent == b_exponent && (a_exponent == 0u || a_exponent == 255u))) {
        return uintBitsToFloat(ARITH_QUIET_NAN);  // NaN, 0/0, inf/inf (subnormals read as 0)
    }
    if (a_exponent == 255u || b_exponent == 0u) {
        return uintBitsToFloat(sign | ARITH_INF);  // inf / finite, nonzero / 0
    }
    if (a_exponent == 0u || b_exponent == 255u) {
        return uintBitsToFloat(sign);  // 0 / nonzero, finite / inf
    }
    uint dividend = a_significand | ARITH_HIDDEN_BIT;
    uint divisor = b_significand | ARITH_HIDDEN_BIT;
    int biased_exponent = int(a_exponent) - int(b_exponent) + 127;
    if (dividend < divisor) {
        dividend <<= 1;
        biased_exponent -= 1;
    }
    // 2^23 / B, and Q within 8 units (float spacing 2 above 2^24, 1.5e-7 relative error)
    precise float reciprocal = arith_reciprocal_estimate(
        uintBitsToFloat(0x3f800000u | b_significand));
    precise float quotient_estimate = float(dividend) * reciprocal * 2.0;
    uint quotient = uint(quotient_estimate);
    int remainder = int((dividend << 24) - quotient * divisor);
    // remainder / B more quotient units (exact to within one), then the last unit
    precise float units = floor(float(remainder) * reciprocal * ARITH_TWO_MINUS_23);
    int steps = int(units);
    quotient += uint(steps);
    remainder -= steps * int(divisor);
    if (remainder < 0) {
        quotient -= 1u;
        remainder += int(divisor);
    }
    if (remainder >= int(divisor)) {
        quotient += 1u;
        remainder -= int(divisor);
    }
    return arith_pack(sign, biased_exponent, quotient >> 1, (quotient & 1u) != 0u,
                      remainder != 0);
}

vec2 f_div(vec2 a, vec2 b) {
    return vec2(f_div(a.x, b.x), f_div(a.y, b.y));
}

vec3 f_div(vec3 a, vec3 b) {
    return vec3(f_div(a.x, b.x), f_div(a.y, b.y), f_div(a.z, b.z));
}

vec2 f_div(vec2 a, float b) {
    return vec2(f_div(a.x, b), f_div(a.y, b));
}

vec3 f_div(vec3 a, float b) {
    return vec3(f_div(a.x, b), f_div(a.y, b), f_div(a.z, b));
}

// sqrt(x) correctly rounded: S = floor(sqrt(X)) of the significand scaled to X = m 2^25
// (even exponent) or m 2^26 (odd), 25 bits (24 and the round bit), with remainder
// R = X - S^2 (the sticky bit). sqrt(-0) = -0; sqrt(x < 0) = NaN.
float f_sqrt(float x) {
    uint bits = floatBitsToUint(x);
    uint biased = (bits >> 23) & 0xffu;
    uint significand = bits & ARITH_SIGNIFICAND;
    if (biased == 255u && significand != 0u) {
        return uintBitsToFloat(ARITH_QUIET_NAN);
    }
    if (biased == 0u) {
        return uintBitsToFloat(bits & ARITH_SIGN);  // +-0, subnormals read as zero
    }
    if ((bits & ARITH_SIGN) != 0u) {
        return uintBitsToFloat(ARITH_QUIET_NAN);
    }
    if (biased == 255u) {
        return x;  // +inf
    }
    int exponent = int(biased) - 127;
    bool odd = (exponent & 1) != 0;
    uint m = significand | ARITH_HIDDEN_BIT;
    // X 2^-48 in [1, 4), its root estimated within 1.5e-7 relative: S within 8 units
    precise float unit = uintBitsToFloat((odd ? 0x40000000u : 0x3f800000u) | significand);
    precise float inverse_root = arith_inverse_root_estimate(unit);
    precise float root_estimate = unit * inverse_root * ARITH_TWO_24;
    uint root = uint(root_estimate);
    int remainder = int((odd ? m << 26 : m << 25) - root * root);
    // R / 2S more units (within one), R updated exactly, then the last unit
    precise float units = floor(float(remainder) * inverse_root * ARITH_TWO_MINUS_25);
    int steps = int(units);
    remainder -= steps * (2 * int(root) + steps);
    root += uint(steps);
    if (remainder < 0) {
        remainder += 2 * int(root) - 1;
        root -= 1u;
    }
    if (remainder > 2 * int(root)) {
        root += 1u;
        remainder -= 2 * int(root) - 1;
    }
    return arith_pack(0u, (exponent >> 1) + 127, root >> 1, (root & 1u) != 0u,
                      remainder != 0);
}
