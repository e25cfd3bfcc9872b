// The emitters' fixed parameters (from the scene) and the shared random texture.
// An emitter's state in the emitter stream is one uvec4:
//   x, y: fractional emission accumulator (float64 as two words), exact over any run
//   z:    particles it emits this frame
//   w:    emission serial of its first particle this frame (wraps at 2^32)
#pragma once
#include "random.glsl"
#include "arithmetic.glsl"

uniform float dt;

// The emitter table: one column per emitter, rows of four 32-bit words (float bits or
// uints) read with texelFetch only, so every value has the bits the host wrote. Rows 0-5
// come from the scene, rows 6-7 from the frame. Host side: cavesim/emitters.py fixed_rows
// and frame_rows.
uniform usampler2D emitter_table;

uvec4 emitter_row(int e, int row) {
    return texelFetch(emitter_table, ivec2(e, row), 0);
}

vec3 emitter_position(int e) { return uintBitsToFloat(emitter_row(e, 0).xyz); }
float emitter_rate(int e) { return uintBitsToFloat(emitter_row(e, 0).w); }  // per second
vec3 emitter_extent(int e) { return uintBitsToFloat(emitter_row(e, 1).xyz); }
// 1 - cos(the cone's half-angle)
float emitter_versine_spread(int e) { return uintBitsToFloat(emitter_row(e, 1).w); }
// the mean direction, with an orthonormal pair
vec3 emitter_axis(int e) { return uintBitsToFloat(emitter_row(e, 2).xyz); }
float emitter_speed(int e) { return uintBitsToFloat(emitter_row(e, 2).w); }
vec3 emitter_tangent(int e) { return uintBitsToFloat(emitter_row(e, 3).xyz); }
float emitter_speed_spread(int e) { return uintBitsToFloat(emitter_row(e, 3).w); }
vec3 emitter_bitangent(int e) { return uintBitsToFloat(emitter_row(e, 4).xyz); }
uint emitter_class(int e) { return emitter_row(e, 4).w; }
vec2 emitter_lifetime(int e) { return uintBitsToFloat(emitter_row(e, 5).xy); }
uvec2 emitter_random_base(int e) { return emitter_row(e, 5).zw; }
// this frame's cap on the count: the capacity, or the rate's bound
uint emitter_max_emit(int e) { return emitter_row(e, 7).x; }

#if FOLLOWING
// emitters that follow the helicopter: this frame's saltation factor and origin (1 and 0
// for the others), made by the master
double frame_rate(int e) {
    return double(emitter_rate(e)) * double(uintBitsToFloat(emitter_row(e, 6).w));
}

vec3 emitter_center(int e) {
    return f_add(uintBitsToFloat(emitter_row(e, 6).xyz), emitter_position(e));
}
#else
double frame_rate(int e) {
    return double(emitter_rate(e));
}

vec3 emitter_center(int e) {
    return emitter_position(e);
}
#endif

// Random word group `texel` (0 or 1) of the particle with emission `serial`.
// Twin: cavesim/core/random_texture.py lookup_coordinates.
uvec4 random_lookup(int e, uint serial, uint texel) {
    return random_texel(emitter_random_base(e), 2u * serial + texel);
}

// 24 random bits as an exact float in [0, 1): an integer below 2^24 times 2^-24 is exact
// in any arithmetic
float unit_float(uint word) {
    return float(word >> 8u) * 5.9604644775390625e-8;
}
