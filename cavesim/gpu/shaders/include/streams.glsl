// The compute path's storage buffers, each at its own binding (cavesim/gpu/engine/compute.py
// binds them by these numbers), and record access in them. A frame reads the front stream,
// updated in place, and writes the back stream in the order transform feedback would:
// the survivors in input order, then the new particles in (batch, emitter, n) order.
#pragma once
#include "record.glsl"

// Particles per block: one invocation of the particle pass owns a block, and one uint of
// alive_masks holds its survivors (bit k: particle 32 b + k lives on).
const uint BLOCK = 32u;

// A 40-byte record is five 8-byte pairs of words: 8-byte aligned at any index, and half the
// loads and stores of single words (llvmpipe runs each as a per-lane access).
layout(std430, binding = 0) buffer FrontStream {
    uvec2 front_stream[];
};
layout(std430, binding = 1) buffer BackStream {
    uvec2 back_stream[];
};
layout(std430, binding = 2) buffer AliveMasks {
    uint alive_masks[];
};
// The exclusive prefix sums, saturated at the capacity, of [survivors of each block,
// particles of each emission segment]: where each block's survivors and each segment's new
// particles land in the back stream.
layout(std430, binding = 3) buffer Offsets {
    uint offsets[];
};
// The emitter stream after this frame's emitter update (count in .z, first serial in .w)
layout(std430, binding = 4) buffer EmitterStates {
    uvec4 emitter_states[];
};
// What the host reads back: the live count after the frame, and the new particles that
// did not fit the capacity (cavesim/gpu/engine/drops.py)
layout(std430, binding = 5) buffer FrameCounts {
    uint live_count;
    uint dropped;
};

Particle load_front(uint i) {
    uint o = i * 5u;
    return unpack_particle(uvec4(front_stream[o], front_stream[o + 1u]),
                           uvec4(front_stream[o + 2u], front_stream[o + 3u]),
                           front_stream[o + 4u]);
}

void store_front(uint i, Particle q) {
    uvec4 a;
    uvec4 b;
    uvec2 c;
    pack_particle(q, a, b, c);
    uint o = i * 5u;
    front_stream[o] = a.xy;
    front_stream[o + 1u] = a.zw;
    front_stream[o + 2u] = b.xy;
    front_stream[o + 3u] = b.zw;
    front_stream[o + 4u] = c;
}

void store_back(uint i, Particle q) {
    uvec4 a;
    uvec4 b;
    uvec2 c;
    pack_particle(q, a, b, c);
    uint o = i * 5u;
    back_stream[o] = a.xy;
    back_stream[o + 1u] = a.zw;
    back_stream[o + 2u] = b.xy;
    back_stream[o + 3u] = b.zw;
    back_stream[o + 4u] = c;
}

// The record's bits as they are: a survivor moves without being unpacked
void copy_front_to_back(uint from, uint to) {
    uint o = from * 5u;
    uint p = to * 5u;
    for (uint k = 0u; k < 5u; ++k) {
        back_stream[p + k] = front_stream[o + k];
    }
}
