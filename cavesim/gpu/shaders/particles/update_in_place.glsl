// The benchmark's bound: the particle pass's arithmetic as an in-place compute shader
// (no emission, no kill). Not part of a frame; it tells how close GS/TF gets to the ALUs.
#include "/include/record.glsl"
#include "/include/physics.glsl"

#if defined COMPUTE_SHADER
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer ParticleWords {
    uint words[];
};
uniform uint particle_count;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= particle_count) {
        return;
    }
    uint o = i * 10u;
    Particle q = unpack_particle(uvec4(words[o], words[o + 1u], words[o + 2u], words[o + 3u]),
                                 uvec4(words[o + 4u], words[o + 5u], words[o + 6u], words[o + 7u]),
                                 uvec2(words[o + 8u], words[o + 9u]));
    step_particle(q, dt);
    uvec4 a;
    uvec4 b;
    uvec2 c;
    pack_particle(q, a, b, c);
    words[o] = a.x; words[o + 1u] = a.y; words[o + 2u] = a.z; words[o + 3u] = a.w;
    words[o + 4u] = b.x; words[o + 5u] = b.y; words[o + 6u] = b.z; words[o + 7u] = b.w;
    words[o + 8u] = c.x; words[o + 9u] = c.y;
}
#endif
