"""The head the master sends when no tracker has spoken: a gentle sway, so head-tracked
projection shows. Computed in float64 on the master alone; nodes get the float32 bits in
the frame message. (The scene's own state comes from its driver, `cavesim.core.drivers`.)"""

from __future__ import annotations

import math
from dataclasses import dataclass

from cavesim.core.wire import HeadState


@dataclass(frozen=True)
class ScriptedHead:
    eye_height: float = 1.7  # m above the CAVE floor
    sway: float = 0.15  # m, side to side
    sway_period: float = 8.0  # s

    def at(self, t: float) -> HeadState:
        x = self.sway * math.sin(2 * math.pi * t / self.sway_period)
        return HeadState((x, 0.0, self.eye_height), (0.0, 0.0, 0.0, 1.0))
