// Flow velocity under the scene's helicopter (compiled in for [field] kind = "rotor"): the
// rotor downwash of cavesim/helicopter/rotor.py, evaluated per particle from this frame's
// hub and induced velocity (made once by the master, the same bits on every node).
#pragma once

uniform vec3 rotor_hub;
uniform float induced_velocity;
uniform float rotor_radius;
uniform float rotor_ground_z;

float dilution(float height) {
    float x = height / (2.5 * rotor_radius);
    return exp(-x * x);
}

vec3 flow_at(vec3 p) {
    float R = rotor_radius;
    float vi = induced_velocity;
    if (vi <= 0.0) {
        return vec3(0.0);
    }
    vec2 d = p.xy - rotor_hub.xy;
    float r = length(d);
    float depth = rotor_hub.z - p.z;
    float w_axis = vi * (1.0 + depth / sqrt(depth * depth + R * R));
    float slip = R * sqrt(vi / max(w_axis, 1e-3 * vi));
    float q = (r / slip) * (r / slip);
    float edge = 1.0 / (1.0 + q * q * q * q);
    float zeta = max(p.z - rotor_ground_z, 0.0);
    float hub_height = max(rotor_hub.z - rotor_ground_z, 0.0);
    float turn = 1.0 - exp(-zeta / (0.3 * R));
    float thickness = 0.1 * R + 0.05 * max(r - R, 0.0);
    float profile = (zeta / thickness) * exp(1.0 - zeta / thickness);
    float w_ground = vi * (1.0 + hub_height / sqrt(hub_height * hub_height + R * R));
    float ramp = r < R ? r / R : pow(R / max(r, R), 1.1);
    float jet = w_ground * dilution(hub_height) * ramp;
    float u_r = jet * profile;
    // the wall jet separates and rolls up beyond 1.5 R: the rising ring of a brownout cloud
    float separation = clamp((r - 1.5 * R) / (1.5 * R), 0.0, 1.0);
    float rise = zeta / (0.8 * R);
    float upwash = 0.5 * jet * separation * rise * exp(1.0 - rise);
    vec2 radial = r > 0.0 ? d / r : vec2(0.0);
    float wake_dilution = depth > 0.0 ? sqrt(dilution(depth)) : 1.0;
    return vec3(radial * u_r, upwash - w_axis * edge * turn * wake_dilution);
}
