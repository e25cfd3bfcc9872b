// What every checksum pass shares: the live counts as the GPU holds them, the sizes of each
// reduction level derived from them, and the integer mixes (checksum.py proves the digest
// sensitive to every word with them; numpy has the same functions there).
// Needs the defines WORKGROUP_SIZE, WORDS_PER_THREAD, FOLD, PARTICLE_WORDS, EMITTER_WORDS.
#pragma once

// The live counts: written by the host (GS/TF, loads) or by a GPU pass (the compute path).
layout(std430, binding = 2) readonly buffer Counts {
    uint particle_count;
    uint emitter_count;
};

const uint WORDS_PER_GROUP = uint(WORKGROUP_SIZE) * uint(WORDS_PER_THREAD);

uint ceil_div(uint a, uint b) {
    return a / b + uint(a % b != 0u);
}

// Work groups of the sums pass over one stream (0: particles, 1: emitters).
uint stream_groups(uint stream) {
    uint words = stream == 0u ? particle_count * uint(PARTICLE_WORDS)
                              : emitter_count * uint(EMITTER_WORDS);
    return ceil_div(words, WORDS_PER_GROUP);
}

// Items entering fold level `level`: 0 the per-invocation sums, 1 and 2 the fold outputs.
uint level_items(uint level) {
    uint items = (stream_groups(0u) + stream_groups(1u)) * uint(WORKGROUP_SIZE);
    for (uint l = 0u; l < level; ++l) {
        items = ceil_div(items, uint(FOLD));
    }
    return items;
}

// MurmurHash3's finalizer: a bijection of 32-bit words with full avalanche
uint fmix32(uint h) {
    h ^= h >> 16;
    h *= 0x85ebca6bu;
    h ^= h >> 13;
    h *= 0xc2b2ae35u;
    h ^= h >> 16;
    return h;
}

// A bijection of 128-bit states: each step replaces one lane by a bijective function of
// itself for the other lanes fixed, so every step, and the whole, can be undone.
uvec4 permute(uvec4 s) {
    s.x = fmix32(s.x + s.w + 0x6a09e667u);
    s.y = fmix32(s.y + s.x + 0xbb67ae85u);
    s.z = fmix32(s.z + s.y + 0x3c6ef372u);
    s.w = fmix32(s.w + s.z + 0xa54ff53au);
    return s;
}

// One step of a fold: injective in `item` for `s` fixed and in `s` for `item` fixed.
uvec4 absorb(uvec4 s, uvec4 item) {
    return permute(s + item);
}
