// Scene pass: terrain and helicopter, Lambert-lit, into the wall's scene color and depth.
// Positions are world metres (z up); view and projection are the wall's off-axis pair.

#if defined VERTEX_SHADER
in vec3 in_position;
in vec3 in_normal;
in vec3 in_color;
uniform mat4 model;
uniform mat4 view;
uniform mat4 projection;
out vec3 world_position;
out vec3 world_normal;
out vec3 base_color;

void main() {
    vec4 world = model * vec4(in_position, 1.0);
    world_position = world.xyz;
    world_normal = mat3(model) * in_normal;
    base_color = in_color;
    gl_Position = projection * view * world;
}
#endif

#if defined FRAGMENT_SHADER
in vec3 world_position;
in vec3 world_normal;
in vec3 base_color;
uniform vec3 sun_direction;  // unit, toward the sun
uniform float grid_strength;  // darkens 1 m grid lines: depth cues on the terrain
out vec4 color;

void main() {
    vec3 n = normalize(world_normal);
    float diffuse = max(dot(n, sun_direction), 0.0);
    vec2 cell = abs(fract(world_position.xy) - 0.5);
    float line = smoothstep(0.47, 0.5, max(cell.x, cell.y)) * grid_strength;
    vec3 lit = base_color * (0.35 + 0.65 * diffuse) * (1.0 - line);
    color = vec4(lit, 1.0);
}
#endif
