"""Byte layouts of the two GPU streams, shared by the engine, the twin and snapshots.

Must match shaders/particles/record.glsl (particles) and emitters.glsl (emitters).
Also the engine's addressing bound on the capacity, which needs no GL (the scene loader's cap).
"""

import numpy as np

PARTICLE_DTYPE = np.dtype([
    ("pos", "<f4", (3,)),
    ("vel", "<f4", (3,)),
    ("age", "<f8"),
    ("lifetime", "<f4"),
    ("class_id", "<u4"),
])
PARTICLE_BYTES = PARTICLE_DTYPE.itemsize  # 40
PARTICLE_WORDS = PARTICLE_BYTES // 4
PARTICLE_VERTEX_FORMAT = "4u 4u 2u"  # as the three integer varyings of record.glsl
PARTICLE_VARYINGS = ("out_a", "out_b", "out_c")

EMITTER_DTYPE = np.dtype([
    ("accumulator", "<f8"),  # fractional emission carried to the next frame
    ("count", "<u4"),  # particles emitted this frame
    ("serial", "<u4"),  # emission serial of this frame's first particle
])
EMITTER_BYTES = EMITTER_DTYPE.itemsize  # 16
EMITTER_VERTEX_FORMAT = "4u"

assert PARTICLE_BYTES == 40 and EMITTER_BYTES == 16

# The engine's addressing bound, whatever a driver allows: moderngl 5.13 hands
# `transform(buffer_offset=)` to GL through a C int (parsed with "I", so a larger offset
# wraps without an error), and the emitter pass appends at survivors x PARTICLE_BYTES.
# Vertex counts (GLsizei) and the checksum's uint word index reach further.
MAX_BYTE_OFFSET = 2**31 - 1
MAX_CAPACITY = MAX_BYTE_OFFSET // PARTICLE_BYTES  # 53,687,091 particles
assert MAX_CAPACITY <= 2**31 - 1 and MAX_CAPACITY * PARTICLE_WORDS <= 2**32 - 1
