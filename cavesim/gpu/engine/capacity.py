"""How many particles a GL context can hold, and which limit decides it.

A particle system is bounded three ways; the smallest bound binds:
- GL_MAX_SHADER_STORAGE_BLOCK_SIZE: the checksum binds a whole particle buffer as one
  storage block (llvmpipe allows 128 MiB, an H100 2 GiB);
- GL_MAX_COMPUTE_WORK_GROUP_COUNT (x): the checksum sums a buffer in one dispatch of
  WORDS_PER_GROUP words per work group;
- the engine's own addressing bound, `limits.MAX_PARTICLES` (GL-free: the scene's cap).
GL has no query for the largest buffer: memory the driver cannot give shows as
GL_OUT_OF_MEMORY after allocating (`allocation_error`). Every bound is read from the
context (`ctx.info`), never assumed from the machine this was written on.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from cavesim.core.digest.shape import WORDS_PER_GROUP
from cavesim.core.errors import CapacityError, FieldError
from cavesim.core.features.feature import Texture
from cavesim.core.limits import MAX_BYTE_OFFSET, MAX_PARTICLES
from cavesim.core.records import PARTICLE_BYTES, PARTICLE_WORDS

PARTICLE_BUFFERS = 2  # front and back: a frame reads one stream and writes the other


@dataclass(frozen=True)
class Bound:
    """One limit on the capacity: its name and value as the driver reports them."""

    name: str
    value: int
    unit: str
    why: str  # what in the engine it limits
    capacity: int  # the largest capacity it allows


@dataclass(frozen=True)
class CapacityLimits:
    """The bounds of one context, and the driver they come from."""

    bounds: tuple[Bound, ...]
    driver: str  # GL_RENDERER, GL_VERSION

    @property
    def binding(self) -> Bound:
        """The bound that allows the fewest particles (the first of equals: the driver's)."""
        return min(self.bounds, key=lambda bound: bound.capacity)

    @property
    def max_capacity(self) -> int:
        return self.binding.capacity

    def check(self, capacity: int) -> None:
        """Raise CapacityError unless `capacity` particles fit every bound."""
        bound = self.binding
        if capacity > bound.capacity:
            raise CapacityError(
                f"capacity {capacity} needs {capacity * PARTICLE_BYTES} bytes per particle "
                f"buffer, more than {bound.name} = {bound.value} {bound.unit} allows "
                f"({bound.why}): at most {bound.capacity} particles on {self.driver}")

    def allocation_error(self, capacity: int, error: str) -> CapacityError:
        """The error for a GL error (GL_OUT_OF_MEMORY) after allocating the particle buffers."""
        return CapacityError(
            f"capacity {capacity} needs {PARTICLE_BUFFERS} particle buffers of "
            f"{capacity * PARTICLE_BYTES} bytes; allocating them gave {error} on {self.driver}")


def capacity_limits(info: Mapping[str, object]) -> CapacityLimits:
    """The capacity bounds of a context from its `ctx.info`."""
    block_bytes = int(info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"])
    groups = int(info["GL_MAX_COMPUTE_WORK_GROUP_COUNT"][0])
    return CapacityLimits((
        Bound("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", block_bytes, "bytes",
              "the checksum binds a particle buffer whole as one storage block",
              block_bytes // PARTICLE_BYTES),
        Bound("GL_MAX_COMPUTE_WORK_GROUP_COUNT[0]", groups, "work groups",
              f"the checksum sums a buffer in one dispatch of {WORDS_PER_GROUP} words per group",
              groups * WORDS_PER_GROUP // PARTICLE_WORDS),
        Bound("the engine's addressing bound", MAX_BYTE_OFFSET, "bytes",
              "moderngl passes transform feedback's byte offset as a C int", MAX_PARTICLES),
    ), f"{info['GL_RENDERER']}, OpenGL {info['GL_VERSION']}")


def check_texture(info: Mapping[str, object], texture: Texture) -> None:
    """FieldError unless a feature's texture fits the context's largest texture on every
    axis (GL_MAX_TEXTURE_SIZE for a 2D one, GL_MAX_3D_TEXTURE_SIZE for a 3D one)."""
    limit = "GL_MAX_3D_TEXTURE_SIZE" if len(texture.size) == 3 else "GL_MAX_TEXTURE_SIZE"
    largest = int(info[limit])
    if max(texture.size) > largest:
        size = " x ".join(map(str, texture.size))
        raise FieldError(f"{texture.what or texture.name} would be {size} texels, beyond "
                         f"{limit} = {largest} on {info['GL_RENDERER']}; use fewer "
                         f"{texture.fewer}")
