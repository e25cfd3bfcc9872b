"""A scene whose field is a time series: its own driver's frame, plus where the field stands.

The master's clock places each stage of the frame's step between two snapshots
(`cavesim.core.fields.snapshot_time`); those six float32 values follow the scene driver's own
parameters in the frame message, and every node decodes them from there.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

from cavesim.core.drivers.scene_driver import DriverStep, SceneDriver
from cavesim.core.errors import ProtocolError
from cavesim.core.fields.snapshot_time import (
    FIELD_TIME_PARAMS,
    FIRST_SNAPSHOT,
    FieldTime,
    field_time_at,
)
from cavesim.core.scene_frame import SceneFrame
from cavesim.core.wire.payloads.poses import WandState


@dataclass(frozen=True)
class FieldClock:
    scene_driver: SceneDriver  # what the scene itself does each frame
    times: tuple[float, ...]  # the field's snapshot times, s from the run's start

    def advance(self, t: float, dt: float, tracked: WandState | None) -> DriverStep:
        step = self.scene_driver.advance(t, dt, tracked)
        frame = dataclasses.replace(step.frame, field_time=field_time_at(self.times, t, dt))
        return dataclasses.replace(step, frame=frame)

    def encode(self, frame: SceneFrame) -> tuple[float, ...]:
        return (*self.scene_driver.encode(frame), *(frame.field_time or FIRST_SNAPSHOT).encode())

    def decode(self, params: Sequence[float]) -> SceneFrame:
        if len(params) < FIELD_TIME_PARAMS:
            raise ProtocolError("bad-params", f"a frame of a time-series field ends in "
                                              f"{FIELD_TIME_PARAMS} field time parameters, got "
                                              f"{len(params)} parameters in all")
        own, field_time = params[:-FIELD_TIME_PARAMS], params[-FIELD_TIME_PARAMS:]
        frame = self.scene_driver.decode(own)
        return dataclasses.replace(frame, field_time=FieldTime.decode(field_time,
                                                                      len(self.times)))
