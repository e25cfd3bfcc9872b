"""A helicopter scene: the wand flies the helicopter, whose downwash raises the dust.

On the master the wand (tracked, or the scene's timeline) steers `Flight`; the frame's
parameters are the rotor hub, yaw, rotor angle, induced velocity, rotor speed and one
saltation factor per following emitter (float32). A node reads the rotor from them and
draws the helicopter at the hub, on the scene's own hub height and rotor radius.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

from cavesim.core.drivers.scene_driver import DriverStep, FlightSample
from cavesim.core.errors import ProtocolError
from cavesim.core.helicopter.flight import (
    WAND_LIMIT,
    Flight,
    clamp_wand,
    heading_of,
    pitch_quaternion,
    tilt_of,
    wand_at,
)
from cavesim.core.scene.model import Scene
from cavesim.core.scene_frame import HelicopterPose, RotorFrame, SceneFrame, float32
from cavesim.core.wire.payloads.poses import WandState

log = logging.getLogger("cavesim.helicopter")
FIXED_PARAMS = 7  # hub (3), yaw, rotor angle, induced velocity, rotor speed; then factors


class HelicopterDriver:
    def __init__(self, scene: Scene) -> None:
        self.helicopter = scene.helicopter
        self.flight = Flight(scene)
        self.followers = self.flight.followers

    def advance(self, t: float, dt: float, tracked: WandState | None) -> DriverStep:
        clamped = False
        if tracked is not None:
            position, clamped = clamp_wand(tracked.position)
            if clamped:
                log.warning("wand position %s is outside +-%g m: clamped to %s",
                            tracked.position, WAND_LIMIT, position)
            tilt, heading, wand = tilt_of(tracked.orientation), \
                heading_of(tracked.orientation), tracked
        else:
            position, tilt = wand_at(self.helicopter.timeline, t)
            heading, wand = 0.0, WandState(tuple(position), pitch_quaternion(tilt))
        frame = self.flight.advance(dt, position, tilt, heading)
        return DriverStep(frame, wand, clamped, self._sample(t, frame.rotor))

    def _sample(self, t: float, rotor: RotorFrame) -> FlightSample:
        altitude = rotor.hub[2] - self.flight.ground - self.helicopter.hub_height
        rate = sum(e.rate * f for e, f in zip(self.followers, rotor.emission_factors,
                                               strict=True))
        return FlightSample(t, altitude, rotor.rotor_speed, rotor.induced_velocity, float(rate))

    def encode(self, frame: SceneFrame) -> tuple[float, ...]:
        pose, rotor = frame.helicopter, frame.rotor
        return float32((*rotor.hub, pose.yaw, pose.rotor_angle, rotor.induced_velocity,
                        rotor.rotor_speed, *rotor.emission_factors))

    def decode(self, params: Sequence[float]) -> SceneFrame:
        expected = FIXED_PARAMS + len(self.followers)
        if len(params) != expected:
            raise ProtocolError("bad-params", f"a helicopter frame has {expected} parameters "
                                              f"({len(self.followers)} following emitters), "
                                              f"got {len(params)}")
        p = tuple(params)
        h = self.helicopter
        pose = HelicopterPose((p[0], p[1], p[2] - h.hub_height), p[3], p[4], h.hub_height,
                              h.rotor_radius)
        return SceneFrame(pose, RotorFrame(p[0:3], p[5], p[6], p[FIXED_PARAMS:]))
