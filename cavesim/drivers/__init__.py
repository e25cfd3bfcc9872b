"""Scene drivers: what changes a scene over time, made once a frame on the master.

One module per scene kind. A driver `advance`s the scene from the clock and the tracked
wand (or its own script) to the frame's `SceneFrame`, `encode`s that into the frame
message's float32 parameters, and on every node `decode`s them back, so the master never
branches on the scene kind and no node derives a value another way (determinism rule 1).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from cavesim.drivers.frame import HelicopterPose, RotorFrame, SceneFrame
from cavesim.scene.model import Scene
from cavesim.wire.messages import WandState


@dataclass(frozen=True)
class FlightSample:
    """One frame of a helicopter scene for the run's report: time, the skids' altitude
    above the ground, rotor speed (fraction of hover), induced velocity (m/s), emission
    rate (particles/s)."""

    t: float
    altitude: float
    rotor_speed: float
    induced_velocity: float
    emission_rate: float


@dataclass(frozen=True)
class DriverStep:
    frame: SceneFrame
    wand: WandState  # the wand the frame carries: the tracked one, or the script's
    clamped: bool = False  # a tracked wand position was pulled back into reach
    flight: FlightSample | None = None


class SceneDriver(Protocol):
    def advance(self, t: float, dt: float, tracked: WandState | None) -> DriverStep:
        """The scene at time t after a step of dt; `tracked` is None when no tracker spoke."""

    def encode(self, frame: SceneFrame) -> tuple[float, ...]:
        """The frame as the message's parameters (float32 values)."""

    def decode(self, params: Sequence[float]) -> SceneFrame:
        """The frame from a message's parameters (ProtocolError if they do not fit)."""


def driver_for(scene: Scene) -> SceneDriver:
    """The driver of `scene`'s kind."""
    from cavesim.drivers.helicopter import HelicopterDriver
    from cavesim.drivers.still import StillDriver

    return HelicopterDriver(scene) if scene.helicopter is not None else StillDriver()


__all__ = ["DriverStep", "FlightSample", "HelicopterPose", "RotorFrame", "SceneDriver",
           "SceneFrame", "driver_for"]
