// A wall's finished picture into (a viewport of) its window: one triangle covering the
// viewport, the picture sampled as it is (nearest texel when the sizes match, so the
// window shows the headless PNG's pixels).

#if defined VERTEX_SHADER
out vec2 uv;

void main() {
    vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    uv = corner;
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#if defined FRAGMENT_SHADER
uniform sampler2D picture;
in vec2 uv;
out vec4 color;

void main() {
    color = vec4(texture(picture, uv).rgb, 1.0);
}
#endif
