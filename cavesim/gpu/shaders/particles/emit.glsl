// Emitter pass, part 2 (geometry shader + transform feedback): the updated emitters append
// their new particles after the survivors. Drawn with one instance per batch of EMIT_BATCH
// particles, so output order is (batch, emitter, particle): fixed on every node.
// Transform feedback drops whatever no longer fits the capacity, the same on every node.
#include "/include/record.glsl"
#include "/include/emitters.glsl"

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

const float TWO_PI = 6.283185307179586;

// A new particle: uniform in the emitter's box, direction uniform in its cone, speed and
// lifetime uniform in their ranges. Twin: cavesim/twin/emission.py spawn.
Particle spawn(int e, uint serial) {
    uvec4 r0 = random_lookup(e, serial, 0u);
    uvec4 r1 = random_lookup(e, serial, 1u);
    Particle q;
    q.pos = emitter_center(e) + (vec3(unit_float(r0.x), unit_float(r0.y), unit_float(r0.z))
                                 - 0.5) * emitter_extent(e);
    // versine form: sqrt(1 - cos^2) would cancel in float32 for narrow cones
    float versine = unit_float(r0.w) * emitter_versine_spread(e);
    float cos_theta = 1.0 - versine;
    float sin_theta = sqrt(max(0.0, versine * (2.0 - versine)));
    float phi = TWO_PI * unit_float(r1.x);
    vec3 direction = (sin_theta * cos(phi)) * emitter_tangent(e)
                   + (sin_theta * sin(phi)) * emitter_bitangent(e)
                   + cos_theta * emitter_axis(e);
    float speed = emitter_speed(e) + emitter_speed_spread(e) * (2.0 * unit_float(r1.y) - 1.0);
    q.vel = speed * direction;
    q.age = 0.0LF;
    vec2 life = emitter_lifetime(e);
    q.lifetime = life.x + (life.y - life.x) * unit_float(r1.z);
    q.class_id = emitter_class(e);
    return q;
}

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
