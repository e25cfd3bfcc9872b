// The sky along a world direction (unit, z up): a gradient from the horizon to the zenith
// with the sun's glow, and the sun's disc. The sky pass and the scene's distance fog share
// it, so fogged ground fades into the very colour the sky has at the horizon; it depends on
// the direction alone, so the walls of a CAVE meet without a seam.

uniform vec3 sky_horizon;
uniform vec3 sky_zenith;
uniform vec3 sun_direction;  // unit, toward the sun
uniform vec3 sun_color;
uniform float sun_cos_radius;  // cosine of the sun disc's angular radius

vec3 sky_color(vec3 direction) {
    float up = 1.0 - clamp(direction.z, 0.0, 1.0);
    vec3 sky = mix(sky_horizon, sky_zenith, 1.0 - up * up * up);
    float toward = max(dot(direction, sun_direction), 0.0);
    float toward8 = toward * toward * toward * toward;
    toward8 *= toward8;
    float toward64 = toward8 * toward8;
    toward64 *= toward64;
    return sky + sun_color * (0.10 * toward8 + 0.30 * toward64);
}

float sun_disc(vec3 direction) {
    float edge = 0.2 * (1.0 - sun_cos_radius);  // a soft rim a fifth of the radius wide
    return smoothstep(sun_cos_radius - edge, sun_cos_radius + edge,
                      dot(direction, sun_direction));
}
