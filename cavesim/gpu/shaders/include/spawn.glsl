// A new particle of emitter `e`, drawn from the random texture through the frame's matrix:
// the emission arithmetic both engine paths share (emit.glsl: geometry shader + transform
// feedback; append.glsl: compute). Twins: cavesim/core/twin/emission.py spawn (float64),
// cavesim/core/portable/spawn.py (portable arithmetic).
#pragma once
#include "arithmetic.glsl"
#include "record.glsl"
#include "emitters.glsl"

// 2 pi as exact float32 bits (a long literal's rounding is up to the compiler;
// cavesim/core/portable/constants.py)
#define TWO_PI uintBitsToFloat(0x40C90FDBu)

// Uniform in the emitter's box, direction uniform in its cone, speed and lifetime uniform
// in their ranges; `serial` is the particle's emission serial (its random texels).
Particle spawn(int e, uint serial) {
    uvec4 r0 = random_lookup(e, serial, 0u);
    uvec4 r1 = random_lookup(e, serial, 1u);
    Particle q;
    vec3 in_box = f_sub(vec3(unit_float(r0.x), unit_float(r0.y), unit_float(r0.z)), vec3(0.5));
    q.pos = f_add(emitter_center(e), f_mul(in_box, emitter_extent(e)));
    q.pos_low = vec3(0.0);
    // versine form: sqrt(1 - cos^2) would cancel in float32 for narrow cones
    float versine = f_mul(unit_float(r0.w), emitter_versine_spread(e));
    float cos_theta = f_sub(1.0, versine);
    float sin_theta = f_sqrt(max(0.0, f_mul(versine, f_sub(2.0, versine))));
    float phi = f_mul(TWO_PI, unit_float(r1.x));
    vec3 direction = f_add(f_add(f_mul(f_mul(sin_theta, f_cos(phi)), emitter_tangent(e)),
                                 f_mul(f_mul(sin_theta, f_sin(phi)), emitter_bitangent(e))),
                           f_mul(cos_theta, emitter_axis(e)));
    float spread = f_sub(f_mul(2.0, unit_float(r1.y)), 1.0);
    float speed = f_add(emitter_speed(e), f_mul(emitter_speed_spread(e), spread));
    q.vel = f_mul(speed, direction);
    q.age = 0.0LF;
    vec2 life = emitter_lifetime(e);
    q.lifetime = f_add(life.x, f_mul(f_sub(life.y, life.x), unit_float(r1.z)));
    q.class_id = emitter_class(e);
    return q;
}
