// The optical depth between a point and the sun, from the light map (render/light_map.glsl):
// a deep opacity map (Yuksel and Keyser 2008) seen along the sun's rays. Per texel it holds
// the depth where the dust begins and the dust's optical depth in four layers behind it,
// LAYER_ENDS thick in units of `layer_depth`; a point's optical depth toward the sun is the
// sum of the layers before it and the share of its own that lies in front of it. The map
// is fixed in the world, so every wall looks up the same value for the same point.
#pragma once

uniform mat4 light_from_world;  // x, y: the map's clip space; z: metres along the rays
uniform sampler2D light_nearest;  // where the dust begins along each texel's ray, metres
uniform sampler2D light_layers;  // the optical depth in each of the four layers
uniform float layer_depth;  // metres: the unit of LAYER_ENDS

const vec4 LAYER_ENDS = vec4(1.0, 3.0, 7.0, 15.0);  // the last layer holds all behind 7 too

float texel_optical_depth(ivec2 texel, float depth) {
    float z = (depth - texelFetch(light_nearest, texel, 0).r) / layer_depth;
    vec4 layers = texelFetch(light_layers, texel, 0);
    vec4 starts = vec4(0.0, LAYER_ENDS.xyz);
    vec4 inside = clamp((z - starts) / (LAYER_ENDS - starts), 0.0, 1.0);
    return dot(layers, inside);
}

// tau toward the sun at `world`, bilinear between the four nearest texels' own lookups
float sun_optical_depth(vec3 world) {
    vec3 light = (light_from_world * vec4(world, 1.0)).xyz;
    vec2 size = vec2(textureSize(light_layers, 0));
    vec2 at = (light.xy * 0.5 + 0.5) * size - 0.5;
    ivec2 base = ivec2(floor(at));
    vec2 f = at - vec2(base);
    ivec2 top = ivec2(size) - 1;
    float tau = 0.0;
    for (int i = 0; i < 4; ++i) {
        ivec2 corner = ivec2(i & 1, i >> 1);
        vec2 w = mix(1.0 - f, f, vec2(corner));
        tau += w.x * w.y * texel_optical_depth(clamp(base + corner, ivec2(0), top), light.z);
    }
    return tau;
}
