// The ground (COLLISION: a plane, or a height field) and the bounce off it. Twins:
// cavesim/core/twin/collision.py and cavesim/core/portable/ground.py.
#pragma once
#include "arithmetic.glsl"
#include "position.glsl"

#if COLLISION != COLLISION_NONE
uniform float friction;  // nu: share of tangential speed lost at a bounce
uniform float resilience;  // epsilon: share of normal speed kept at a bounce
uniform float friction_min_speed;
#if COLLISION == COLLISION_PLANE
uniform float ground_z;

void ground_at(vec2 xy, out float height, out vec3 normal) {
    height = ground_z;
    normal = vec3(0.0, 0.0, 1.0);
}
#else
#include "heightfield.glsl"
#endif

// Kolb et al.: v' = (1 - nu) v_t - epsilon v_n when heading into the ground, no friction
// below a small speed; a particle caught below the surface is pushed back onto it.
void collide(inout vec3 p, inout vec3 v) {
    float height;
    vec3 n;
    ground_at(p.xy, height, n);
    if (p.z >= height) {
        return;
    }
    p.z = height;
    step_position_low.z = 0.0;
    float vn = f_dot(v, n);
    if (vn < 0.0) {
        vec3 v_normal = f_mul(vn, n);
        vec3 v_tangent = f_sub(v, v_normal);
        float keep = f_length(v) < friction_min_speed ? 1.0 : f_sub(1.0, friction);
        v = f_sub(f_mul(keep, v_tangent), f_mul(resilience, v_normal));
    }
}
#endif
