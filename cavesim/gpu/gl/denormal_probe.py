"""Whether draws and compute dispatches treat denormal floats alike on a context.

The engine's two paths are byte-identical only if they do (`cavesim.gpu.gl.denormals`
says why they may not, and what the engine does about it on llvmpipe). The compute path
checks it when it is built; a mismatch is logged, since a cluster whose walls all use one
path stays consistent, but a mixed one would part.
"""

from __future__ import annotations

import moderngl
import numpy as np

from cavesim.gpu.gl.denormals import flushing_denormals
from cavesim.gpu.shader_source import ProgramSpec

DENORMAL_PROBE_DRAW = ProgramSpec("probes/denormals.glsl", ("vertex",), (), ("flushed",))
DENORMAL_PROBE_DISPATCH = ProgramSpec("probes/denormals.glsl", ("compute",))
PROBE_VALUES = 4096  # enough work groups to reach every compute worker thread
_LOCAL_SIZE = 64  # as shaders/probes/denormals.glsl declares


def probe(ctx: moderngl.Context) -> bool:
    """Whether a draw (transform feedback) and a compute dispatch, run as the engine runs
    them, give the same bits for products and sums that land among the denormals."""
    inputs = _probe_inputs()
    draw = DENORMAL_PROBE_DRAW.build(ctx, {})
    dispatch = DENORMAL_PROBE_DISPATCH.build(ctx, {})
    source = ctx.buffer(inputs.tobytes())
    drawn = ctx.buffer(reserve=inputs.nbytes)
    dispatched = ctx.buffer(reserve=inputs.nbytes)
    vao = ctx.vertex_array(draw, [(source, "1u", "in_bits")])
    try:
        vao.transform(drawn, moderngl.POINTS, vertices=PROBE_VALUES)
        source.bind_to_storage_buffer(0)
        dispatched.bind_to_storage_buffer(1)
        dispatch["value_count"].value = PROBE_VALUES
        with flushing_denormals():
            dispatch.run(PROBE_VALUES // _LOCAL_SIZE)
        ctx.memory_barrier()
        return drawn.read() == dispatched.read()
    finally:
        for resource in (vao, source, drawn, dispatched, draw, dispatch):
            resource.release()


def _probe_inputs() -> np.ndarray:
    """Float bits from the smallest normals down into the denormals, as uint32."""
    exponents = np.linspace(-120.0, -150.0, PROBE_VALUES)
    return (np.float32(1.5) * np.exp2(exponents)).astype(np.float32).view(np.uint32)
