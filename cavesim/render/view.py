"""What a wall needs to draw a frame besides the particles: head pose and helicopter pose.

Both travel in the frame message, so every wall draws one world from one head.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

HELICOPTER_PARAMS = 5  # frame parameters 0..4: x, y, z, yaw (rad), rotor angle (rad)
ROTOR_HUB = (0.0, 0.0, 1.3)  # in the helicopter's frame


@dataclass(frozen=True)
class HelicopterPose:
    position: tuple[float, float, float]
    yaw: float  # radians, nose direction from +x toward +y
    rotor_angle: float  # radians

    @classmethod
    def from_params(cls, params: tuple[float, ...]) -> HelicopterPose | None:
        """The pose in a frame's scene parameters, or None when the frame carries none."""
        if len(params) < HELICOPTER_PARAMS:
            return None
        x, y, z, yaw, rotor = params[:HELICOPTER_PARAMS]
        return cls((x, y, z), yaw, rotor)

    def to_params(self) -> tuple[float, ...]:
        return (*self.position, self.yaw, self.rotor_angle)

    def model(self) -> np.ndarray:
        """4x4 world-from-helicopter matrix."""
        return translation(self.position) @ rotation_z(self.yaw)

    def rotor_model(self) -> np.ndarray:
        return self.model() @ translation(ROTOR_HUB) @ rotation_z(self.rotor_angle)


def translation(offset) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = offset
    return m


def rotation_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    m = np.eye(4)
    m[:2, :2] = [[c, -s], [s, c]]
    return m

