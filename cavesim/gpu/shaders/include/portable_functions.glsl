// Portable arithmetic, part 2 (arithmetic.glsl says what the mode is): exp, log, pow, sin
// and cos from the correctly rounded operations of portable_operations.glsl, and the vector
// forms, each one defined sequence. Included by arithmetic.glsl only, in
// ARITHMETIC_PORTABLE; twin: cavesim/core/portable/arithmetic.py.
#pragma once
#include "portable_operations.glsl"

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
