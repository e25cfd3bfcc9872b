// One function of include/arithmetic.glsl (FUNCTION, numbered as
// cavesim/gpu/gl/arithmetic_probe.py's FUNCTIONS) applied to each case's operands a, b, c,
// in the mode ARITHMETIC. With REPEAT > 0 it runs REPEAT calls per case on operands one ULP
// apart and writes their results xor-ed together: a timing of the calls.

#include "/include/arithmetic.glsl"

#if defined COMPUTE_SHADER
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Operands {
    uint operands[];  // 9 per case: a.xyz, b.xyz, c.xyz
};
layout(std430, binding = 1) writeonly buffer Results {
    uint results[];  // 3 per case: a scalar result in the first, zeros after it
};
uniform uint case_count;

vec3 operand(uint n, uint k) {
    uint first = 9u * n + 3u * k;
    return uintBitsToFloat(uvec3(operands[first], operands[first + 1u], operands[first + 2u]));
}

vec3 apply(vec3 a, vec3 b, vec3 c) {
#if FUNCTION == 0
    return vec3(f_ftz(a.x), 0.0, 0.0);
#elif FUNCTION == 1
    return vec3(f_add(a.x, b.x), 0.0, 0.0);
#elif FUNCTION == 2
    return vec3(f_sub(a.x, b.x), 0.0, 0.0);
#elif FUNCTION == 3
    return vec3(f_mul(a.x, b.x), 0.0, 0.0);
#elif FUNCTION == 4
    return vec3(f_div(a.x, b.x), 0.0, 0.0);
#elif FUNCTION == 5
    return vec3(f_sqrt(a.x), 0.0, 0.0);
#elif FUNCTION == 6
    return vec3(f_exp(a.x), 0.0, 0.0);
#elif FUNCTION == 7
    return vec3(f_log(a.x), 0.0, 0.0);
#elif FUNCTION == 8
    return vec3(f_pow(a.x, b.x), 0.0, 0.0);
#elif FUNCTION == 9
    return vec3(f_sin(a.x), 0.0, 0.0);
#elif FUNCTION == 10
    return vec3(f_cos(a.x), 0.0, 0.0);
#elif FUNCTION == 11
    return vec3(f_mix(a.x, b.x, c.x), 0.0, 0.0);
#elif FUNCTION == 12
    return vec3(f_dot(a, b), 0.0, 0.0);
#elif FUNCTION == 13
    return vec3(f_dot(a.xy, b.xy), 0.0, 0.0);
#elif FUNCTION == 14
    return vec3(f_length(a), 0.0, 0.0);
#elif FUNCTION == 15
    return vec3(f_length(a.xy), 0.0, 0.0);
#elif FUNCTION == 16
    return f_normalize(a);
#elif FUNCTION == 17
    return f_add(a, b);
#elif FUNCTION == 18
    return f_sub(a, b);
#elif FUNCTION == 19
    return f_mul(a, b);
#elif FUNCTION == 20
    return f_mul(a.x, b);
#elif FUNCTION == 21
    return f_mul(a, b.x);
#elif FUNCTION == 22
    return f_div(a, b);
#elif FUNCTION == 23
    return f_div(a, b.x);
#elif FUNCTION == 24
    return f_mix(a, b, c);
#elif FUNCTION == 25
    return f_mix(a, b, c.x);
#elif FUNCTION == 26
    return vec3(f_add(a.xy, b.xy), 0.0);
#elif FUNCTION == 27
    return vec3(f_sub(a.xy, b.xy), 0.0);
#elif FUNCTION == 28
    return vec3(f_mul(a.xy, b.xy), 0.0);
#elif FUNCTION == 29
    return vec3(f_mul(a.x, b.xy), 0.0);
#elif FUNCTION == 30
    return vec3(f_mul(a.xy, b.x), 0.0);
#elif FUNCTION == 31
    return vec3(f_div(a.xy, b.xy), 0.0);
#elif FUNCTION == 32
    return vec3(f_div(a.xy, b.x), 0.0);
#elif FUNCTION == 33
    return vec3(f_mix(a.xy, b.xy, c.xy), 0.0);
#elif FUNCTION == 34
    return vec3(f_mix(a.xy, b.xy, c.x), 0.0);
#elif FUNCTION == 35
    return f_ftz(a);
#elif FUNCTION == 36
    return vec3(f_ftz(a.xy), 0.0);
#else
#error FUNCTION names no function of arithmetic_probe.py's FUNCTIONS
#endif
}

void main() {
    uint n = gl_GlobalInvocationID.x;
    if (n >= case_count) {
        return;
    }
    vec3 a = operand(n, 0u);
    vec3 b = operand(n, 1u);
    vec3 c = operand(n, 2u);
#if REPEAT == 0
    uvec3 bits = floatBitsToUint(apply(a, b, c));
#else
    uvec3 bits = uvec3(0u);
    for (int call = 0; call < REPEAT; ++call) {
        bits ^= floatBitsToUint(apply(a, b, c));
        a = uintBitsToFloat(floatBitsToUint(a) + 1u);
    }
#endif
    results[3u * n] = bits.x;
    results[3u * n + 1u] = bits.y;
    results[3u * n + 2u] = bits.z;
}
#endif
