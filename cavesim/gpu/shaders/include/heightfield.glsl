// Ground height and upward normal from the scene's height field (R32F, nx by ny), the
// bilinear surface with the index clamped to the grid: outside the box the edge height
// continues, flat across the edge. Twins: cavesim/core/fields/heights.py sample_height
// (float64), cavesim/core/portable/ground.py (portable arithmetic).
#pragma once
#include "arithmetic.glsl"

uniform sampler2D ground_height;
uniform vec2 ground_box_min;
uniform vec2 ground_index_scale;  // (resolution - 1) / (box_max - box_min)

void ground_at(vec2 xy, out float height, out vec3 normal) {
    ivec2 res = textureSize(ground_height, 0);
    vec2 unclamped = f_mul(f_sub(xy, ground_box_min), ground_index_scale);
    vec2 f = clamp(unclamped, vec2(0.0), vec2(res - 1));
    vec2 inside = vec2(equal(f, unclamped));
    ivec2 i0 = min(ivec2(floor(f)), res - 2);
    vec2 t = f_sub(f, vec2(i0));
    float h00 = texelFetch(ground_height, i0, 0).r;
    float h10 = texelFetch(ground_height, i0 + ivec2(1, 0), 0).r;
    float h01 = texelFetch(ground_height, i0 + ivec2(0, 1), 0).r;
    float h11 = texelFetch(ground_height, i0 + ivec2(1, 1), 0).r;
    height = f_mix(f_mix(h00, h10, t.x), f_mix(h01, h11, t.x), t.y);
    float slope_x = f_mix(f_sub(h10, h00), f_sub(h11, h01), t.y);
    float slope_y = f_mix(f_sub(h01, h00), f_sub(h11, h10), t.x);
    float dh_dx = f_mul(f_mul(slope_x, ground_index_scale.x), inside.x);
    float dh_dy = f_mul(f_mul(slope_y, ground_index_scale.y), inside.y);
    normal = f_normalize(vec3(-dh_dx, -dh_dy, 1.0));
}
