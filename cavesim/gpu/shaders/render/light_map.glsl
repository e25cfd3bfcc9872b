// The light map: the live particles splatted along the sun's rays (orthographic), each as
// a point sprite of its soft sphere (every sample_stride-th particle, standing for the
// ones it skips: light_map.py). With NEAREST_PASS, each texel keeps the depth where its
// first dust begins (blended by MIN); otherwise each fragment adds its optical depth into
// the layer behind that depth that holds the particle's centre (blended by addition). Both
// are sums or minima: the same map whatever the particles' order (include/sunlight.glsl).
#include "/include/record.glsl"
#include "/include/parcel.glsl"

#if defined VERTEX_SHADER
in uvec4 in_a;  // position (and vel.x)
in uvec2 in_age;  // the age's two words
in uvec2 in_c;  // lifetime, class
uniform mat4 light_from_world;  // x, y: the map's clip space; z: metres along the rays
uniform float texels_per_metre;
uniform float min_size_texels;
uniform float sample_stride;  // this particle stands for itself and the next stride - 1
out float center_depth;
out float radius;
out float optical_depth;  // through the centre, thinned where the sprite is grown

void main() {
    Particle q = unpack_particle(in_a, uvec4(0u, 0u, in_age), in_c);
    Parcel p = parcel(q.class_id, float(q.age), q.lifetime);
    float widen = pow(sample_stride, 1.0 / 3.0);
    p.radius *= widen;
    p.optical_depth *= sample_stride / (widen * widen);
    vec3 light = (light_from_world * vec4(q.pos, 1.0)).xyz;
    // Sprites narrower than a few texels fall between texel centres: draw them at the
    // minimum size, thinned by the area ratio, keeping their optical depth.
    float size = 2.0 * p.radius * texels_per_metre;
    float grow = max(min_size_texels / size, 1.0);
    gl_PointSize = size * grow;
    gl_Position = vec4(light.xy, 0.0, 1.0);
    center_depth = light.z;
    radius = p.radius;
    optical_depth = p.optical_depth / (grow * grow);
}
#endif

#if defined FRAGMENT_SHADER
in float center_depth;
in float radius;
in float optical_depth;
#include "/include/sunlight.glsl"
out vec4 accumulated;

void main() {
    vec2 across = gl_PointCoord * 2.0 - 1.0;
    float r2 = dot(across, across);
    if (r2 > 1.0) {
        discard;
    }
#if NEAREST_PASS
    accumulated = vec4(center_depth - radius * sqrt(1.0 - r2), 0.0, 0.0, 0.0);
#else
    float z = (center_depth - texelFetch(light_nearest, ivec2(gl_FragCoord.xy), 0).r)
              / layer_depth;
    vec4 starts = vec4(0.0, LAYER_ENDS.xyz);
    vec4 layer = step(starts, vec4(z)) * step(vec4(z), vec4(LAYER_ENDS.xyz, 1e30));
    layer.xyz *= 1.0 - layer.yzw;  // a centre on a boundary goes to the later layer
    accumulated = layer * optical_depth * chord_share(r2);
#endif
}
#endif
