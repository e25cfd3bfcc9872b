"""What the particle pass counts on the GPU in a frame: per class, the particles that leave
the field's box; and the substeps adaptive tracers take.

The particle pass (physics.glsl) adds to uints in a storage buffer: step_particle one to its
class's when a particle's step takes it from inside the field's closed box to outside it
(COUNT_DOMAIN_EXITS; a runaway is dropped, not counted), and an adaptive tracer's `trace`
one for itself, its substeps taken and retaken, and the most it took
(COUNT_TRACER_SUBSTEPS). Each buffer is cleared before each frame and read after the frame's
wait, so the read costs a copy, not a stall.

Only a gridded field has a box; only tracers stepped by TracerMethod.RK45 take substeps. The
compute path always counts. The GS/TF path steps in its vertex stage, which GL 4.3 need not
let write storage: it counts where the context offers GL_MAX_VERTEX_SHADER_STORAGE_BLOCKS >= 1,
read from the context (a recorded profile without the value counts as offering none).
"""

from __future__ import annotations

from collections.abc import Mapping

import moderngl
import numpy as np

from cavesim.core.scene.model import Engine, Scene
from cavesim.core.substeps import SubstepCounts

DOMAIN_EXITS = 6  # the storage-buffer bindings physics.glsl declares
TRACER_SUBSTEPS = 7


def stage_counts(engine: Engine, info: Mapping[str, object]) -> bool:
    """Whether the stage that steps the particles on `engine` may write storage."""
    return engine is Engine.COMPUTE or int(info.get("GL_MAX_VERTEX_SHADER_STORAGE_BLOCKS")
                                           or 0) >= 1


def counts_exits(scene: Scene, engine: Engine, info: Mapping[str, object]) -> bool:
    """Whether the scene's particle pass on `engine` counts exits in a context with `info`."""
    return scene.gridded_flow and stage_counts(engine, info)


def counts_tracer_substeps(scene: Scene, engine: Engine, info: Mapping[str, object]) -> bool:
    """Whether the scene's particle pass on `engine` counts its tracers' substeps."""
    return scene.tracers_take_substeps and stage_counts(engine, info)


class FrameCounts:
    """The uints of one frame: `start_frame` before its particle pass, `read` after its
    wait."""

    def __init__(self, buffer: moderngl.Buffer, binding: int) -> None:
        """Over `buffer`, bound at `binding` (its owner releases it)."""
        self.buffer = buffer
        self.binding = binding
        self._zeros = bytes(buffer.size)

    def start_frame(self) -> None:
        """Zero the counts and bind them where the particle pass adds to them."""
        self.buffer.write(self._zeros)
        self.buffer.bind_to_storage_buffer(self.binding)

    def read(self) -> tuple[int, ...]:
        """The counts of the last frame."""
        return tuple(np.frombuffer(self.buffer.read(), dtype=np.uint32).tolist())


def substep_counts(counts: FrameCounts) -> SubstepCounts:
    """The last frame's substeps from TracerSubsteps' uints."""
    return SubstepCounts(*counts.read())
