// Checksum, first pass: each invocation sums, over its words of one stream, two bijective
// mixes of (word XOR its index). A change of any single word changes both sums of its
// invocation (a bijection of the word, added mod 2^32), and the index makes order count.
// Integer sums do not depend on evaluation order, so the result is the same on every GPU.
// No shared-memory reduction: llvmpipe runs barrier() as per-invocation coroutines, four
// times slower than this; fold.glsl reduces the sums.
#include "/include/digest.glsl"

#if defined COMPUTE_SHADER
layout(local_size_x = WORKGROUP_SIZE) in;
layout(std430, binding = 0) readonly buffer ParticleWords {
    uint particle_words[];
};
layout(std430, binding = 3) readonly buffer EmitterWords {
    uint emitter_words[];
};
layout(std430, binding = 1) writeonly buffer Partials {
    uvec2 partials[];
};

uvec2 mixes(uint word, uint i) {
    uint h = word ^ (i * 0x9e3779b9u);
    return uvec2(fmix32(h), fmix32(h + 0x7f4a7c15u));
}

void main() {
    const uint group_size = uint(WORKGROUP_SIZE);
    // one dispatch: the particle stream's groups, then the emitter stream's (one for up to
    // MAX_EMITTERS records), so a whole group reads one stream
    uint particle_groups = stream_groups(0u);
    bool emitters = gl_WorkGroupID.x >= particle_groups;
    uint group = gl_WorkGroupID.x - (emitters ? particle_groups : 0u);
    uint word_count = emitters ? emitter_count * uint(EMITTER_WORDS)
                               : particle_count * uint(PARTICLE_WORDS);
    uint first = group * WORDS_PER_GROUP + gl_LocalInvocationID.x;
    uint end = min(word_count, first + WORDS_PER_GROUP);
    uvec2 s = uvec2(0u);
    // adjacent invocations read adjacent words; a loop per stream, as a select of the two
    // loads in one loop costs llvmpipe a third more time
    if (emitters) {
        for (uint i = first; i < end; i += group_size) {
            s += mixes(emitter_words[i], i);
        }
    } else {
        for (uint i = first; i < end; i += group_size) {
            s += mixes(particle_words[i], i);
        }
    }
    partials[gl_GlobalInvocationID.x] = s;
}
#endif
