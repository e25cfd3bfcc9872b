// Compute path, pass 2 of 4: where every output record lands, in the order transform
// feedback writes them. One work group scans the entries
//   [survivors of block 0 .. block_count - 1 | new particles of segment 0 .. segment_count - 1]
// (segment s = batch s / E of emitter s % E: emit.glsl's (batch, emitter, n) order) into
// their exclusive prefix sums. Each invocation sums a contiguous run of entries, one
// invocation scans those run totals, then each writes its run's prefixes: integer sums in
// a fixed order, two barriers, no atomics. Sums saturate at the capacity: a record at or
// past it is dropped (as transform feedback drops what does not fit), so the total is the
// live count, min(survivors + generated, capacity); the same sums unsaturated give the
// dropped count, survivors + generated - live.
#include "/include/streams.glsl"

#if defined COMPUTE_SHADER
layout(local_size_x = SCAN_SIZE) in;
uniform uint block_count;
uniform uint segment_count;  // batches x emitters
uniform uint emitter_count;
uniform uint capacity;

shared uint run_totals[SCAN_SIZE];
shared uint run_wanted[SCAN_SIZE];  // each run's entries summed without the capacity

uint entry(uint i) {
    if (i < block_count) {
        return uint(bitCount(alive_masks[i]));
    }
    uint s = i - block_count;
    uint count = emitter_states[s % emitter_count].z;
    uint first = (s / emitter_count) * uint(EMIT_BATCH);
    return count > first ? min(count - first, uint(EMIT_BATCH)) : 0u;
}

void main() {
    uint t = gl_LocalInvocationID.x;
    uint entries = block_count + segment_count;
    uint per_run = (entries + uint(SCAN_SIZE) - 1u) / uint(SCAN_SIZE);
    uint begin = min(t * per_run, entries);
    uint end = min(begin + per_run, entries);
    uint sum = 0u;
    uint wanted = 0u;
    for (uint i = begin; i < end; ++i) {
        uint n = entry(i);
        sum = min(sum + n, capacity);
        wanted += n;
    }
    run_totals[t] = sum;
    run_wanted[t] = wanted;
    barrier();
    if (t == 0u) {
        uint total = 0u;
        uint all_wanted = 0u;
        for (uint r = 0u; r < uint(SCAN_SIZE); ++r) {
            uint run = run_totals[r];
            run_totals[r] = total;
            total = min(total + run, capacity);
            all_wanted += run_wanted[r];
        }
        live_count = total;
        dropped = all_wanted - total;
    }
    barrier();
    uint at = run_totals[t];
    for (uint i = begin; i < end; ++i) {
        offsets[i] = at;
        at = min(at + entry(i), capacity);
    }
}
#endif
