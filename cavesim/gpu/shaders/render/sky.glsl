// Sky pass: one full-screen triangle at the far plane, drawn after the opaque scene where
// the depth is still clear, shaded per pixel from the world direction of its view ray.

#include "/include/atmosphere.glsl"

#if defined VERTEX_SHADER
uniform mat4 world_from_clip;  // inverse of the wall's projection * view
uniform vec3 eye;  // world m
out vec3 ray;  // toward the far plane: affine across the wall, so interpolated exactly

void main() {
    vec2 ndc = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2) * 2.0 - 1.0;
    vec4 far_point = world_from_clip * vec4(ndc, 1.0, 1.0);
    ray = far_point.xyz / far_point.w - eye;
    gl_Position = vec4(ndc, 1.0, 1.0);
}
#endif

#if defined FRAGMENT_SHADER
in vec3 ray;
out vec4 color;

void main() {
    vec3 direction = normalize(ray);
    color = vec4(mix(sky_color(direction), sun_color, sun_disc(direction)), 1.0);
}
#endif
