"""What the master sends as head and scene parameters when nothing is tracked.

A gentle head sway (so head-tracked projection shows). A helicopter scene's parameters
come from its flight (the wand: tracked, or the scene's timeline); other scenes get a
helicopter hovering ahead with its rotor turning, to draw. Computed in float64 on the
master alone; nodes get the float32 bits in the frame message.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from cavesim.render.view import HelicopterPose
from cavesim.wire import HeadState


@dataclass(frozen=True)
class ScriptedView:
    eye_height: float = 1.7  # m above the CAVE floor
    sway: float = 0.15  # m, side to side
    sway_period: float = 8.0  # s
    hover: tuple[float, float, float] = (0.0, 9.0, 6.0)  # helicopter position, world m
    rotor_hz: float = 4.5  # main rotor turns per second

    def head(self, t: float) -> HeadState:
        x = self.sway * math.sin(2 * math.pi * t / self.sway_period)
        return HeadState((x, 0.0, self.eye_height), (0.0, 0.0, 0.0, 1.0))

    def hover_params(self, t: float) -> tuple[float, ...]:
        rotor = math.fmod(2 * math.pi * self.rotor_hz * t, 2 * math.pi)
        return HelicopterPose(self.hover, -math.pi / 2, rotor).to_params()  # nose toward us
