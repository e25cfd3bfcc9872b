// Flow velocity from the scene's 3D field texture (compiled in only with Stokes drag).
// Node (i, j, k) of the grid sits at field_box_min + (i, j, k) / field_index_scale.
// MANUAL sampling is trilinear from texelFetch through arithmetic.glsl, the same bits on
// every GPU in portable arithmetic (twin: cavesim/core/portable/field.py); HARDWARE uses
// the texture unit (faster, but vendors differ in filter weights, so the scene loader
// refuses it with portable arithmetic).
#pragma once
#include "arithmetic.glsl"

uniform sampler3D flow_field;
uniform vec3 field_box_min;
uniform vec3 field_index_scale;  // (resolution - 1) / (box_max - box_min)

vec3 flow_at(vec3 p) {
    ivec3 res = textureSize(flow_field, 0);
    vec3 last = vec3(res - 1);
    vec3 f = f_mul(f_sub(p, field_box_min), field_index_scale);
#if FIELD_OUT_OF_DOMAIN == OUT_OF_DOMAIN_ZERO
    if (any(lessThan(f, vec3(0.0))) || any(greaterThan(f, last))) {
        return vec3(0.0);
    }
#endif
    f = clamp(f, vec3(0.0), last);
#if FIELD_SAMPLING == SAMPLING_HARDWARE
    return texture(flow_field, (f + 0.5) / vec3(res)).xyz;
#else
    ivec3 i0 = min(ivec3(floor(f)), res - 2);
    vec3 t = f_sub(f, vec3(i0));
    vec3 c000 = texelFetch(flow_field, i0, 0).xyz;
    vec3 c100 = texelFetch(flow_field, i0 + ivec3(1, 0, 0), 0).xyz;
    vec3 c010 = texelFetch(flow_field, i0 + ivec3(0, 1, 0), 0).xyz;
    vec3 c110 = texelFetch(flow_field, i0 + ivec3(1, 1, 0), 0).xyz;
    vec3 c001 = texelFetch(flow_field, i0 + ivec3(0, 0, 1), 0).xyz;
    vec3 c101 = texelFetch(flow_field, i0 + ivec3(1, 0, 1), 0).xyz;
    vec3 c011 = texelFetch(flow_field, i0 + ivec3(0, 1, 1), 0).xyz;
    vec3 c111 = texelFetch(flow_field, i0 + ivec3(1, 1, 1), 0).xyz;
    vec3 c00 = f_mix(c000, c100, t.x);
    vec3 c10 = f_mix(c010, c110, t.x);
    vec3 c01 = f_mix(c001, c101, t.x);
    vec3 c11 = f_mix(c011, c111, t.x);
    return f_mix(f_mix(c00, c10, t.y), f_mix(c01, c11, t.y), t.z);
#endif
}
