"""Scene drivers: what changes a scene over time, made once a frame on the master.

One module per scene kind. A driver `advance`s the scene from the clock and the tracked
wand (or its own script) to the frame's `SceneFrame`, `encode`s that into the frame
message's float32 parameters, and on every node `decode`s them back, so the master never
branches on the scene kind and no node derives a value another way (determinism rule 1).
"""

from __future__ import annotations

from cavesim.core.drivers.field_clock import FieldClock
from cavesim.core.drivers.helicopter import HelicopterDriver
from cavesim.core.drivers.scene_driver import DriverStep, FlightSample, SceneDriver
from cavesim.core.drivers.still import StillDriver
from cavesim.core.scene.model import Scene
from cavesim.core.scene_frame import HelicopterPose, RotorFrame, SceneFrame


def driver_for(scene: Scene) -> SceneDriver:
    """The driver of `scene`'s kind, with the field's clock where its field is a time series."""
    driver = HelicopterDriver(scene) if scene.helicopter is not None else StillDriver()
    if scene.field is not None and scene.field.times is not None:
        return FieldClock(driver, scene.field.times)
    return driver


__all__ = ["DriverStep", "FieldClock", "FlightSample", "HelicopterDriver", "HelicopterPose",
           "RotorFrame", "SceneDriver", "SceneFrame", "StillDriver", "driver_for"]
