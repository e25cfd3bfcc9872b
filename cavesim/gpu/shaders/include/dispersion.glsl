// Turbulent dispersion: what a particle sees besides the flow over one step, a random walk
// drawn from the shared random texture, so every node draws the same numbers. The model
// and its sources: cavesim/core/twin/dispersion.py (float64 twin); portable twin:
// cavesim/core/portable/dispersion.py. Included by physics.glsl where HAS_DISPERSION.
//   K = l sigma, sigma = max(l |du/dz|, 0.1 |u|), l = kappa z / (1 + kappa z / l_inf)
//   K_p = K lambda / (lambda + sigma / l)                     (the particle's share)
//   seen: (dK_p/dz) z^ + sqrt(2 K_p / h) xi
#pragma once
#include "arithmetic.glsl"
#include "random.glsl"

uniform float mixing_length;  // l_inf, m: the largest eddies
uniform vec3 draw_mean;  // the draws' mean over the whole random texture
uniform vec3 draw_scale;  // 1 / their standard deviation over it

// exact float32 bits (a literal's rounding is up to the compiler;
// cavesim/core/portable/constants.py)
#define KARMAN uintBitsToFloat(0x3ECCCCCDu)  // 0.4
#define SHEAR_STEP uintBitsToFloat(0x3DCCCCCDu)  // 0.1 m
#define HALF_SHEAR_STEP uintBitsToFloat(0x3D4CCCCDu)  // 0.05 m
#define SQRT_3 uintBitsToFloat(0x3FDDB3D7u)
#define TURBULENCE_FLOOR uintBitsToFloat(0x3DCCCCCDu)  // 0.1: sigma >= this |u|
const float INVERSE_SHEAR_STEP = 10.0;

// xi of the particle at `index` in the stream: word index & 3 of lattice texel index >> 2
// (base 0) in this frame's map, three 10-bit fields j, sqrt(3) ((2j + 1)/1024 - 1)
// (all exact but the last product), standardised over the texture: uniform, zero mean,
// unit variance (cavesim/core/twin/dispersion.py says why).
vec3 dispersion_draws(uint index) {
    uint word = random_texel(uvec2(0u), index >> 2u)[index & 3u];
    uvec3 fields = (uvec3(word) >> uvec3(0u, 10u, 20u)) & uvec3(1023u);
    vec3 odd = vec3(2u * fields + 1u);
    vec3 raw = f_mul(f_sub(f_mul(odd, vec3(0.0009765625)), vec3(1.0)), vec3(SQRT_3));
    return f_mul(f_sub(raw, draw_mean), draw_scale);
}

// l at height z above the ground
float mixing_length_at(float z) {
    float grown = f_mul(KARMAN, max(z, 0.0));
    return f_div(grown, f_add(1.0, f_div(grown, mixing_length)));
}

// K_p at height z from the flow at the two ends of a SHEAR_STEP: l sigma lambda l /
// (lambda l + sigma), which is K lambda / (lambda + sigma / l) without dividing by l = 0
float particle_diffusivity(vec3 lower, vec3 upper, float z, float rate) {
    float shear = f_mul(f_length(f_sub(upper, lower)), INVERSE_SHEAR_STEP);
    float speed = f_length(f_mul(0.5, f_add(lower, upper)));
    float l = mixing_length_at(z);
    float sigma = max(f_mul(l, shear), f_mul(TURBULENCE_FLOOR, speed));
    float relaxed = f_mul(rate, l);
    float denominator = f_add(relaxed, sigma);
    if (!(denominator > 0.0)) {
        return 0.0;  // still air at the ground
    }
    return f_div(f_mul(f_mul(l, sigma), relaxed), denominator);
}

// What the particle at p with velocity v (class drag: inv_tau_p) sees besides u(p) over a
// step h: drift plus random velocity; nothing in a step of no time.
vec3 turbulence_seen(vec3 p, vec3 v, float inv_tau_p, uint index, float h) {
    vec3 lift = vec3(0.0, 0.0, SHEAR_STEP);
    vec3 below = flow_at(f_sub(p, lift), STAGE_START);
    vec3 here = flow_at(p, STAGE_START);
    vec3 above = flow_at(f_add(p, lift), STAGE_START);
    float rate = drag_rate(f_sub(here, v), inv_tau_p);
    float ground;
    vec3 normal;
    ground_at(p.xy, ground, normal);
    float height = f_sub(p.z, ground);
    float low = particle_diffusivity(below, here, f_sub(height, HALF_SHEAR_STEP), rate);
    float high = particle_diffusivity(here, above, f_add(height, HALF_SHEAR_STEP), rate);
    if (!(h > 0.0)) {
        return vec3(0.0);
    }
    float diffusivity = f_mul(0.5, f_add(low, high));
    float gradient = f_mul(f_sub(high, low), INVERSE_SHEAR_STEP);
    vec3 seen = f_mul(f_sqrt(f_div(f_mul(2.0, diffusivity), h)), dispersion_draws(index));
    seen.z = f_add(seen.z, gradient);
    return seen;
}
