"""The helicopter's part of a frame's scene parameters: which float32 goes where.

The master fills them once per frame; every node reads the same bits (determinism rule 1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

POSE = 5  # x, y, z of the rotor hub, yaw, rotor angle (the renderer's HelicopterPose)
INDUCED_VELOCITY = 5
ROTOR_SPEED = 6
FIRST_FACTOR = 7  # then one emission factor per helicopter-following emitter


@dataclass(frozen=True)
class RotorFrame:
    hub: tuple[float, float, float]  # world m
    yaw: float  # rad
    rotor_angle: float  # rad
    induced_velocity: float  # m/s
    rotor_speed: float  # fraction of hover speed
    emission_factors: tuple[float, ...]  # per following emitter, in scene order

    def to_params(self) -> tuple[float, ...]:
        values = (*self.hub, self.yaw, self.rotor_angle, self.induced_velocity,
                  self.rotor_speed, *self.emission_factors)
        return tuple(np.asarray(values, dtype=np.float32).tolist())

    @classmethod
    def from_params(cls, params, followers: int) -> RotorFrame:
        if len(params) != FIRST_FACTOR + followers:
            raise ValueError(f"a helicopter frame has {FIRST_FACTOR + followers} parameters "
                             f"({followers} following emitters), got {len(params)}")
        p = tuple(params)
        return cls(p[0:3], p[3], p[4], p[INDUCED_VELOCITY], p[ROTOR_SPEED], p[FIRST_FACTOR:])
