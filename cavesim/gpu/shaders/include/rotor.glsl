// Flow velocity under the scene's helicopter (compiled in for [field] kind = "rotor"): the
// rotor downwash of cavesim/core/helicopter/downwash.py (its physics, sources and
// validation), evaluated per particle from this frame's hub and induced velocity (made once
// by the master, the same bits on every node). The flow of a Stokes stream function, so
// divergence-free and C1: with G = Phi / (pi r²) (Phi: the flux down through the disk of
// radius r), u_r = r dG/dz / 2 and u_z = -(G + r² dG/d(r²)), and G = v_i W E T, the wake,
// the wall jet's entrainment and its layer, each with its derivatives in z and r².
// Portable twin: cavesim/core/portable/rotor.py.
#pragma once
#include "arithmetic.glsl"

uniform vec3 rotor_hub;
uniform float induced_velocity;
uniform float rotor_radius;
uniform float rotor_ground_z;

// The model's constants that no short literal spells exactly, as their float32 bits (how a
// literal such as 0.138 rounds is up to the compiler; cavesim/core/portable/constants.py)
#define WAKE_SPREADING uintBitsToFloat(0x3E0D4FDFu)         // 0.138: the far wake's widening
#define WALL_JET_GROWTH uintBitsToFloat(0x3F0D4371u)        // r_e^0.8 = R sigma k / (this H^0.2)
#define WALL_JET_WIDTH_SQ uintBitsToFloat(0x3C1D5A18u)      // 0.098²: Poreh's half-width
#define FOUR_PROFILE_INTEGRAL uintBitsToFloat(0x408B93F0u)  // 4 F: the width on the axis
#define PROFILE_DECAY uintBitsToFloat(0x40066666u)          // 2.1: the profile's a
#define PROFILE_SHAPE uintBitsToFloat(0x40533333u)          // 3.3: its c
#define PROFILE_INNER uintBitsToFloat(0x4274CCCDu)          // 61.2 = b - a + c
#define PROFILE_FLUX uintBitsToFloat(0x3F986CE4u)           // its integral
#define ONE_FIFTH uintBitsToFloat(0x3E4CCCCDu)              // 0.2
#define TWO_FIFTHS uintBitsToFloat(0x3ECCCCCDu)             // 0.4
#define WIDTH_POWER uintBitsToFloat(0x3FE66666u)            // 1.8 = 2 x 0.9
#define HALF_WIDTH_POWER uintBitsToFloat(0x3EE66666u)       // 0.45 = 0.9 / 2
const float PROFILE_RISE = 60.0;  // the profile's b
const float GROWTH_POWER = 1.25;  // 1 / 0.8

// The frame's wall jet (downwash.wall_jet): the hub height, the jet's width on the axis,
// r_e² and (0.098 H^0.1)²
struct WallJet {
    float hub_height;
    float source_width;
    float growth_radius_sq;
    float width_coefficient_sq;
};

WallJet wall_jet(float R) {
    float h = max(f_sub(rotor_hub.z, rotor_ground_z), 0.0);
    float H = max(h, f_mul(0.5, R));
    float ratio = f_div(R, f_mul(4.0, H));
    float k = f_sub(1.0, f_mul(ratio, ratio));
    float growth = f_add(1.0, f_div(h, f_sqrt(f_add(f_mul(h, h), f_mul(R, R)))));
    float m = f_div(f_mul(f_mul(WAKE_SPREADING, h), growth), f_mul(2.0, R));
    float spread = f_sqrt(f_add(1.0, f_mul(m, m)));
    float source_width = f_div(f_mul(f_mul(f_mul(R, spread), f_sqrt(growth)), k),
                               FOUR_PROFILE_INTEGRAL);
    float H_fifth = f_pow(H, ONE_FIFTH);
    float growth_radius = f_pow(f_div(f_mul(f_mul(R, spread), k),
                                      f_mul(WALL_JET_GROWTH, H_fifth)), GROWTH_POWER);
    return WallJet(h, source_width, f_mul(growth_radius, growth_radius),
                   f_mul(WALL_JET_WIDTH_SQ, H_fifth));
}

// (W, dW/dz, dW/d(r²)): the slipstream, (g / sigma) (1 + x⁴)^-1/4, x = r² g / (R sigma)²
vec3 wake(float q, float z, float h, float R) {
    float depth = f_sub(h, z);
    float RR = f_mul(R, R);
    float s = f_sqrt(f_add(f_mul(depth, depth), RR));
    float g = f_add(1.0, f_div(depth, s));
    float g_d = f_div(RR, f_mul(f_mul(s, s), s));
    float two_R = f_mul(2.0, R);
    float m = f_div(f_mul(f_mul(WAKE_SPREADING, depth), g), two_R);
    float sigma = f_sqrt(f_add(1.0, f_mul(m, m)));
    float m_d = f_div(f_mul(WAKE_SPREADING, f_add(g, f_mul(depth, g_d))), two_R);
    float sigma_d = f_div(f_mul(m, m_d), sigma);
    float tube = f_mul(RR, f_mul(sigma, sigma));
    float c = f_div(g, tube);
    float c_d = f_div(f_sub(g_d, f_div(f_mul(f_mul(2.0, g), sigma_d), sigma)), tube);
    float x = f_mul(q, c);
    float x2 = f_mul(x, x);
    float tilde = f_div(1.0, f_sqrt(f_sqrt(f_add(1.0, f_mul(x2, x2)))));
    float tilde2 = f_mul(tilde, tilde);
    float tilde_x = -f_mul(f_mul(x2, x), f_mul(f_mul(tilde2, tilde2), tilde));
    float speed = f_div(g, sigma);
    float speed_d = f_div(f_sub(g_d, f_div(f_mul(g, sigma_d), sigma)), sigma);
    return vec3(f_mul(speed, tilde),
                -f_add(f_mul(speed_d, tilde), f_mul(f_mul(speed, tilde_x), f_mul(q, c_d))),
                f_mul(f_mul(speed, tilde_x), c));
}

// (E, dE/dz, dE/d(r²)): 1 + (E_g - 1) exp(-z² / (r² + R²)), E_g = (1 + (r² / r_e²)²)^0.2
vec3 entrainment(float q, float z, WallJet jet, float R) {
    float u = f_div(q, jet.growth_radius_sq);
    float grow = f_add(1.0, f_mul(u, u));
    float grown = f_pow(grow, ONE_FIFTH);
    float grown_q = f_div(f_mul(f_mul(TWO_FIFTHS, u), grown), f_mul(grow, jet.growth_radius_sq));
    float reach = f_add(q, f_mul(R, R));
    float fade = f_exp(-f_div(f_mul(z, z), reach));
    float extra = f_mul(f_sub(grown, 1.0), fade);
    return vec3(f_add(1.0, extra), -f_div(f_mul(f_mul(2.0, z), extra), reach),
                f_add(f_mul(grown_q, fade),
                      f_div(f_mul(extra, f_mul(z, z)), f_mul(reach, reach))));
}

// (delta, d delta / d(r²)): (delta_0⁴ + ((0.098 H^0.1)² (r² + R²/4)^0.9)²)^1/4
vec2 jet_width(float q, WallJet jet, float R) {
    float axis = f_add(q, f_mul(0.25, f_mul(R, R)));
    float coefficient = jet.width_coefficient_sq;
    float far4 = f_mul(f_mul(coefficient, coefficient), f_pow(axis, WIDTH_POWER));
    float source2 = f_mul(jet.source_width, jet.source_width);
    float width4 = f_add(f_mul(source2, source2), far4);
    float width = f_sqrt(f_sqrt(width4));
    return vec2(width, f_mul(f_div(f_mul(HALF_WIDTH_POWER, far4), f_mul(axis, width4)), width));
}

// (T, dT/deta): the flux fraction below eta of the profile
// f = (1 + c eta) e^(-a eta) - (1 + (b - a + c) eta) e^(-b eta)
vec2 jet_profile(float eta) {
    float ea = f_exp(-f_mul(PROFILE_DECAY, eta));
    float eb = f_exp(-f_mul(PROFILE_RISE, eta));
    float outer = f_add(f_div(f_sub(1.0, ea), PROFILE_DECAY),
                        f_div(f_mul(PROFILE_SHAPE, f_sub(1.0, f_mul(f_add(1.0, f_mul(PROFILE_DECAY, eta)), ea))),
                              f_mul(PROFILE_DECAY, PROFILE_DECAY)));
    float inner = f_add(f_div(f_sub(1.0, eb), PROFILE_RISE),
                        f_div(f_mul(PROFILE_INNER, f_sub(1.0, f_mul(f_add(1.0, f_mul(PROFILE_RISE, eta)), eb))),
                              f_mul(PROFILE_RISE, PROFILE_RISE)));
    float f = f_sub(f_mul(f_add(1.0, f_mul(PROFILE_SHAPE, eta)), ea),
                    f_mul(f_add(1.0, f_mul(PROFILE_INNER, eta)), eb));
    return vec2(f_div(f_sub(outer, inner), PROFILE_FLUX), f_div(f, PROFILE_FLUX));
}

// (T, dT/dz, dT/d(r²)): the wall jet's layer, T(z / delta(r²))
vec3 layer(float q, float z, WallJet jet, float R) {
    vec2 width = jet_width(q, jet, R);
    float eta = f_div(z, width.x);
    vec2 t = jet_profile(eta);
    return vec3(t.x, f_div(t.y, width.x), -f_div(f_mul(f_mul(t.y, eta), width.y), width.x));
}

// the same at every stage of a step: the rotor moves once a frame
vec3 flow_at(vec3 p, int stage) {
    float R = rotor_radius;
    float vi = induced_velocity;
    if (vi <= 0.0) {
        return vec3(0.0);
    }
    WallJet jet = wall_jet(R);
    vec2 offset = f_sub(p.xy, rotor_hub.xy);
    float q = f_dot(offset, offset);
    // below the ground the flow is the reflection of the flow above (Phi odd in z)
    float height = f_sub(p.z, rotor_ground_z);
    float z = abs(height);
    vec3 w = wake(q, z, jet.hub_height, R);
    vec3 e = entrainment(q, z, jet, R);
    vec3 t = layer(q, z, jet, R);
    float we = f_mul(w.x, e.x);
    float wt = f_mul(w.x, t.x);
    float et = f_mul(e.x, t.x);
    float G = f_mul(we, t.x);
    float G_z = f_add(f_add(f_mul(w.y, et), f_mul(e.y, wt)), f_mul(t.y, we));
    float G_q = f_add(f_add(f_mul(w.z, et), f_mul(e.z, wt)), f_mul(t.z, we));
    float up = f_mul(vi, f_add(G, f_mul(q, G_q)));
    return vec3(f_mul(offset, f_mul(0.5, f_mul(vi, G_z))), height < 0.0 ? up : -up);
}

// the same at every time of a step
vec3 flow_in_step(vec3 p, float fraction) {
    return flow_at(p, STAGE_START);
}
