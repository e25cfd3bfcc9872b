// Checksum, last pass (one invocation): the digest of the seed, both live counts and level
// 2's folds, written with the counts it covers so that one 24-byte read returns them all.
#include "/include/digest.glsl"

#if defined COMPUTE_SHADER
layout(local_size_x = 1) in;
layout(std430, binding = 0) readonly buffer Items {
    uvec4 items[];
};
layout(std430, binding = 1) writeonly buffer Result {
    uvec4 digest;
    uint particles;
    uint emitters;
};
uniform uvec2 seed;  // the scene's 64-bit seed: low word, high word

void main() {
    uvec4 s = absorb(uvec4(0x1f83d9abu, 0x5be0cd19u, 0xcbbb9d5du, 0x629a292au),
                     uvec4(seed, particle_count, emitter_count));
    uint count = level_items(2u);
    for (uint i = 0u; i < count; ++i) {
        s = absorb(s, items[i]);
    }
    digest = permute(permute(s));
    particles = particle_count;
    emitters = emitter_count;
}
#endif
