"""Byte layouts of the two GPU streams, shared by the engine, the twin and snapshots.

Must match shaders/include/record.glsl (particles) and emitters.glsl (emitters).
"""

import numpy as np

from cavesim.core.limits import MAX_BYTE_OFFSET, MAX_PARTICLE_CLASSES, MAX_PARTICLES

PARTICLE_DTYPE = np.dtype([
    ("pos", "<f4", (3,)),
    ("vel", "<f4", (3,)),
    ("age", "<f8"),
    ("lifetime", "<f4"),
    ("class_id", "u1"),  # below MAX_PARTICLE_CLASSES
    ("pos_low", "i1", (3,)),  # what pos leaves out, in 1/256 of its spacing (position.py)
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
EMITTER_WORDS = EMITTER_BYTES // 4
EMITTER_VERTEX_FORMAT = "4u"

assert PARTICLE_BYTES == 40 and EMITTER_BYTES == 16
assert MAX_PARTICLE_CLASSES <= 256  # a class is a byte
# cavesim.core.limits writes the engine's addressing bound with this record size
assert MAX_PARTICLES == MAX_BYTE_OFFSET // PARTICLE_BYTES
assert MAX_PARTICLES * PARTICLE_WORDS <= 2**32 - 1  # the checksum's uint word index
