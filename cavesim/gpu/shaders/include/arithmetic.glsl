// The arithmetic of everything that enters the hashed particle state, in one of two modes
// chosen by ARITHMETIC (unset: native):
//   ARITHMETIC_NATIVE: the plain operators and GLSL built-ins, as fast as the GPU goes. The
//     GLSL spec leaves division (2.5 ULP), sqrt, exp, log, pow, sin and cos to the driver
//     and lets the compiler fuse a*b+c, so GPUs of different vendors part after a while.
//   ARITHMETIC_PORTABLE: the same bits on every GPU. Only +, - and * of the hardware are
//     used, each correctly rounded (GLSL 4.30, 4.7.1) and kept unfused by `precise`;
//     division and square root are Newton-Raphson estimates made exact by integer
//     remainders on the 24-bit significands (uint arithmetic is exact), so correctly
//     rounded; exp, log, sin and cos are Cody-Waite range reductions and Horner
//     polynomials (Moshier's Cephes expf, logf, sinf, cosf) of those +, -, *.
//     Subnormals are handled in code, never by the hardware (llvmpipe flushes them,
//     NVIDIA flushes in GL, others keep them):
//     - an operand whose exponent field is 0 reads as a zero of its sign (DAZ);
//     - a result is its exact value rounded to nearest even to 24 bits with an unbounded
//       exponent, then a zero of its sign if below 2^-126 in magnitude, inf if 2^128 or
//       more (FTZ by one definition: tininess after rounding);
//     - a NaN result is the quiet NaN 0x7fc00000, whatever the hardware's NaN.
// cavesim/core/portable/arithmetic.py is the float32 numpy twin: the same operation
// sequences, bit for bit. README.md "Portable arithmetic" states accuracy and cost.
#pragma once

#define ARITHMETIC_NATIVE 0
#define ARITHMETIC_PORTABLE 1

#if !defined ARITHMETIC
#define ARITHMETIC_MODE ARITHMETIC_NATIVE
#else
#define ARITHMETIC_MODE ARITHMETIC
#endif
#if ARITHMETIC_MODE != ARITHMETIC_NATIVE && ARITHMETIC_MODE != ARITHMETIC_PORTABLE
#error ARITHMETIC must be ARITHMETIC_NATIVE (0) or ARITHMETIC_PORTABLE (1)
#endif

#if ARITHMETIC_MODE == ARITHMETIC_PORTABLE

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

// --- exp, log, pow, sin, cos: range reduction and polynomials of +, -, * ---------------
//
// Inside these functions the operations are plain `precise` ones, not flushed: none of
// their values is subnormal or near 2^-126, except, for tiny arguments, terms that are
// then added to a value at least 2^24 times larger (r^2 P(r) to r in exp, r^3 S(r^2) to r
// and r^4 C(r^2) - r^2/2 to 1 in sin and cos, (x 2/pi) to 1/2). Such a sum rounds to the
// larger value whatever the hardware made of the tiny term (a subnormal, a zero, 2^-126),
// so the result has the same bits everywhere.

#define ARITH_LOG2_E uintBitsToFloat(0x3fb8aa3bu)   // 1.44269502
// ln 2 = LN2_HIGH + LN2_LOW (Cody-Waite; LN2_HIGH = 355/512 has 9 bits, so n LN2_HIGH is
// exact for |n| < 2^15)
const float ARITH_LN2_HIGH = 0.693359375;
#define ARITH_LN2_LOW uintBitsToFloat(0xb95e8083u)  // -2.12194442e-4
// Cephes expf: e^r = 1 + r + r^2 P(r) on |r| <= ln2 / 2
#define ARITH_EXP_P0 uintBitsToFloat(0x39506967u)   // 1.98756912e-4
#define ARITH_EXP_P1 uintBitsToFloat(0x3ab743ceu)   // 1.39819994e-3
#define ARITH_EXP_P2 uintBitsToFloat(0x3c088908u)   // 8.33345205e-3
#define ARITH_EXP_P3 uintBitsToFloat(0x3d2aa9c1u)   // 4.16657962e-2
#define ARITH_EXP_P4 uintBitsToFloat(0x3e2aaaaau)   // 1.66666657e-1
const float ARITH_EXP_P5 = 0.5;

// p 2^n for p in [0.5, 2) (positive), by the exponent field: exact; a zero below 2^-126,
// inf from 2^128.
float arith_scale(float p, int n) {
    uint bits = floatBitsToUint(p);
    int biased_exponent = int(bits >> 23) + n;
    if (biased_exponent <= 0) {
        return 0.0;
    }
    if (biased_exponent >= 255) {
        return uintBitsToFloat(ARITH_INF);
    }
    return uintBitsToFloat((uint(biased_exponent) << 23) | (bits & ARITH_SIGNIFICAND));
}

// e^x for x not subnormal: n = round(x log2 e), r = x - n ln2 (Cody-Waite), e^r by the
// Cephes polynomial, scaled by 2^n.
float arith_exp(float x) {
    uint bits = floatBitsToUint(x);
    if ((bits & ARITH_MAGNITUDE) > ARITH_INF) {
        return uintBitsToFloat(ARITH_QUIET_NAN);
    }
    // e^89 overflows and e^-104 flushes whatever the polynomial gives; the clamp keeps n
    // an int for any x, inf included
    precise float clamped = clamp(x, -104.0, 89.0);
    precise float n = floor(clamped * ARITH_LOG2_E + 0.5);
    // r = x for n = 0; otherwise 0 or at least 2^-36 (a multiple of n LN2_LOW's last place)
    precise float r = (clamped - n * ARITH_LN2_HIGH) - n * ARITH_LN2_LOW;
    precise float r2 = r * r;
    precise float p = ARITH_EXP_P0;
    p = p * r + ARITH_EXP_P1;
    p = p * r + ARITH_EXP_P2;
    p = p * r + ARITH_EXP_P3;
    p = p * r + ARITH_EXP_P4;
    p = p * r + ARITH_EXP_P5;
    p = (p * r2 + r) + 1.0;
    return arith_scale(p, int(n));
}

float f_exp(float x) {
    return arith_exp(f_ftz(x));
}

// Cephes logf: log(1 + f) = f - f^2/2 + f^3 Q(f) for 1 + f in [sqrt(1/2), sqrt(2))
const uint ARITH_SQRT2_BITS = 0x3fb504f3u;                 // 1.41421354
#define ARITH_LOG_Q0 uintBitsToFloat(0x3d9021bbu)   //  7.03768358e-2
#define ARITH_LOG_Q1 uintBitsToFloat(0xbdebd1b8u)   // -1.15146101e-1
#define ARITH_LOG_Q2 uintBitsToFloat(0x3def251au)   //  1.16769984e-1
#define ARITH_LOG_Q3 uintBitsToFloat(0xbdfe5d4fu)   // -1.24201410e-1
#define ARITH_LOG_Q4 uintBitsToFloat(0x3e11e9bfu)   //  1.42493233e-1
#define ARITH_LOG_Q5 uintBitsToFloat(0xbe2aae50u)   // -1.66680574e-1
#define ARITH_LOG_Q6 uintBitsToFloat(0x3e4cceacu)   //  2.00007141e-1
#define ARITH_LOG_Q7 uintBitsToFloat(0xbe7ffffcu)   // -2.49999940e-1
#define ARITH_LOG_Q8 uintBitsToFloat(0x3eaaaaaau)   //  3.33333313e-1

// log x for x not subnormal: x = (1 + f) 2^e by the bits (exact), then the polynomial.
// log(+-0) = -inf, log(x < 0) = NaN, log(inf) = inf.
float arith_log(float x) {
    uint bits = floatBitsToUint(x);
    uint magnitude = bits & ARITH_MAGNITUDE;
    if (magnitude > ARITH_INF || (magnitude != 0u && (bits & ARITH_SIGN) != 0u)) {
        return uintBitsToFloat(ARITH_QUIET_NAN);
    }
    if (magnitude == 0u) {
        return uintBitsToFloat(ARITH_SIGN | ARITH_INF);
    }
    if (magnitude == ARITH_INF) {
        return x;
    }
    int e = int(bits >> 23) - 127;
    uint one_plus_f = (bits & ARITH_SIGNIFICAND) | 0x3f800000u;  // in [1, 2)
    if (one_plus_f >= ARITH_SQRT2_BITS) {
        one_plus_f -= ARITH_HIDDEN_BIT;  // halved, into [sqrt(1/2), 1)
        e += 1;
    }
    // f is 0 or at least 2^-24 in magnitude, and each Horner value 0 or at least 2^-28
    // (a sum of terms near 0.1), so no value here comes near the subnormals
    precise float f = uintBitsToFloat(one_plus_f) - 1.0;  // exact (Sterbenz)
    precise float f2 = f * f;
    precise float q = ARITH_LOG_Q0;
    q = q * f + ARITH_LOG_Q1;
    q = q * f + ARITH_LOG_Q2;
    q = q * f + ARITH_LOG_Q3;
    q = q * f + ARITH_LOG_Q4;
    q = q * f + ARITH_LOG_Q5;
    q = q * f + ARITH_LOG_Q6;
    q = q * f + ARITH_LOG_Q7;
    q = q * f + ARITH_LOG_Q8;
    q = (q * f) * f2;
    precise float fe = float(e);
    q = q + fe * ARITH_LN2_LOW;
    q = q - 0.5 * f2;
    precise float result = (f + q) + fe * ARITH_LN2_HIGH;
    return result;
}

float f_log(float x) {
    return arith_log(f_ftz(x));
}

// x^y = e^(y log x) for x > 0: the error grows with |y log x| (README.md).
float f_pow(float x, float y) {
    return arith_exp(arith_mul(f_ftz(y), arith_log(f_ftz(x))));
}

// x - n pi/2 with pi/2 = PIO2_1 + PIO2_2 + PIO2_3 + PIO2_4 (Cody-Waite; Cephes' first two
// parts, 8 and 11 bits, the third 11 bits, so n PIO2_1..3 are exact for |n| < 2^13, that
// is |x| < 12867; the four parts sum to pi/2 within 2^-64 of it, enough for arguments as
// close to a multiple of pi/2 as float32 holds: README.md "Portable arithmetic")
#define ARITH_TWO_OVER_PI uintBitsToFloat(0x3f22f983u)  // 0.636619747
const float ARITH_PIO2_1 = 1.5703125;
#define ARITH_PIO2_2 uintBitsToFloat(0x39fda000u)  // 4.83751297e-4
#define ARITH_PIO2_3 uintBitsToFloat(0x33a22000u)  // 7.54953362e-8
#define ARITH_PIO2_4 uintBitsToFloat(0x2c34611au)  // 2.56334407e-12
// Cephes sinf/cosf on |r| <= pi/4: sin r = r + r^3 S(r^2), cos r = 1 - r^2/2 + r^4 C(r^2)
#define ARITH_SIN_S0 uintBitsToFloat(0xb94ca1f9u)  // -1.95152956e-4
#define ARITH_SIN_S1 uintBitsToFloat(0x3c08839eu)  //  8.33216123e-3
#define ARITH_SIN_S2 uintBitsToFloat(0xbe2aaaa3u)  // -1.66666552e-1
#define ARITH_COS_C0 uintBitsToFloat(0x37ccf5ceu)  //  2.44331568e-5
#define ARITH_COS_C1 uintBitsToFloat(0xbab6061au)  // -1.38873165e-3
#define ARITH_COS_C2 uintBitsToFloat(0x3d2aaaa5u)  //  4.16666456e-2

// sin r and cos r of the reduced argument, and the quadrant n mod 4 of x, for x finite
// and not subnormal.
void arith_sin_cos_reduced(float x, out float sin_r, out float cos_r, out int quadrant) {
    precise float n = floor(x * ARITH_TWO_OVER_PI + 0.5);
    // r = x for n = 0; otherwise 0 or at least 2^-62 (a multiple of n PIO2_4's last place)
    precise float r = x - n * ARITH_PIO2_1;
    r = r - n * ARITH_PIO2_2;
    r = r - n * ARITH_PIO2_3;
    r = r - n * ARITH_PIO2_4;
    // n mod 4, exact for any n: n/4 and 4 floor(n/4) are exact, their difference too
    precise float n_mod_4 = n - floor(n * 0.25) * 4.0;
    quadrant = int(n_mod_4);
    precise float r2 = r * r;
    precise float s = ARITH_SIN_S0;
    s = s * r2 + ARITH_SIN_S1;
    s = s * r2 + ARITH_SIN_S2;
    precise float sine = (s * r2) * r + r;
    sin_r = sine;
    precise float c = ARITH_COS_C0;
    c = c * r2 + ARITH_COS_C1;
    c = c * r2 + ARITH_COS_C2;
    c = (c * r2) * r2;
    precise float cosine = (c - 0.5 * r2) + 1.0;
    cos_r = cosine;
}

// sin x; accurate for |x| <= 8192 (README.md), NaN for inf and NaN.
float f_sin(float x) {
    x = f_ftz(x);
    if ((floatBitsToUint(x) & ARITH_MAGNITUDE) >= ARITH_INF) {
        return uintBitsToFloat(ARITH_QUIET_NAN);
    }
    float sin_r, cos_r;
    int quadrant;
    arith_sin_cos_reduced(x, sin_r, cos_r, quadrant);
    float value = (quadrant & 1) == 0 ? sin_r : cos_r;
    // |x| too large for the reduction makes inf - inf inside it: the hardware's own NaN
    return arith_quiet(quadrant >= 2 ? -value : value);
}

// cos x; accurate for |x| <= 8192 (README.md), NaN for inf and NaN.
float f_cos(float x) {
    x = f_ftz(x);
    if ((floatBitsToUint(x) & ARITH_MAGNITUDE) >= ARITH_INF) {
        return uintBitsToFloat(ARITH_QUIET_NAN);
    }
    float sin_r, cos_r;
    int quadrant;
    arith_sin_cos_reduced(x, sin_r, cos_r, quadrant);
    float value = (quadrant & 1) == 0 ? cos_r : sin_r;
    // |x| too large for the reduction makes inf - inf inside it: the hardware's own NaN
    return arith_quiet(quadrant == 1 || quadrant == 2 ? -value : value);
}

// --- vector forms, each one defined sequence ------------------------------------------

// ((a.x b.x + a.y b.y) + a.z b.z)
float f_dot(vec3 a, vec3 b) {
    a = f_ftz(a);
    b = f_ftz(b);
    return arith_quiet(arith_add(arith_add(arith_mul(a.x, b.x), arith_mul(a.y, b.y)),
                                 arith_mul(a.z, b.z)));
}

float f_dot(vec2 a, vec2 b) {
    a = f_ftz(a);
    b = f_ftz(b);
    return arith_quiet(arith_add(arith_mul(a.x, b.x), arith_mul(a.y, b.y)));
}

float f_length(vec3 x) {
    return f_sqrt(f_dot(x, x));
}

float f_length(vec2 x) {
    return f_sqrt(f_dot(x, x));
}

vec3 f_normalize(vec3 x) {
    return f_div(x, f_length(x));
}

// a + t (b - a)
float f_mix(float a, float b, float t) {
    return f_add(a, f_mul(t, f_sub(b, a)));
}

vec2 f_mix(vec2 a, vec2 b, vec2 t) {
    return f_add(a, f_mul(t, f_sub(b, a)));
}

vec3 f_mix(vec3 a, vec3 b, vec3 t) {
    return f_add(a, f_mul(t, f_sub(b, a)));
}

vec2 f_mix(vec2 a, vec2 b, float t) {
    return f_add(a, f_mul(t, f_sub(b, a)));
}

vec3 f_mix(vec3 a, vec3 b, float t) {
    return f_add(a, f_mul(t, f_sub(b, a)));
}

#else  // ARITHMETIC_NATIVE: the operators and built-ins themselves

float f_ftz(float x) { return x; }
vec2 f_ftz(vec2 x) { return x; }
vec3 f_ftz(vec3 x) { return x; }
float f_add(float a, float b) { return a + b; }
vec2 f_add(vec2 a, vec2 b) { return a + b; }
vec3 f_add(vec3 a, vec3 b) { return a + b; }
float f_sub(float a, float b) { return a - b; }
vec2 f_sub(vec2 a, vec2 b) { return a - b; }
vec3 f_sub(vec3 a, vec3 b) { return a - b; }
float f_mul(float a, float b) { return a * b; }
vec2 f_mul(vec2 a, vec2 b) { return a * b; }
vec3 f_mul(vec3 a, vec3 b) { return a * b; }
vec2 f_mul(float a, vec2 b) { return a * b; }
vec3 f_mul(float a, vec3 b) { return a * b; }
vec2 f_mul(vec2 a, float b) { return a * b; }
vec3 f_mul(vec3 a, float b) { return a * b; }
float f_div(float a, float b) { return a / b; }
vec2 f_div(vec2 a, vec2 b) { return a / b; }
vec3 f_div(vec3 a, vec3 b) { return a / b; }
vec2 f_div(vec2 a, float b) { return a / b; }
vec3 f_div(vec3 a, float b) { return a / b; }
float f_sqrt(float x) { return sqrt(x); }
float f_exp(float x) { return exp(x); }
float f_log(float x) { return log(x); }
float f_pow(float x, float y) { return pow(x, y); }
float f_sin(float x) { return sin(x); }
float f_cos(float x) { return cos(x); }
float f_dot(vec3 a, vec3 b) { return dot(a, b); }
float f_dot(vec2 a, vec2 b) { return dot(a, b); }
float f_length(vec3 x) { return length(x); }
float f_length(vec2 x) { return length(x); }
vec3 f_normalize(vec3 x) { return normalize(x); }
float f_mix(float a, float b, float t) { return mix(a, b, t); }
vec2 f_mix(vec2 a, vec2 b, vec2 t) { return mix(a, b, t); }
vec3 f_mix(vec3 a, vec3 b, vec3 t) { return mix(a, b, t); }
vec2 f_mix(vec2 a, vec2 b, float t) { return mix(a, b, t); }
vec3 f_mix(vec3 a, vec3 b, float t) { return mix(a, b, t); }

#endif
