// Compute path, pass 4 of 4: the updated emitters' new particles, after the survivors in
// the back stream, each exactly where emit.glsl's transform feedback would put it. A work
// group is one segment, batch b of emitter e (segment b E + e), an invocation its particle
// n: serial state.w + b EMIT_BATCH + n, for n < min(count - b EMIT_BATCH, EMIT_BATCH).
// Records at or past the capacity are dropped, as transform feedback drops them.
#include "/include/streams.glsl"
#include "/include/spawn.glsl"

#if defined COMPUTE_SHADER
layout(local_size_x = EMIT_BATCH) in;
uniform uint first_segment;  // of this dispatch: a frame's segments may need several
uniform uint block_count;
uniform uint emitter_count;
uniform uint capacity;

void main() {
    uint s = first_segment + gl_WorkGroupID.x;
    uint n = gl_LocalInvocationID.x;
    int e = int(s % emitter_count);
    uvec4 state = emitter_states[e];
    uint index = (s / emitter_count) * uint(EMIT_BATCH) + n;  // within the emitter's frame
    if (index >= state.z) {
        return;
    }
    uint at = offsets[block_count + s] + n;
    if (at >= capacity) {
        return;
    }
    store_back(at, spawn(e, state.w + index));
}
#endif
