// Checksum, fold pass: invocation j absorbs items [FOLD·j, FOLD·j + FOLD) of its level, in
// order, into one 128-bit state (`absorb` is injective in each item and in the state, so the
// output changes with any one item and order counts). Sequential per invocation, no barrier.
#include "/include/digest.glsl"
// LEVEL (a define): 1 folds the sums, 2 folds level 1's output.

#if defined COMPUTE_SHADER
layout(local_size_x = WORKGROUP_SIZE) in;
layout(std430, binding = 0) readonly buffer Items {
    uint items[];  // level 1: the sums pass's uvec2s; level 2: level 1's uvec4s
};
layout(std430, binding = 1) writeonly buffer Folded {
    uvec4 folded[];
};

void main() {
    uint j = gl_GlobalInvocationID.x;
    uint count = level_items(uint(LEVEL) - 1u);
    if (j >= ceil_div(count, uint(FOLD))) {
        return;
    }
    uint last = min(j * uint(FOLD) + uint(FOLD), count);
    uvec4 s = uvec4(uint(LEVEL), j, 0x510e527fu, 0x9b05688cu);
    for (uint i = j * uint(FOLD); i < last; ++i) {
#if LEVEL == 1
        uint o = 2u * i;
        s = absorb(s, uvec4(items[o], items[o + 1u], 0u, 0u));
#else
        uint o = 4u * i;
        s = absorb(s, uvec4(items[o], items[o + 1u], items[o + 2u], items[o + 3u]));
#endif
    }
    folded[j] = s;
}
#endif
