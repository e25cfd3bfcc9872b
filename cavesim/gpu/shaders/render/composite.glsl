// Composite pass of the deferred shading: one full-screen triangle lights the accumulated
// dust (its density-weighted normals) and blends it over the scene by its opacity.

#if defined VERTEX_SHADER
out vec2 uv;

void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    uv = p;
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#if defined FRAGMENT_SHADER
in vec2 uv;
uniform sampler2D scene_color;
uniform sampler2D dust;
uniform vec3 light_in_view;  // unit, toward the sun, in the wall's view space
uniform vec3 dust_albedo;
uniform float dust_ambient;  // the share of the albedo lit away from the sun
uniform float opacity;  // optical depth per unit accumulated density
out vec4 color;

void main() {
    vec3 scene = texture(scene_color, uv).rgb;
    vec4 d = texture(dust, uv);
    float alpha = 1.0 - exp(-opacity * d.a);
    vec3 n = d.a > 0.0 ? normalize(d.rgb + vec3(0.0, 0.0, 1e-6)) : vec3(0.0, 0.0, 1.0);
    float light = dust_ambient + (1.0 - dust_ambient) * max(dot(n, light_in_view), 0.0);
    color = vec4(mix(scene, dust_albedo * light, alpha), 1.0);
}
#endif
