"""How many particles of each class leave the field's box in a frame, counted on the GPU.

The particle pass (physics.glsl's step_particle, COUNT_DOMAIN_EXITS) adds one to its class's
uint in a storage buffer when a particle's step takes it from inside the field's closed box
to outside it (a runaway is dropped, not counted). The buffer is cleared before each frame
and read after the frame's wait, so the read costs a copy, not a stall.

Only a gridded field has a box. The compute path always counts. The GS/TF path steps in its
vertex stage, which GL 4.3 need not let write storage: it counts where the context offers
GL_MAX_VERTEX_SHADER_STORAGE_BLOCKS >= 1, read from the context (a recorded profile
without the value counts as offering none).
"""

from __future__ import annotations

from collections.abc import Mapping

import moderngl
import numpy as np

from cavesim.core.scene.model import Engine, Scene

DOMAIN_EXITS = 6  # the storage-buffer binding physics.glsl declares


def counts_exits(scene: Scene, engine: Engine, info: Mapping[str, object]) -> bool:
    """Whether the scene's particle pass on `engine` counts exits in a context with `info`."""
    if not scene.gridded_flow:
        return False
    return engine is Engine.COMPUTE or int(info.get("GL_MAX_VERTEX_SHADER_STORAGE_BLOCKS")
                                           or 0) >= 1


class DomainExits:
    """The per-class counts of one frame: `start_frame` before its particle pass, `read`
    after its wait."""

    def __init__(self, buffer: moderngl.Buffer) -> None:
        """Over `buffer`: a uint per particle class (its owner releases it)."""
        self.buffer = buffer
        self._zeros = bytes(buffer.size)

    def start_frame(self) -> None:
        """Zero the counts and bind them where the particle pass adds to them."""
        self.buffer.write(self._zeros)
        self.buffer.bind_to_storage_buffer(DOMAIN_EXITS)

    def read(self) -> tuple[int, ...]:
        """Each class's exits in the last frame."""
        return tuple(np.frombuffer(self.buffer.read(), dtype=np.uint32).tolist())
