"""A scene with nothing moving in it: every frame is the same, and nothing is drawn but
the ground and the particles (a helicopter only where the scene has one, its own driver).

Its frame has no parameters on the wire.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from cavesim.core.drivers.scene_driver import DriverStep
from cavesim.core.errors import ProtocolError
from cavesim.core.scene_frame import NOTHING_MOVES, SceneFrame
from cavesim.core.wire.payloads.poses import WandState


@dataclass(frozen=True)
class StillDriver:
    def advance(self, t: float, dt: float, tracked: WandState | None) -> DriverStep:
        return DriverStep(NOTHING_MOVES, tracked or WandState())

    def encode(self, frame: SceneFrame) -> tuple[float, ...]:
        return ()

    def decode(self, params: Sequence[float]) -> SceneFrame:
        if params:
            raise ProtocolError("bad-params", f"a still scene's frame has no parameters, "
                                              f"got {len(params)}")
        return NOTHING_MOVES
