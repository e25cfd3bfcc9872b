// Dust pass of the deferred shading (Smith et al., after Francis), as a participating
// medium: every live particle becomes a billboard facing the eye, and its fragments add
// the optical depth tau of the particle's soft sphere along their ray (include/parcel.glsl)
// into a float target, with tau-weighted sums of the particle's distance from the eye and
// of its square: where along the ray the dust lies, which the composite lights from the
// light map. Additive blending: the same sums in any order, so no sorting. Soft edges: a
// fragment fades as it nears the scene surface behind it (soft particles).
#include "/include/record.glsl"
#include "/include/parcel.glsl"

#if defined VERTEX_SHADER
in uvec4 in_a;  // position (and vel.x)
in uvec2 in_age;  // the age's two words
in uvec2 in_c;  // lifetime, class; velocity is not needed to draw
uniform mat4 view;
out vec3 view_position;
out float radius;
out float optical_depth;

void main() {
    Particle q = unpack_particle(in_a, uvec4(0u, 0u, in_age), in_c);
    Parcel p = parcel(q.class_id, float(q.age), q.lifetime);
    view_position = (view * vec4(q.pos, 1.0)).xyz;
    radius = p.radius;
    optical_depth = p.optical_depth;
}
#endif

#if defined GEOMETRY_SHADER
layout(points) in;
layout(triangle_strip, max_vertices = 4) out;
in vec3 view_position[];
in float radius[];
in float optical_depth[];
uniform mat4 projection;
uniform float pixels_per_unit_slope;  // viewport height / (top - bottom) at depth 1
uniform float min_radius_pixels;
uniform float near_plane;  // metres: nearer to the eye, dust is not drawn
out vec3 across;  // view space: offset in the billboard's plane from its centre, in radii
out vec3 billboard_point;  // view space: where this fragment's ray meets the billboard
flat out float center_tau;  // tau through the centre, thinned where the billboard is grown
flat out float eye_distance;  // metres: the same on every wall

void main() {
    vec3 center = view_position[0];
    float distance = length(center);
    if (distance < near_plane || optical_depth[0] <= 0.0) {
        return;  // the eye is inside the particle: no wall draws it; or it has faded out
    }
    // A billboard smaller than a few pixels would fall between pixel centres and vanish:
    // draw it at the minimum size and thin it by the area ratio, keeping its optical depth.
    // `pixels` is r * (pixels per metre) * L / D, with L and D the eye's distances to the
    // wall point and to the particle on one ray: the narrowest radius of the billboard's
    // footprint on the wall, so walls of one pixel size grow a particle on their shared
    // edge alike.
    float pixels = radius[0] * pixels_per_unit_slope / max(-center.z, near_plane);
    float grow = max(min_radius_pixels / pixels, 1.0);
    // The billboard faces the eye itself, not the wall's view axis: every wall then sees
    // the same disc, whatever the wall's orientation. Its spin about the line of sight
    // does not show (a disc), so any perpendicular pair will do.
    vec3 toward = -center / distance;
    // Cull only discs wholly behind the eye: one whose centre is behind this wall's eye
    // plane may still reach onto this wall, as it does onto its neighbour.
    if (center.z - radius[0] * grow * length(toward.xy) > 0.0) {
        return;
    }
    vec3 right = normalize(cross(abs(toward.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0),
                                 toward));
    mat3 axes = mat3(right, cross(toward, right), toward);
    for (int i = 0; i < 4; ++i) {
        vec2 c = vec2(i & 1, i >> 1) * 2.0 - 1.0;
        across = axes * vec3(c, 0.0);
        billboard_point = center + across * radius[0] * grow;
        center_tau = optical_depth[0] / (grow * grow);
        eye_distance = distance;
        gl_Position = projection * vec4(billboard_point, 1.0);
        EmitVertex();
    }
    EndPrimitive();
}
#endif

#if defined FRAGMENT_SHADER
in vec3 across;
in vec3 billboard_point;
flat in float center_tau;
flat in float eye_distance;
uniform sampler2D scene_depth;  // the scene pass's, pixel for pixel
uniform float near_plane;  // the scene pass's near plane, and the dust's near sphere
uniform float far_plane;
uniform float soft_distance;  // metres over which a particle fades into the scene
out vec4 accumulated;  // r: tau * distance, g: tau * distance^2, a: tau

float linear_depth(float window_depth) {
    float ndc = window_depth * 2.0 - 1.0;
    return 2.0 * near_plane * far_plane / (far_plane + near_plane - ndc * (far_plane - near_plane));
}

void main() {
    float r2 = dot(across, across);
    // Dust near the eye is cut at a sphere, the same on every wall; a wall's near plane
    // would cut each ray at its own distance (the dust pass's near plane sits far closer).
    float distance = length(billboard_point);
    if (r2 > 1.0 || distance < near_plane) {
        discard;
    }
    // Depths along the wall's axis differ between walls for the same point: measure the gap
    // to the scene along the ray, which every wall shares.
    float depth = -billboard_point.z;
    float scene = linear_depth(texelFetch(scene_depth, ivec2(gl_FragCoord.xy), 0).r);
    float gap = (scene - depth) * distance / depth;
    float soft = clamp(gap / soft_distance, 0.0, 1.0);
    float tau = center_tau * chord_share(r2) * soft;
    accumulated = tau * vec4(eye_distance, eye_distance * eye_distance, 0.0, 1.0);
}
#endif
