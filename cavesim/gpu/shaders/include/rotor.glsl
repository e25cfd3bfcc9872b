// Flow velocity under the scene's helicopter (compiled in for [field] kind = "rotor"): the
// rotor downwash of cavesim/core/helicopter/rotor.py, evaluated per particle from this
// frame's hub and induced velocity (made once by the master, the same bits on every node).
// Portable twin: cavesim/core/portable/rotor.py.
#pragma once
#include "arithmetic.glsl"

uniform vec3 rotor_hub;
uniform float induced_velocity;
uniform float rotor_radius;
uniform float rotor_ground_z;

// The model's constants that no literal spells exactly, as their float32 bits (how a
// literal such as 0.3 rounds is up to the compiler; cavesim/core/portable/constants.py)
#define WAKE_FLOOR uintBitsToFloat(0x3A83126Fu)  // 1e-3: least w_axis, share of v_i
#define TURN_HEIGHT uintBitsToFloat(0x3E99999Au)  // 0.3 R: where the wake turns
#define JET_THICKNESS uintBitsToFloat(0x3DCCCCCDu)  // 0.1 R: the wall jet at the rim
#define JET_GROWTH uintBitsToFloat(0x3D4CCCCDu)  // 0.05: its thickening beyond
#define JET_DECAY uintBitsToFloat(0x3F8CCCCDu)  // 1.1: speed ~ (R/r)^1.1 beyond R
#define UPWASH_HEIGHT uintBitsToFloat(0x3F4CCCCDu)  // 0.8 R: the ring's peak

float dilution(float height) {
    float x = f_div(height, f_mul(2.5, rotor_radius));
    return f_exp(-f_mul(x, x));
}

// 1 + h / sqrt(h^2 + R^2): the wake's speed at depth h below the disk, in units of v_i
float wake_growth(float h, float R) {
    return f_add(1.0, f_div(h, f_sqrt(f_add(f_mul(h, h), f_mul(R, R)))));
}

vec3 flow_at(vec3 p) {
    float R = rotor_radius;
    float vi = induced_velocity;
    if (vi <= 0.0) {
        return vec3(0.0);
    }
    vec2 d = f_sub(p.xy, rotor_hub.xy);
    float r = f_length(d);
    float depth = f_sub(rotor_hub.z, p.z);
    float w_axis = f_mul(vi, wake_growth(depth, R));
    float slip = f_mul(R, f_sqrt(f_div(vi, max(w_axis, f_mul(WAKE_FLOOR, vi)))));
    float r_slip = f_div(r, slip);
    float q = f_mul(r_slip, r_slip);
    float edge = f_div(1.0, f_add(1.0, f_mul(f_mul(f_mul(q, q), q), q)));
    float zeta = max(f_sub(p.z, rotor_ground_z), 0.0);
    float hub_height = max(f_sub(rotor_hub.z, rotor_ground_z), 0.0);
    float turn = f_sub(1.0, f_exp(-f_div(zeta, f_mul(TURN_HEIGHT, R))));
    float thickness = f_add(f_mul(JET_THICKNESS, R), f_mul(JET_GROWTH, max(f_sub(r, R), 0.0)));
    float height_in_jet = f_div(zeta, thickness);
    float profile = f_mul(height_in_jet, f_exp(f_sub(1.0, height_in_jet)));
    float w_ground = f_mul(vi, wake_growth(hub_height, R));
    float ramp = r < R ? f_div(r, R) : f_pow(f_div(R, max(r, R)), JET_DECAY);
    float jet = f_mul(f_mul(w_ground, dilution(hub_height)), ramp);
    float u_r = f_mul(jet, profile);
    // the wall jet separates and rolls up beyond 1.5 R: the rising ring of a brownout cloud
    float separation = clamp(f_div(f_sub(r, f_mul(1.5, R)), f_mul(1.5, R)), 0.0, 1.0);
    float rise = f_div(zeta, f_mul(UPWASH_HEIGHT, R));
    float upwash = f_mul(f_mul(f_mul(f_mul(0.5, jet), separation), rise), f_exp(f_sub(1.0, rise)));
    vec2 radial = r > 0.0 ? f_div(d, r) : vec2(0.0);
    float wake_dilution = depth > 0.0 ? f_sqrt(dilution(depth)) : 1.0;
    float downdraft = f_mul(f_mul(f_mul(w_axis, edge), turn), wake_dilution);
    return vec3(f_mul(radial, u_r), f_sub(upwash, downdraft));
}
