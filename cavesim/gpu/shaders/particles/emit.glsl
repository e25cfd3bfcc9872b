// Emitter pass, part 2 (geometry shader + transform feedback): the updated emitters append
// their new particles after the survivors. Drawn with one instance per batch of EMIT_BATCH
// particles, so output order is (batch, emitter, particle): fixed on every node, and the
// order the compute path's append.glsl reproduces. Transform feedback drops whatever no
// longer fits the capacity, the same on every node.
#include "/include/spawn.glsl"

#if defined VERTEX_SHADER
in uvec4 in_state;
flat out uvec4 emitter_state;
flat out int emitter_index;
flat out int batch;

void main() {
    emitter_state = in_state;
    emitter_index = gl_VertexID;
    batch = gl_InstanceID;
}
#endif

#if defined GEOMETRY_SHADER
layout(points) in;
layout(points, max_vertices = EMIT_BATCH) out;
flat in uvec4 emitter_state[];
flat in int emitter_index[];
flat in int batch[];
flat out uvec4 out_a;
flat out uvec4 out_b;
flat out uvec2 out_c;

void main() {
    uint count = emitter_state[0].z;
    uint first = uint(batch[0]) * uint(EMIT_BATCH);
    if (first >= count) {
        return;
    }
    uint in_this_batch = min(count - first, uint(EMIT_BATCH));
    for (uint n = 0u; n < in_this_batch; ++n) {
        Particle q = spawn(emitter_index[0], emitter_state[0].w + first + n);
        pack_particle(q, out_a, out_b, out_c);
        EmitVertex();
        EndPrimitive();
    }
}
#endif
