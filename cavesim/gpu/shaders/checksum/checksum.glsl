// Checksum of a buffer's live words, on the GPU: each invocation sums, over its words, two
// bijective mixes of (word XOR its index); the host hashes the small array of these sums.
// A change of any single word changes both sums of its invocation (a bijection of the
// word, added mod 2^32), and the index makes order count. Integer sums do not depend on
// evaluation order, so the result is the same on every GPU. No shared-memory reduction:
// llvmpipe runs barrier() as per-invocation coroutines, four times slower than this.

#if defined COMPUTE_SHADER
layout(local_size_x = WORKGROUP_SIZE) in;
layout(std430, binding = 0) readonly buffer Words {
    uint words[];
};
layout(std430, binding = 1) writeonly buffer Partials {
    uvec2 partials[];
};
uniform uint word_count;

// MurmurHash3's finalizer: a bijection of 32-bit words with full avalanche
uint fmix32(uint h) {
    h ^= h >> 16;
    h *= 0x85ebca6bu;
    h ^= h >> 13;
    h *= 0xc2b2ae35u;
    h ^= h >> 16;
    return h;
}

void main() {
    const uint group_size = uint(WORKGROUP_SIZE);
    uint first = gl_WorkGroupID.x * group_size * uint(WORDS_PER_THREAD)
               + gl_LocalInvocationID.x;
    uvec2 s = uvec2(0u);
    for (uint k = 0u; k < uint(WORDS_PER_THREAD); ++k) {
        uint i = first + k * group_size;  // adjacent invocations read adjacent words
        if (i < word_count) {
            uint h = words[i] ^ (i * 0x9e3779b9u);
            s += uvec2(fmix32(h), fmix32(h + 0x7f4a7c15u));
        }
    }
    partials[gl_GlobalInvocationID.x] = s;
}
#endif
