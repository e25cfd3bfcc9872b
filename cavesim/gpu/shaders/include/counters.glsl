// The frame's counters (cavesim/core/counters.py): one storage buffer of uints, cleared
// before each frame's passes and read with the checksum's wait
// (cavesim/gpu/engine/counter_buffer.py). Each row the particle pass combines into has a
// switch, COUNT_<ROW>, and its first uint, <ROW>_AT (the first of one per particle class for
// a per-class row), both injected from the table, so counting code reads
//     #if COUNT_DOMAIN_EXITS
//         count_add(DOMAIN_EXITS_AT + int(class), 1u);
//     #endif
// COUNTING: any switch on. Only the stage that steps the particles counts: a GS/TF
// program's geometry stage only passes them on and declares no storage, so there the calls
// do nothing. Atomic adds and maxes: the values do not depend on the order of the particles.
#pragma once

#if COUNTING && !defined GEOMETRY_SHADER
layout(std430, binding = 6) buffer Counters {
    uint counters[];
};

void count_add(int at, uint n) {
    atomicAdd(counters[at], n);
}

void count_max(int at, uint n) {
    atomicMax(counters[at], n);
}
#else
void count_add(int at, uint n) {
}

void count_max(int at, uint n) {
}
#endif
