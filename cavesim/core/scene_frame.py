"""What a scene's time-varying state is in one frame, as one typed record.

The master's scene driver makes a `SceneFrame` once per frame; it travels as the frame
message's float32 parameters (each driver's `encode`/`decode`), so every node steps and
draws from the same bits (determinism rule 1): the engine reads `rotor` and `field_time`,
the renderer `helicopter`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cavesim.core.fields.snapshot_time import FieldTime

MESH_HUB_HEIGHT = 1.3  # m from the skids up to the rotor hub of the drawn model (meshes.py)
MESH_ROTOR_RADIUS = 5.0  # m, the drawn rotor's radius before scaling
TAIL_ROTOR_GEARING = 5.0  # tail rotor turns per main rotor turn: about 5 on utility helicopters


@dataclass(frozen=True)
class HelicopterPose:
    """Where the walls draw a helicopter: its skids' position, heading, rotor angle, and
    its size (the model is scaled to this hub height and rotor radius)."""

    position: tuple[float, float, float]  # world m, between the skids
    yaw: float  # radians, nose direction from +x toward +y
    rotor_angle: float  # radians
    hub_height: float = MESH_HUB_HEIGHT  # m above the skids
    rotor_radius: float = MESH_ROTOR_RADIUS  # m

    def model(self) -> np.ndarray:
        """4x4 world-from-model matrix of the body."""
        return (translation(self.position) @ rotation_z(self.yaw)
                @ scaling(self.hub_height / MESH_HUB_HEIGHT))

    def rotor_model(self) -> np.ndarray:
        """4x4 world-from-model matrix of the rotor disk, turned by the rotor angle."""
        return (translation(self.position) @ rotation_z(self.yaw)
                @ translation((0.0, 0.0, self.hub_height)) @ rotation_z(self.rotor_angle)
                @ scaling(self.rotor_radius / MESH_ROTOR_RADIUS))

    def tail_rotor_model(self, hub, radius: float) -> np.ndarray:
        """4x4 world-from-model matrix of the rotor disk as a tail rotor of the body: its hub
        and radius in the body's model frame, the disk standing in the model's xz plane and
        turned about y by TAIL_ROTOR_GEARING times the rotor angle."""
        return (self.model() @ translation(hub) @ rotation_x(-math.pi / 2)  # disk z to y
                @ rotation_z(TAIL_ROTOR_GEARING * self.rotor_angle)
                @ scaling(radius / MESH_ROTOR_RADIUS))


@dataclass(frozen=True)
class RotorFrame:
    """The rotor's downwash and the dust it raises this frame (helicopter scenes)."""

    hub: tuple[float, float, float]  # world m
    induced_velocity: float  # m/s at the disk
    rotor_speed: float  # fraction of hover speed
    emission_factors: tuple[float, ...]  # saltation, per following emitter in scene order


@dataclass(frozen=True)
class SceneFrame:
    helicopter: HelicopterPose | None = None  # what the walls draw
    rotor: RotorFrame | None = None  # what blows the dust (helicopter scenes)
    field_time: FieldTime | None = None  # where a time-series field stands this step


NOTHING_MOVES = SceneFrame()  # a frame of a scene whose state does not change over time


def translation(offset) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = offset
    return m


def rotation_x(angle: float) -> np.ndarray:
    return _rotation(angle, 1, 2)


def rotation_z(angle: float) -> np.ndarray:
    return _rotation(angle, 0, 1)


def _rotation(angle: float, a: int, b: int) -> np.ndarray:
    """4x4 turn by `angle` radians from axis `a` toward axis `b`."""
    c, s = math.cos(angle), math.sin(angle)
    m = np.eye(4)
    m[np.ix_((a, b), (a, b))] = [[c, -s], [s, c]]
    return m


def scaling(factor: float) -> np.ndarray:
    return np.diag([factor, factor, factor, 1.0])


def float32(values) -> tuple[float, ...]:
    """Values as the float32 bits the frame message carries (the master sends these)."""
    return tuple(np.asarray(values, dtype=np.float32).tolist())
