// Compute path, pass 1 of 4: every live particle ages by dt and moves, in place in the front
// stream (the arithmetic of the GS/TF update.glsl: step_particle). Each invocation owns a
// block of BLOCK consecutive particles and writes which of them live on as one bit each;
// no invocation depends on another, and no barrier is needed (llvmpipe runs barrier()
// slowly). A particle that dies is not written back: nothing reads it again.
#include "/include/streams.glsl"
#include "/include/physics.glsl"

#if defined COMPUTE_SHADER
layout(local_size_x = WORKGROUP_SIZE) in;
uniform uint particle_count;

void main() {
    uint block = gl_GlobalInvocationID.x;
    uint first = block * BLOCK;
    if (first >= particle_count) {
        return;
    }
    uint n = min(particle_count - first, BLOCK);
    uint alive = 0u;
    for (uint k = 0u; k < n; ++k) {
        Particle q = load_front(first + k);
        if (step_particle(q, dt, first + k)) {
            store_front(first + k, q);
            alive |= 1u << k;
        }
    }
    alive_masks[block] = alive;
}
#endif
