"""A scene with nothing flying: a helicopter hovers ahead as scenery, its rotor turning.

Its pose is the whole frame (five parameters); the particles do not feel it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from cavesim.core.drivers.scene_driver import DriverStep
from cavesim.core.errors import ProtocolError
from cavesim.core.scene_frame import HelicopterPose, SceneFrame, float32
from cavesim.core.wire.payloads.poses import WandState

POSE_PARAMS = 5  # x, y, z, yaw, rotor angle


@dataclass(frozen=True)
class StillDriver:
    hover: tuple[float, float, float] = (0.0, 9.0, 6.0)  # skids, world m
    rotor_hz: float = 4.5  # main rotor turns per second

    def advance(self, t: float, dt: float, tracked: WandState | None) -> DriverStep:
        rotor = math.fmod(2 * math.pi * self.rotor_hz * t, 2 * math.pi)
        pose = HelicopterPose(self.hover, -math.pi / 2, rotor)  # nose toward the viewer
        return DriverStep(SceneFrame(helicopter=pose), tracked or WandState())

    def encode(self, frame: SceneFrame) -> tuple[float, ...]:
        pose = frame.helicopter
        return () if pose is None else float32((*pose.position, pose.yaw, pose.rotor_angle))

    def decode(self, params: Sequence[float]) -> SceneFrame:
        if not params:
            return SceneFrame()
        if len(params) != POSE_PARAMS:
            raise ProtocolError("bad-params", f"a still scene's frame has {POSE_PARAMS} "
                                              f"parameters (a pose) or none, got {len(params)}")
        x, y, z, yaw, rotor = params
        return SceneFrame(helicopter=HelicopterPose((x, y, z), yaw, rotor))
