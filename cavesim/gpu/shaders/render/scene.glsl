// Scene pass: terrain, helicopter and rotor disc, lit by the sun and fogged toward the sky,
// into the wall's scene colour and depth. Positions are world metres (z up); view and
// projection are the wall's off-axis pair. Everything drawn depends on world position and
// the eye only, so the walls of a CAVE agree.

#include "/include/atmosphere.glsl"

// SURFACE (injected) picks the shading, one program each: SURFACE_PAINTED, SURFACE_SAND
// or SURFACE_ROTOR, injected too (programs.py Surface)

#if defined VERTEX_SHADER
in vec3 in_position;
in vec3 in_normal;
in vec3 in_color;
uniform mat4 model;
uniform mat4 view;
uniform mat4 projection;
uniform vec3 eye;  // world m
uniform float fog_distance;  // m over which the fog takes 1 - 1/e of the colour
out vec3 world_position;
out vec3 world_normal;
out vec3 base_color;
// smooth over metres, so per vertex (each varying costs on software GL): the fog's share,
// and radians added to the sand ripples' phase, bending them over tens of metres
out vec2 fog_and_bend;

void main() {
    vec4 world = model * vec4(in_position, 1.0);
    world_position = world.xyz;
    world_normal = mat3(model) * in_normal;
    base_color = in_color;
    fog_and_bend = vec2(1.0 - exp(-length(world.xyz - eye) / fog_distance),
                        1.6 * sin(0.23 * world.x + 0.7 * sin(0.31 * world.y))
                        + 0.8 * sin(0.41 * world.y));
    gl_Position = projection * view * world;
}
#endif

#if defined FRAGMENT_SHADER
in vec3 world_position;
in vec3 world_normal;
in vec3 base_color;
in vec2 fog_and_bend;
uniform vec3 eye;  // world m
uniform mat4 model_from_world;  // the rotor disc's: its blades lie in the model's xy
uniform float grid_strength;  // darkens 1 m grid lines: depth cues on the terrain
uniform float rotor_radius;  // of the disc, in model units
uniform float blade_count;
out vec4 color;

// Sand: the vertex colour carries patches over metres (meshes.terrain); here wind ripples
// about 0.7 m apart, bent and with brighter sun-facing flanks, and the metre grid; both
// fade out where a pixel spans them.
float sand_shade(vec2 xy) {
    float phase = dot(xy, vec2(0.8, 0.6)) * 9.0 + fog_and_bend.y;
    float ripples = cos(phase) * clamp(1.4 - fwidth(phase), 0.0, 1.0);
    vec2 cell = abs(fract(xy) - 0.5);
    float grid = smoothstep(0.47, 0.5, max(cell.x, cell.y))
               * clamp(1.5 - 20.0 * max(fwidth(xy.x), fwidth(xy.y)), 0.0, 1.0);
    return (1.0 + 0.05 * ripples) * (1.0 - grid_strength * grid);
}

float blade_cover(vec2 p) {
    float r = length(p) / rotor_radius;
    float sector = fract(atan(p.y, p.x) * blade_count / 6.2831853);  // 0 on a blade
    // the blades turn toward +angle: a sharp leading edge, a long blurred trail
    float blade = max(exp(-24.0 * sector), exp(-5.0 * (1.0 - sector)));
    float root = smoothstep(0.08, 0.16, r);
    return r < 0.05 ? 1.0 : 0.07 + 0.55 * root * blade + 0.12 * smoothstep(0.94, 0.99, r);
}

void main() {
    vec3 n = normalize(world_normal);
    vec3 to_eye = normalize(eye - world_position);
    vec3 albedo = base_color;
    float alpha = 1.0;
#if SURFACE == SURFACE_SAND
    albedo *= sand_shade(world_position.xy);
#elif SURFACE == SURFACE_ROTOR
    alpha = blade_cover((model_from_world * vec4(world_position, 1.0)).xy);
    n = n * sign(dot(n, to_eye));  // the disc is lit on the side seen
#endif
    float diffuse = max(dot(n, sun_direction), 0.0);
    float ambient = 0.38 + 0.08 * n.z;  // more sky above than below
    vec3 lit = albedo * (ambient + 0.62 * diffuse);
#if SURFACE == SURFACE_PAINTED  // a glint of the sun on paint and glass
    float glint = max(dot(reflect(-to_eye, n), sun_direction), 0.0);
    glint *= glint;
    glint *= glint;
    lit += 0.25 * sun_color * glint * glint * glint;
#endif
    // toward the horizon's colour: the sky's just above the ground and below the sun's glow
    color = vec4(mix(lit, sky_horizon, fog_and_bend.x), alpha);
}
#endif
