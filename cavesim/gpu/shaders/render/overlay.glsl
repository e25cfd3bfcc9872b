// A line of text over a window's picture: a quad at `rect` (normalized device
// coordinates: left, bottom, right, top) whose texture holds the glyphs' coverage; the
// text is white on a half-dark band, blended over what the window already shows.

#if defined VERTEX_SHADER
uniform vec4 rect;
out vec2 uv;

void main() {
    vec2 corner = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1));  // a strip of 4
    uv = vec2(corner.x, 1.0 - corner.y);  // the texture's first row is the text's top
    gl_Position = vec4(mix(rect.xy, rect.zw, corner), 0.0, 1.0);
}
#endif

#if defined FRAGMENT_SHADER
uniform sampler2D glyphs;
in vec2 uv;
out vec4 color;

void main() {
    float ink = texture(glyphs, uv).r;
    color = vec4(vec3(ink), mix(0.6, 1.0, ink));
}
#endif
