// A new particle of emitter `e`, drawn from the random texture through the frame's matrix:
// the emission arithmetic both engine paths share (emit.glsl: geometry shader + transform
// feedback; append.glsl: compute). Twin: cavesim/core/twin/emission.py spawn.
#pragma once
#include "record.glsl"
#include "emitters.glsl"

const float TWO_PI = 6.283185307179586;

// Uniform in the emitter's box, direction uniform in its cone, speed and lifetime uniform
// in their ranges; `serial` is the particle's emission serial (its random texels).
Particle spawn(int e, uint serial) {
    uvec4 r0 = random_lookup(e, serial, 0u);
    uvec4 r1 = random_lookup(e, serial, 1u);
    Particle q;
    q.pos = emitter_center(e) + (vec3(unit_float(r0.x), unit_float(r0.y), unit_float(r0.z))
                                 - 0.5) * emitter_extent(e);
    // versine form: sqrt(1 - cos^2) would cancel in float32 for narrow cones
    float versine = unit_float(r0.w) * emitter_versine_spread(e);
    float cos_theta = 1.0 - versine;
    float sin_theta = sqrt(max(0.0, versine * (2.0 - versine)));
    float phi = TWO_PI * unit_float(r1.x);
    vec3 direction = (sin_theta * cos(phi)) * emitter_tangent(e)
                   + (sin_theta * sin(phi)) * emitter_bitangent(e)
                   + cos_theta * emitter_axis(e);
    float speed = emitter_speed(e) + emitter_speed_spread(e) * (2.0 * unit_float(r1.y) - 1.0);
    q.vel = speed * direction;
    q.age = 0.0LF;
    vec2 life = emitter_lifetime(e);
    q.lifetime = life.x + (life.y - life.x) * unit_float(r1.z);
    q.class_id = emitter_class(e);
    return q;
}
