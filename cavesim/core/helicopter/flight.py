"""Flying the helicopter with the wand: the master's side, in float64, once per frame.

Wand position steers (the hub goes toward wand_origin + wand_scale * wand position, with
a first-order lag, never below its landing height) and its heading turns the nose; wand
tilt sets the rotor speed, as in Smith et al. (level = hover speed, +30 degrees = 25%
faster). Without a tracker the scene's timeline plays the wand.
"""

from __future__ import annotations

import math

import numpy as np

from cavesim.core.features.collision import CollisionKind
from cavesim.core.helicopter.downwash import friction_velocity
from cavesim.core.helicopter.rotor import induced_velocity, saltation_factor
from cavesim.core.limits import ROTOR_SPEED_RANGE
from cavesim.core.scene.model import Helicopter, Scene, WandKey
from cavesim.core.scene_frame import HelicopterPose, RotorFrame, SceneFrame

TILT_GAIN = 0.25 / 30.0  # rotor speed per degree of tilt
WAND_LIMIT = 50.0  # m from the room's origin: farther is a tracker fault, not a gesture


def ground_height(scene: Scene) -> float:
    """The plane the helicopter lands on (a height field's lowest point counts as 0)."""
    c = scene.collision
    return c.height if c is not None and c.kind is CollisionKind.PLANE else 0.0


def wand_at(timeline: tuple[WandKey, ...], t: float) -> tuple[np.ndarray, float]:
    """The scripted wand (position, tilt in degrees) at time t, linear between keys."""
    if not timeline:
        return np.zeros(3), 0.0
    times = [k.t for k in timeline]
    positions = np.array([k.position for k in timeline])
    tilts = [k.tilt for k in timeline]
    position = np.array([np.interp(t, times, positions[:, i]) for i in range(3)])
    return position, float(np.interp(t, times, tilts))


def clamp_wand(position) -> tuple[tuple[float, float, float], bool]:
    """The wand position pulled within WAND_LIMIT of the room's origin, and whether it was."""
    clamped = tuple(min(max(float(x), -WAND_LIMIT), WAND_LIMIT) for x in position)
    return clamped, clamped != tuple(float(x) for x in position)


def pitch_quaternion(tilt: float) -> tuple[float, float, float, float]:
    """A wand orientation (xyzw) pitched by `tilt` degrees about the room's x axis."""
    half = math.radians(tilt) / 2
    return (math.sin(half), 0.0, 0.0, math.cos(half))


def heading_of(orientation_xyzw) -> float:
    """Where a wand points in the horizontal plane, radians: the azimuth of its forward
    axis (+y in its own frame), 0 along +y (into the CAVE, toward the front wall), positive
    turning toward -x (counter-clockwise seen from above)."""
    x, y, z, w = orientation_xyzw
    return math.atan2(2.0 * (w * z - x * y), 1.0 - 2.0 * (x * x + z * z))


def tilt_of(orientation_xyzw) -> float:
    """How far a wand points up, degrees: the elevation of its forward axis (nose up
    positive), whatever its heading and roll."""
    x, y, z, w = orientation_xyzw
    return math.degrees(math.asin(max(-1.0, min(1.0, 2.0 * (y * z + w * x)))))


class Flight:
    """The helicopter's state on the master; `advance` gives the frame's rotor and pose."""

    def __init__(self, scene: Scene) -> None:
        self.helicopter: Helicopter = scene.helicopter
        self.ground = ground_height(scene)
        self.followers = [e for e in scene.emitters if e.follow_helicopter]
        position, _ = wand_at(self.helicopter.timeline, 0.0)
        self.hub = self._target(position)
        self.rotor_angle = 0.0

    def _target(self, wand_position) -> np.ndarray:
        h = self.helicopter
        target = np.asarray(h.wand_origin) + h.wand_scale * np.asarray(wand_position, float)
        target[2] = max(target[2], self.ground + h.hub_height)  # on its skids at the lowest
        return target

    def advance(self, dt: float, wand_position, tilt: float, heading: float = 0.0) -> SceneFrame:
        """Move toward the wand's target, spin the rotor, and work out the downwash.

        `heading` (radians, 0 = the wand points at the front wall) turns the helicopter:
        its nose points back along the wand, toward the viewer, when the heading is 0.
        """
        h = self.helicopter
        gain = 1.0 - math.exp(-dt / h.response_time)
        self.hub = self.hub + gain * (self._target(wand_position) - self.hub)
        speed = min(max(1.0 + TILT_GAIN * tilt, ROTOR_SPEED_RANGE[0]), ROTOR_SPEED_RANGE[1])
        self.rotor_angle = math.fmod(self.rotor_angle + 2 * math.pi * h.rotor_hz * speed * dt,
                                     2 * math.pi)
        height = self.hub[2] - self.ground
        v_i = induced_velocity(h, speed, height)
        distances = [math.hypot(*e.position[:2]) for e in self.followers]
        factors = saltation_factor(h, friction_velocity(h, np.array(distances), height, v_i))
        hub = tuple(float(x) for x in self.hub)
        skids = (hub[0], hub[1], hub[2] - h.hub_height)
        pose = HelicopterPose(skids, heading - math.pi / 2, self.rotor_angle, h.hub_height,
                              h.rotor_radius)
        return SceneFrame(pose, RotorFrame(hub, v_i, speed, tuple(np.atleast_1d(factors).tolist())))
