// Checksum of a buffer's live words, on the GPU: each workgroup sums, over its words, two
// bijective mixes of (word XOR its index); the host hashes the small array of workgroup
// sums. A change of any single word changes both sums of its workgroup (a bijection of the
// word, added mod 2^32), and the index makes order count. Integer sums do not depend on
// the order of reduction, so the result is the same on every GPU.

#if defined COMPUTE_SHADER
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Words {
    uint words[];
};
layout(std430, binding = 1) writeonly buffer Partials {
    uvec2 partials[];
};
uniform uint word_count;
shared uvec2 sums[256];

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
    uint lane = gl_LocalInvocationID.x;
    uint first = gl_WorkGroupID.x * (256u * uint(WORDS_PER_THREAD));
    uvec2 s = uvec2(0u);
    for (uint k = 0u; k < uint(WORDS_PER_THREAD); ++k) {
        uint i = first + k * 256u + lane;  // adjacent lanes read adjacent words
        if (i < word_count) {
            uint h = words[i] ^ (i * 0x9e3779b9u);
            s += uvec2(fmix32(h), fmix32(h + 0x7f4a7c15u));
        }
    }
    sums[lane] = s;
    barrier();
    for (uint stride = 128u; stride > 0u; stride >>= 1) {
        if (lane < stride) {
            sums[lane] += sums[lane + stride];
        }
        barrier();
    }
    if (lane == 0u) {
        partials[gl_WorkGroupID.x] = sums[0];
    }
}
#endif
