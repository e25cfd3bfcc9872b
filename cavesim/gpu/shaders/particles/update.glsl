// Particle pass (geometry shader + transform feedback): every live particle ages by dt and
// moves; the geometry shader streams out only those still alive, in input order
// (determinism rule 3), so the survivors land packed at the start of the other buffer.
// The arithmetic runs in the vertex stage, where llvmpipe vectorizes best.
#include "/include/record.glsl"
#include "/include/physics.glsl"

#if defined VERTEX_SHADER
in uvec4 in_a;
in uvec4 in_b;
in uvec2 in_c;
flat out uvec4 moved_a;
flat out uvec4 moved_b;
flat out uvec2 moved_c;
flat out uint alive;

void main() {
    Particle q = unpack_particle(in_a, in_b, in_c);
    alive = step_particle(q, dt, uint(gl_VertexID)) ? 1u : 0u;
    pack_particle(q, moved_a, moved_b, moved_c);
}
#endif

#if defined GEOMETRY_SHADER
layout(points) in;
layout(points, max_vertices = 1) out;
flat in uvec4 moved_a[];
flat in uvec4 moved_b[];
flat in uvec2 moved_c[];
flat in uint alive[];
flat out uvec4 out_a;
flat out uvec4 out_b;
flat out uvec2 out_c;

void main() {
    if (alive[0] == 0u) {
        return;
    }
    out_a = moved_a[0];
    out_b = moved_b[0];
    out_c = moved_c[0];
    EmitVertex();
    EndPrimitive();
}
#endif
