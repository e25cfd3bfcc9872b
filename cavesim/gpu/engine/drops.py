"""How many new particles a frame dropped because the capacity was full, counted on the GPU.

Both engine paths leave the frame's counts in a small storage buffer: the live count at
LIVE, what did not fit at DROPPED (survivors + emitted - live). GS/TF's splice
(shaders/particles/splice.glsl) takes them from its primitives queries; the compute path's
scan (scan.glsl) sums the same entries once saturated at the capacity and once not. The
host reads the count after the frame's wait, so the read costs a copy, not a stall.
"""

from __future__ import annotations

import moderngl
import numpy as np

LIVE, DROPPED = 0, 4  # byte offsets of the counts in a path's frame counts buffer


def read_dropped(counts: moderngl.Buffer) -> int:
    """The particles the last frame dropped at the capacity, from a frame counts buffer."""
    return int(np.frombuffer(counts.read(4, offset=DROPPED), "<u4")[0])
