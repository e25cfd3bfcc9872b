// Compute path, pass 3 of 4: each block's survivors move, in input order, from the front
// stream to their place in the back stream (scan.glsl's offsets): the survivors land packed
// at its start, as the GS/TF particle pass leaves them. Survivors never exceed the
// capacity, so every one fits.
#include "/include/streams.glsl"

#if defined COMPUTE_SHADER
layout(local_size_x = WORKGROUP_SIZE) in;
uniform uint block_count;

void main() {
    uint block = gl_GlobalInvocationID.x;
    if (block >= block_count) {
        return;
    }
    uint alive = alive_masks[block];
    uint at = offsets[block];
    uint first = block * BLOCK;
    while (alive != 0u) {
        uint k = uint(findLSB(alive));
        alive &= alive - 1u;
        copy_front_to_back(first + k, at);
        at += 1u;
    }
}
#endif
