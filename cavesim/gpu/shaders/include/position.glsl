// A particle's position to 32 significant bits in the 40-byte record: the float32 `pos`
// (hi) and, per axis, a signed byte `code` for what hi leaves out (low), in 1/256 of hi's
// float32 spacing. Each step adds its increment to hi + low exactly (Knuth's TwoSum) and
// keeps the sum as a new hi + low, so steady motion stops losing the same rounding every
// step (README: the float32 floor); the forces still see hi. The record keeps low rounded
// to its byte. Twin: cavesim/core/position.py (bit for bit in portable arithmetic).
#pragma once
#include "arithmetic.glsl"

// The sums must stay exact: unfused and unreordered (`precise`), and in portable
// arithmetic with its flushing of results below 2^-126, as the twin computes them.
#if ARITHMETIC_MODE == ARITHMETIC_PORTABLE
#define position_add(a, b) f_add(a, b)
#define position_sub(a, b) f_sub(a, b)
#else
#define position_add(a, b) ((a) + (b))
#define position_sub(a, b) ((a) - (b))
#endif

// low of a hi whose exponent field is below this is 0: its code's unit would be subnormal
const uint LOW_EXPONENT_MIN = 32u;

// 2^(e - 158) as float bits: 1/256 of the spacing of floats with exponent field e
float low_unit(uint e) {
    return uintBitsToFloat((e - 31u) << 23);
}

uvec3 exponent_fields(vec3 hi) {
    return (floatBitsToUint(hi) >> 23) & uvec3(0xFFu);
}

vec3 low_part(vec3 hi, ivec3 code) {
    uvec3 e = exponent_fields(hi);
    vec3 low;
    for (int i = 0; i < 3; ++i) {
        low[i] = e[i] < LOW_EXPONENT_MIN ? 0.0 : f_mul(float(code[i]), low_unit(e[i]));
    }
    return low;
}

// low in units of 1/256 of hi's spacing, rounded to nearest even; |low| <= half a spacing,
// so only a tie at +128 is clamped (to 127)
ivec3 low_code(vec3 hi, vec3 low) {
    uvec3 e = exponent_fields(hi);
    ivec3 code;
    for (int i = 0; i < 3; ++i) {
        // 2^(158 - e): an exact power-of-two scaling
        float units = f_mul(low[i], uintBitsToFloat((285u - e[i]) << 23));
        code[i] = e[i] < LOW_EXPONENT_MIN ? 0 : int(clamp(roundEven(units), -128.0, 127.0));
    }
    return code;
}

// a + b == sum + error exactly, for any floats a and b (Knuth's TwoSum, six operations)
void two_sum(vec3 a, vec3 b, out vec3 sum, out vec3 error) {
    precise vec3 s = position_add(a, b);
    precise vec3 b_virtual = position_sub(s, a);
    precise vec3 a_virtual = position_sub(s, b_virtual);
    precise vec3 e = position_add(position_sub(a, a_virtual), position_sub(b, b_virtual));
    sum = s;
    error = e;
}

// The low part of the position of the particle being stepped (physics.glsl's advance
// sets it from the record and stores it back).
vec3 step_position_low;

// hi + low + dp as the new hi + low; returns hi. Every integrator moves its position
// through this, once a step.
vec3 move(vec3 hi, vec3 dp) {
    vec3 sum, rounding;
    two_sum(hi, dp, sum, rounding);
    precise vec3 carried = position_add(rounding, step_position_low);
    vec3 moved;
    two_sum(sum, carried, moved, step_position_low);
    return moved;
}
