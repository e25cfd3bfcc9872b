// Flow velocity from the scene's 3D field texture (compiled in only with Stokes drag).
// Node (i, j, k) of the grid sits at field_box_min + (i, j, k) / field_index_scale.
// MANUAL sampling reads texels with texelFetch and interpolates through arithmetic.glsl,
// the same bits on every GPU in portable arithmetic (twin: cavesim/core/portable/field.py):
// trilinear (8 nodes), or with FIELD_INTERPOLATION a C1 Catmull-Rom or C2 cubic B-spline
// (64 texels). HARDWARE uses the texture unit's trilinear filter (faster, but vendors differ
// in filter weights, so the scene loader refuses it with portable arithmetic or a cubic).
// FIELD_TIME_SERIES: the snapshots of a time series stacked along z, each the same texels
// deep; the flow at a stage of the step mixes the stage's pair linearly in time
// (cavesim/core/fields/snapshot_time.py).
#pragma once
#include "arithmetic.glsl"

uniform sampler3D flow_field;
uniform vec3 field_box_min;
uniform vec3 field_index_scale;  // (resolution - 1) / (box_max - box_min)
#if FIELD_TIME_SERIES
uniform int field_snapshots;
uniform ivec3 field_pair;  // per stage: the first snapshot of the pair it lies between
uniform vec3 field_weight;  // per stage: the weight of the pair's second snapshot
#endif

#if FIELD_INTERPOLATION != INTERPOLATION_TRILINEAR
// Smooth interpolation (cavesim/core/fields/interpolation.py): 4 texels per axis, 64 in all, with
// cubic weights of the fraction t. They are integer polynomials: the texels carry the cubic's
// 1/2 (Catmull-Rom) or 1/6 (B-spline) per axis, so every constant here is exact.
// w1 = (3t - A) t^2 + B and w2 = w1(1 - t).
#if FIELD_INTERPOLATION == INTERPOLATION_BSPLINE
#define CUBIC_A 6.0
#define CUBIC_B 4.0
#else
#define CUBIC_A 5.0
#define CUBIC_B 2.0
#endif

vec4 cubic_weights(float t) {
    float s = f_sub(1.0, t);
    float t2 = f_mul(t, t);
    float s2 = f_mul(s, s);
    float w1 = f_add(f_mul(f_sub(f_mul(3.0, t), CUBIC_A), t2), CUBIC_B);
    float w2 = f_add(f_mul(f_sub(f_mul(3.0, s), CUBIC_A), s2), CUBIC_B);
#if FIELD_INTERPOLATION == INTERPOLATION_BSPLINE
    return vec4(f_mul(s2, s), w1, w2, f_mul(t2, t));  // Sigg & Hadwiger (GPU Gems 2, ch. 20) x 6
#else
    return vec4(-f_mul(t, s2), w1, w2, -f_mul(s, t2));  // Keys (1981), a = -1/2, x 2
#endif
}

// The 4 x 4 x 4 texels from i0, weighted along x, then y, then z, each sum from 0 in tap
// order; texel i0 holds node i0 - 1 (one ghost texel beyond each end of every axis).
// Loops, not written-out sums: RK4 inlines the flow four times, and in portable arithmetic
// llvmpipe took about 100 s to compile the written-out form (the loops: about 3 s).
vec3 cubic_flow(ivec3 i0, vec3 t) {
    vec4 wx = cubic_weights(t.x);
    vec4 wy = cubic_weights(t.y);
    vec4 wz = cubic_weights(t.z);
    vec3 flow = vec3(0.0);
    for (int c = 0; c < 4; ++c) {
        vec3 plane = vec3(0.0);
        for (int b = 0; b < 4; ++b) {
            vec3 row = vec3(0.0);
            for (int a = 0; a < 4; ++a) {
                vec3 texel = texelFetch(flow_field, i0 + ivec3(a, b, c), 0).xyz;
                row = f_add(row, f_mul(wx[a], texel));
            }
            plane = f_add(plane, f_mul(wy[b], row));
        }
        flow = f_add(flow, f_mul(wz[c], plane));
    }
    return flow;
}
#endif

// Texels per axis of one snapshot
ivec3 snapshot_size() {
    ivec3 size = textureSize(flow_field, 0);
#if FIELD_TIME_SERIES
    return ivec3(size.xy, size.z / field_snapshots);
#else
    return size;
#endif
}

// Grid nodes per axis
ivec3 field_resolution() {
#if FIELD_INTERPOLATION == INTERPOLATION_TRILINEAR
    return snapshot_size();
#else
    return snapshot_size() - 2;  // the texels less the ghosts
#endif
}

// Whether grid coordinates f lie outside the field's closed box [0, res - 1] on an axis
// (NaN does not)
bool outside_field(vec3 f) {
    return any(lessThan(f, vec3(0.0))) || any(greaterThan(f, vec3(field_resolution() - 1)));
}

// The grid coordinates of p: node (i, j, k) at (i, j, k)
vec3 field_coordinates(vec3 p) {
    return f_mul(f_sub(p, field_box_min), field_index_scale);
}

// The flow of one snapshot: its texels start a snapshot's depth times `snapshot` deep
vec3 snapshot_flow(vec3 p, int snapshot) {
    ivec3 size = textureSize(flow_field, 0);
    ivec3 res = field_resolution();
    ivec3 first = ivec3(0, 0, snapshot_size().z * snapshot);
    vec3 last = vec3(res - 1);
    vec3 f = field_coordinates(p);
#if FIELD_OUT_OF_DOMAIN == OUT_OF_DOMAIN_ZERO
    if (outside_field(f)) {
        return vec3(0.0);
    }
#endif
    f = clamp(f, vec3(0.0), last);
#if FIELD_SAMPLING == SAMPLING_HARDWARE
    return texture(flow_field, (f + vec3(first) + 0.5) / vec3(size)).xyz;
#else
    ivec3 cell = min(ivec3(floor(f)), res - 2);
    vec3 t = f_sub(f, vec3(cell));
    ivec3 i0 = cell + first;
#if FIELD_INTERPOLATION != INTERPOLATION_TRILINEAR
    return cubic_flow(i0, t);
#else
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
#endif
}

#if FIELD_TIME_SERIES
// The flow at p between snapshot `pair` and the next, `weight` of the way to it
vec3 series_flow(vec3 p, int pair, float weight) {
    vec3 ends[2];
    for (int k = 0; k < 2; ++k) {  // one call site: RK4 inlines flow_at four times
        ends[k] = snapshot_flow(p, pair + k);
    }
    return f_mix(ends[0], ends[1], weight);
}
#endif

// The flow at p at a stage of the step (STAGE_START, STAGE_MIDDLE, STAGE_END)
vec3 flow_at(vec3 p, int stage) {
#if FIELD_TIME_SERIES
    return series_flow(p, field_pair[stage], field_weight[stage]);
#else
    return snapshot_flow(p, 0);
#endif
}

// The flow at p at `fraction` of the step, for an adaptive tracer's substeps, which stop
// between the stages. In a series the place pair + weight runs linearly in time from stage
// to stage (START to MIDDLE, MIDDLE to END): exact unless that half of the step crosses a
// snapshot between two intervals of unequal length (cavesim/core/fields/snapshot_time.py: places_in_step).
vec3 flow_in_step(vec3 p, float fraction) {
#if FIELD_TIME_SERIES
    int a = fraction <= 0.5 ? STAGE_START : STAGE_MIDDLE;
    float local = f_sub(f_mul(2.0, fraction), float(a));  // 0 to 1 through the half
    float span = f_add(float(field_pair[a + 1] - field_pair[a]),
                       f_sub(field_weight[a + 1], field_weight[a]));
    float place = f_add(field_weight[a], f_mul(local, span));
    float whole = floor(place);
    int pair = field_pair[a] + int(whole);
    float weight = f_sub(place, whole);
    if (pair > field_snapshots - 2) {
        pair = field_snapshots - 2;
        weight = 1.0;
    }
    return series_flow(p, pair, weight);
#else
    return snapshot_flow(p, 0);
#endif
}
