// The emitters' fixed parameters (from the scene) and the shared random texture.
// An emitter's state in the emitter stream is one uvec4:
//   x, y: fractional emission accumulator (float64 as two words), exact over any run
//   z:    particles it emits this frame
//   w:    emission serial of its first particle this frame (wraps at 2^32)
#pragma once

uniform float dt;
uniform float emitter_rate[EMITTER_COUNT];  // particles per second
uniform uint emitter_max_emit[EMITTER_COUNT];  // this frame's cap: capacity, or rate bound
uniform vec3 emitter_position[EMITTER_COUNT];
uniform vec3 emitter_extent[EMITTER_COUNT];
uniform vec3 emitter_axis[EMITTER_COUNT];  // mean direction, with an orthonormal pair:
uniform vec3 emitter_tangent[EMITTER_COUNT];
uniform vec3 emitter_bitangent[EMITTER_COUNT];
uniform float emitter_versine_spread[EMITTER_COUNT];  // 1 - cos(the cone's half-angle)
uniform float emitter_speed[EMITTER_COUNT];
uniform float emitter_speed_spread[EMITTER_COUNT];
uniform vec2 emitter_lifetime[EMITTER_COUNT];
uniform uint emitter_class[EMITTER_COUNT];
uniform uvec2 emitter_random_base[EMITTER_COUNT];

#if FOLLOWING
// emitters that follow the helicopter: this frame's saltation factor and origin (1 and 0
// for the others), made by the master
uniform float emitter_rate_factor[EMITTER_COUNT];
uniform vec3 emission_origin[EMITTER_COUNT];

double frame_rate(int e) {
    return double(emitter_rate[e]) * double(emitter_rate_factor[e]);
}

vec3 emitter_center(int e) {
    return emission_origin[e] + emitter_position[e];
}
#else
double frame_rate(int e) {
    return double(emitter_rate[e]);
}

vec3 emitter_center(int e) {
    return emitter_position[e];
}
#endif

uniform usampler2D random_texture;  // RGBA32UI, RANDOM_SIZE square, read with texelFetch only
uniform mat3 random_transform;  // this frame's integer affine map of the texel lattice

// Random word group `texel` (0 or 1) of the particle with emission `serial`; the
// arithmetic is integer and wraps modulo 2^32, so it is exact on every GPU.
// Twin: cavesim/random_texture.py lookup_coordinates.
uvec4 random_lookup(int e, uint serial, uint texel) {
    const uint mask = uint(RANDOM_SIZE - 1);
    uint k = 2u * serial + texel;
    uvec2 base = emitter_random_base[e];
    int x = int((base.x + (k & mask)) & mask);
    int y = int((base.y + k / uint(RANDOM_SIZE)) & mask);
    ivec3 col0 = ivec3(random_transform[0]);
    ivec3 col1 = ivec3(random_transform[1]);
    ivec3 col2 = ivec3(random_transform[2]);
    int moved_x = (col0.x * x + col1.x * y + col2.x) & int(mask);
    int moved_y = (col0.y * x + col1.y * y + col2.y) & int(mask);
    return texelFetch(random_texture, ivec2(moved_x, moved_y), 0);
}

// 24 random bits as an exact float in [0, 1)
float unit_float(uint word) {
    return float(word >> 8u) * (1.0 / 16777216.0);
}
