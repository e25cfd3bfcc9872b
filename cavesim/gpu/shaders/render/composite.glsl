// Composite pass: one full-screen triangle lights the dust, puts it over the scene and
// tone maps the sum. The dust target holds per pixel the optical depth tau along the ray
// and the tau-weighted mean and mean square of the dust's distance from the eye. Taking
// the dust on the ray as one medium of a mean source (exact for a uniform one; order-free,
// as the sums are):
//   L = T L_scene + (1 - T) albedo (E_sun sum_i 2^-i p_i T_sun^(2^-i) + E_sky T_sky),
//   T = exp(-tau)
// (Beer-Lambert for the background, scattering in: single, i = 0, and multiple, in
// octaves i > 0, below), with p_i the phase function relative to isotropic scattering at
// the angle between the sunlight and the ray to the eye: two Henyey-Greenstein lobes, a
// strong forward one (dust glows toward the sun) and a weaker backward one (its grains
// throw light back too, so dust with the sun behind the viewer is not dull), T_sun the
// transmittance toward the sun from the light map where
// the eye sees the dust, and T_sky the same for the skylight with a share of that optical
// depth. Where on the ray: the sums give the dust's mean distance and spread; taken as
// uniform over the segment of that mean and spread, light scattered at depth fraction x
// reaches the eye by exp(-tau x), so the seen dust lies at the mean fraction
// f = 1/tau - 1/(e^tau - 1) (1/2 when thin, the front skin when thick). The scene pass
// draws display values: they are taken as this same camera's picture, so the inverse of
// the tone curve turns them into radiance, and a pixel without dust keeps its scene colour
// bit for bit.

#if defined VERTEX_SHADER
out vec2 uv;

void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    uv = p;
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#if defined FRAGMENT_SHADER
#include "/include/sunlight.glsl"
in vec2 uv;
uniform sampler2D scene_color;
uniform sampler2D dust;
uniform mat4 world_from_clip;  // the wall's inverse projection and view
uniform vec3 eye;  // world metres
uniform vec3 light_toward;  // unit: toward the sun
uniform vec3 dust_albedo;
uniform float sun_radiance;  // E_sun: sunlit dust of albedo 1 scatters this radiance
uniform float sky_radiance;  // E_sky: skylit dust likewise
uniform float forward_scattering;  // g of the forward lobe, in [0, 1)
uniform float backward_scattering;  // g of the backward lobe, in (-1, 0]
uniform float backward_share;  // the backward lobe's weight, in [0, 1]
uniform float ambient_shadow;  // the share of the optical depth to the sun that dims E_sky
uniform float exposure;
uniform bool shadows;  // false: the dust is lit as if nothing stood between it and the sun
uniform bool multiple_scattering;  // false: single scattering only
out vec4 color;

// Light scattered more than once, in octaves of a half (Wrenninge et al. 2013, "Oz: the
// great and volumetric"): octave i of three has 2^-i of the energy, sees 2^-i of the
// optical depth toward the sun and scatters with 2^-i of the phase function's anisotropy.
const float WHITE = 254.5 / 255.0;  // the brightest display value the inverse maps back
const vec3 LUMA = vec3(0.2126, 0.7152, 0.0722);  // Rec. 709

// Reinhard's curve on the exposed radiance's luminance, x -> x / (1 + x), keeping its hue
vec3 tone_map(vec3 radiance) {
    vec3 x = exposure * radiance;
    float luma = dot(x, LUMA);
    return x / (1.0 + luma);
}

vec3 inverse_tone_map(vec3 display) {
    vec3 y = min(display, vec3(WHITE));
    return y / (1.0 - min(dot(y, LUMA), WHITE)) / exposure;
}

// Henyey-Greenstein, relative to isotropic scattering
float henyey_greenstein(float g, float cosine) {
    float d = 1.0 + g * g - 2.0 * g * cosine;
    return (1.0 - g * g) / (d * sqrt(d));
}

// the dust's two lobes, their anisotropy scaled by `anisotropy` (1 for single scattering)
float phase(float anisotropy, float cosine) {
    return mix(henyey_greenstein(anisotropy * forward_scattering, cosine),
               henyey_greenstein(anisotropy * backward_scattering, cosine), backward_share);
}

void main() {
    vec3 display = texture(scene_color, uv).rgb;
    vec4 d = texture(dust, uv);
    float tau = d.a;
    if (tau <= 0.0) {
        color = vec4(display, 1.0);  // the curve and its inverse would round it off
        return;
    }
    vec4 far = world_from_clip * vec4(uv * 2.0 - 1.0, 1.0, 1.0);
    vec3 ray = normalize(far.xyz / far.w - eye);
    float mean = d.r / tau;
    float extent = sqrt(12.0 * max(d.g / tau - mean * mean, 0.0));
    float start = max(mean - 0.5 * extent, 0.0);
    float seen = tau < 1e-3 ? 0.5 - tau / 12.0 : 1.0 / tau - 1.0 / (exp(tau) - 1.0);
    float tau_sun = shadows ? sun_optical_depth(eye + ray * (start + seen * extent)) : 0.0;
    float cosine = dot(ray, light_toward);
    float quarter = exp(-0.25 * tau_sun);  // octave 2's transmittance; octave 1's is its square
    float half_ = quarter * quarter;
    float sun = phase(1.0, cosine) * half_ * half_;
    if (multiple_scattering) {
        sun += 0.5 * phase(0.5, cosine) * half_ + 0.25 * phase(0.25, cosine) * quarter;
    }
    float sky = exp(-ambient_shadow * tau_sun);
    vec3 source = dust_albedo * (sun_radiance * sun + sky_radiance * sky);
    float transmittance = exp(-tau);
    vec3 scene = inverse_tone_map(display);
    color = vec4(tone_map(transmittance * scene + (1.0 - transmittance) * source), 1.0);
}
#endif
