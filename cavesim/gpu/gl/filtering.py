"""The precision of this context's hardware texture filtering, measured, not assumed.

Hashed state samples fields by hand (texelFetch and float32 arithmetic, the same on every
GPU); hardware trilinear filtering is an opt-in (`sampling = "hardware"`) whose weights
vendors quantize differently: llvmpipe filters with float weights, NVIDIA with 8 bits.
Tests and reports bound its error with the figure measured here.
"""

from __future__ import annotations

import moderngl
import numpy as np

from cavesim.gpu.shader_source import ProgramSpec

FILTER_PROBE = ProgramSpec("probes/filter_weights.glsl", ("compute",))
SAMPLES = 4096  # points between two texel centres: finer than any vendor's weight steps
_LOCAL_SIZE = 64


def filter_weight_error(ctx: moderngl.Context) -> float:
    """The largest error of a linear filter weight on `ctx` (0 for exact weights)."""
    program = FILTER_PROBE.build(ctx, {})
    ramp = ctx.texture3d((2, 1, 1), 1, np.array([0.0, 1.0], dtype="f4").tobytes(), dtype="f4")
    ramp.filter = (moderngl.LINEAR, moderngl.LINEAR)
    ramp.repeat_x = ramp.repeat_y = ramp.repeat_z = False
    out = ctx.buffer(reserve=SAMPLES * 4)
    try:
        ramp.use(0)
        program["ramp"].value = 0
        program["sample_count"].value = SAMPLES
        out.bind_to_storage_buffer(0)
        program.run(-(-SAMPLES // _LOCAL_SIZE))
        filtered = np.frombuffer(out.read(), dtype="f4").astype(np.float64)
    finally:
        for resource in (out, ramp, program):
            resource.release()
    return float(np.abs(filtered - np.arange(SAMPLES) / SAMPLES).max())
