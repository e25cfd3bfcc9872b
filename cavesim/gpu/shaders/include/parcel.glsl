// A drawn particle: a parcel of grains seen as a soft sphere whose extinction falls from
// its centre as sigma(s) = sigma0 (1 - s^2), s the distance from the centre in radii. A ray
// at s = r from the centre then crosses the optical depth
//   tau(r) = integral of sigma along the chord = (4/3) sigma0 R (1 - r^2)^(3/2),
// smooth to zero at the rim, and the parcel's whole extinction (tau over its disc) is
// (8/15) pi sigma0 R^3. A parcel spreads with age as the turbulence mixes its grains
// outward, R^2 = R0^2 + 2 K age for an eddy diffusivity K (Taylor's puff), keeping that
// whole (sigma0 ~ 1 / R^3), and fades out over the end of its life instead of vanishing.
// Shared by the dust pass and the light map, so both see the same medium.
#pragma once

uniform float billboard_radius[CLASS_COUNT];  // metres, per particle class, when emitted
uniform float peak_extinction;  // sigma0 of a new parcel, per metre
uniform float eddy_diffusivity;  // K, m^2/s
uniform float max_radius;  // metres: the most a parcel spreads to
uniform float fade_time;  // seconds: a parcel's optical depth falls to 0 over these before it dies

struct Parcel {
    float radius;  // metres
    float optical_depth;  // tau(0): along the chord through the centre
};

Parcel parcel(uint class_id, float age, float lifetime) {
    float radius = billboard_radius[min(class_id, uint(CLASS_COUNT - 1))];
    float spread = sqrt(radius * radius + 2.0 * eddy_diffusivity * max(age, 0.0));
    float grow = max(min(spread, max_radius), radius) / radius;
    float fade = clamp((lifetime - age) / fade_time, 0.0, 1.0);
    Parcel p;
    p.radius = radius * grow;
    p.optical_depth = 4.0 / 3.0 * peak_extinction * radius * fade / (grow * grow);
    return p;
}

// tau(r) / tau(0) at r^2 = `r2` of the radius
float chord_share(float r2) {
    float c = max(1.0 - r2, 0.0);
    return c * sqrt(c);
}
