"""The counts both engine paths leave on the GPU in a small storage buffer each frame: the
live count at LIVE, and the new particles that did not fit the capacity at DROPPED
(survivors + emitted - live).

GS/TF's splice (shaders/particles/splice.glsl) takes them from its primitives queries; the
compute path's scan (scan.glsl) sums the same entries once saturated at the capacity and once
not. The checksum copies the live count from here on the GPU; the counter buffer copies the
drops (its `capacity_drops` row, `counter_buffer.py`).
"""

LIVE, DROPPED = 0, 4  # byte offsets of the counts in a path's frame counts buffer
