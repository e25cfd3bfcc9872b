"""What a scene driver is and what one step of it gives the master."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from cavesim.core.scene_frame import SceneFrame
from cavesim.core.wire.payloads.poses import WandState


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
