"""The emitters' fixed parameters as float32 arrays: the bits both the GPU and the twin use.

Derived once from the scene on every node, so each node uploads the same uniforms. Also
the host's bound on a frame's emission, which sizes the instanced emission draw.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cavesim.random_texture import emitter_bases
from cavesim.scene.model import Scene


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
