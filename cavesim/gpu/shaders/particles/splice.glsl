// GS/TF path, after the emission: the new particles, streamed into a scratch buffer, move
// to their place after the survivors in the back stream. Both counts come from the passes'
// primitives queries, written into `FrameCounts` on the GPU (or by the host where the
// context has no query buffer objects): the host never needs them to place the emission.
// What no longer fits the capacity is dropped, as transform feedback drops it, so the back
// stream holds the bytes the emission would have streamed there itself; how many is counted.
#if defined COMPUTE_SHADER
layout(local_size_x = WORKGROUP_SIZE) in;
uniform uint capacity;

// A 40-byte record is five 8-byte pairs of words (streams.glsl)
layout(std430, binding = 0) readonly buffer EmittedStream {
    uvec2 emitted_stream[];
};
layout(std430, binding = 1) buffer BackStream {
    uvec2 back_stream[];
};
layout(std430, binding = 5) buffer FrameCounts {
    uint live_count;  // written here: what the host and the checksum read
    uint dropped;  // written here: the new records past the capacity (drops.py)
    uint survivors;  // the particle pass's records, at the start of the back stream
    uint generated;  // the emission's records, every one counted, kept or not
};

void main() {
    uint kept = min(generated, capacity - survivors);
    if (gl_GlobalInvocationID.x == 0u) {
        live_count = survivors + kept;
        dropped = generated - kept;
    }
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint i = gl_GlobalInvocationID.x; i < kept; i += stride) {
        uint from = i * 5u;
        uint to = (survivors + i) * 5u;
        for (uint k = 0u; k < 5u; ++k) {
            back_stream[to + k] = emitted_stream[from + k];
        }
    }
}
#endif
