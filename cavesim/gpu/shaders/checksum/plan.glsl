// Checksum, for live counts only the GPU knows: the work-group counts of the sums and fold
// passes, as glDispatchComputeIndirect reads them (x, y, z per dispatch; see checksum.py).
#include "/include/digest.glsl"

#if defined COMPUTE_SHADER
layout(local_size_x = 1) in;
layout(std430, binding = 1) writeonly buffer Dispatches {
    uint dispatches[];
};

void set_groups(uint dispatch, uint groups) {
    dispatches[3u * dispatch] = groups;
    dispatches[3u * dispatch + 1u] = 1u;
    dispatches[3u * dispatch + 2u] = 1u;
}

void main() {
    set_groups(0u, stream_groups(0u) + stream_groups(1u));
    set_groups(1u, ceil_div(level_items(1u), uint(WORKGROUP_SIZE)));
    set_groups(2u, ceil_div(level_items(2u), uint(WORKGROUP_SIZE)));
}
#endif
