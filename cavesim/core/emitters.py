"""The emitters' fixed parameters as float32 arrays: the bits both the GPU and the twin use.

Derived once from the scene on every node, so each node uploads the same table. On the GPU
the table is a texture (shaders/include/emitters.glsl), not uniform arrays: any GL 4.3
driver fetches thousands of emitters exactly, where uniform arrays outgrow the smallest
drivers' limits at a few dozen. Also the host's bound on a frame's emission, which sizes
the instanced emission draw.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cavesim.core.random_texture import emitter_bases
from cavesim.core.scene.model import Scene

# Rows of the emitter table texture, each four 32-bit words per emitter (float bits or
# uints); must match the accessors in shaders/include/emitters.glsl.
EMIT_BATCH = 64  # new particles per emitter per geometry-shader invocation: 64 x 10
# components fits GL's minimum of 1024; the order of emission is (batch, emitter, particle)
FIXED_ROWS = 6  # from the scene, written once
FRAME_ROWS = 2  # written every frame: emission origin and rate factor; this frame's cap
TABLE_ROWS = FIXED_ROWS + FRAME_ROWS


@dataclass(frozen=True)
class EmitterTable:
    rate: np.ndarray  # (E,) float32, particles per second
    position: np.ndarray  # (E, 3) float32
    extent: np.ndarray  # (E, 3) float32
    axis: np.ndarray  # (E, 3) float32 unit mean direction
    tangent: np.ndarray  # (E, 3) float32, orthonormal to axis
    bitangent: np.ndarray  # (E, 3) float32, axis x tangent
    versine_spread: np.ndarray  # (E,) float32, 1 - cos(half-angle), without cancellation
    speed: np.ndarray  # (E,) float32
    speed_spread: np.ndarray  # (E,) float32
    lifetime: np.ndarray  # (E, 2) float32
    class_id: np.ndarray  # (E,) uint32
    random_base: np.ndarray  # (E, 2) uint32 base texel in the random texture

    @classmethod
    def from_scene(cls, scene: Scene) -> EmitterTable:
        emitters = scene.emitters
        axis = np.array([e.direction for e in emitters], dtype=np.float64).reshape(-1, 3)
        tangent, bitangent = _orthonormal_pair(axis)

        def f32(values: list, width: int | None = None) -> np.ndarray:
            shape = (len(emitters),) if width is None else (len(emitters), width)
            return np.array(values, dtype=np.float32).reshape(shape)

        return cls(
            rate=f32([e.rate for e in emitters]),
            position=f32([e.position for e in emitters], 3),
            extent=f32([e.extent for e in emitters], 3),
            axis=axis.astype(np.float32),
            tangent=tangent.astype(np.float32),
            bitangent=bitangent.astype(np.float32),
            versine_spread=f32([2 * math.sin(math.radians(e.spread_angle) / 2) ** 2
                                for e in emitters]),
            speed=f32([e.speed for e in emitters]),
            speed_spread=f32([e.speed_spread for e in emitters]),
            lifetime=f32([e.lifetime for e in emitters], 2),
            class_id=np.array([e.particle_class for e in emitters], dtype=np.uint32),
            random_base=emitter_bases(scene.seed, len(emitters),
                                      scene.random_texture_size).astype(np.uint32),
        )

    def __len__(self) -> int:
        return len(self.rate)

    def fixed_rows(self) -> np.ndarray:
        """The scene's rows of the table texture: (FIXED_ROWS, E, 4) uint32 words."""
        words = np.zeros((FIXED_ROWS, len(self), 4), dtype=np.uint32)
        for row, (vector, scalar) in enumerate((
                (self.position, self.rate), (self.extent, self.versine_spread),
                (self.axis, self.speed), (self.tangent, self.speed_spread))):
            words[row, :, :3] = vector.view(np.uint32)
            words[row, :, 3] = scalar.view(np.uint32)
        words[4, :, :3] = self.bitangent.view(np.uint32)
        words[4, :, 3] = self.class_id
        words[5, :, :2] = self.lifetime.view(np.uint32)
        words[5, :, 2:] = self.random_base
        return words

    def frame_rows(self, max_emit: np.ndarray, factors: np.ndarray | None = None,
                   origins: np.ndarray | None = None) -> np.ndarray:
        """This frame's rows of the table texture: (FRAME_ROWS, E, 4) uint32 words.

        Emitters that follow nothing have factor 1 and origin 0 (unused by their shader).
        """
        words = np.zeros((FRAME_ROWS, len(self), 4), dtype=np.uint32)
        if origins is not None:
            words[0, :, :3] = np.asarray(origins, np.float32).view(np.uint32)
        words[0, :, 3] = (np.ones(len(self), np.float32) if factors is None
                          else np.asarray(factors, np.float32)).view(np.uint32)
        words[1, :, 0] = max_emit
        return words

    def frame_rates(self, factors: np.ndarray | None = None) -> np.ndarray:
        """Per emitter, rate × this frame's factor in float64, in the GPU's order of ops."""
        rates = self.rate.astype(np.float64)
        return rates if factors is None else rates * np.asarray(factors, np.float32)

    def max_emit(self, dt: np.float32, capacity: int,
                 factors: np.ndarray | None = None) -> np.ndarray:
        """Per emitter, a bound on this frame's count, capped at the capacity (uint32).

        The accumulator is below 1 before the frame, so the count floor(acc + rate·dt) is at
        most floor(1 + rate·dt), computed here in the same float64 arithmetic as the GPU.
        """
        bound = np.floor(1.0 + self.frame_rates(factors) * np.float64(dt))
        return np.minimum(bound, capacity).astype(np.uint32)


def _orthonormal_pair(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing each (unit) axis to a right-handed frame."""
    helper = np.where(np.abs(axis[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    tangent = np.cross(axis, helper)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    return tangent, np.cross(axis, tangent)
