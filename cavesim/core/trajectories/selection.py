"""Which particles a run tracks: those whose birth index is a multiple of a stride S and
below N·S, with S = max(1, floor(B / N)) for B the births the scene is expected to make over
the run's planned frames: its emitters' rates × dt, times, in a helicopter scene, the rotor's
rate factors along the scripted flight (`expected_births`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cavesim.core.drivers import driver_for
from cavesim.core.emitters import EmitterTable
from cavesim.core.helicopter.inputs import RotorInputs
from cavesim.core.limits import MAX_TRAJECTORIES
from cavesim.core.scene.model import Scene


@dataclass(frozen=True)
class Selection:
    count: int  # N: at most this many particles are tracked
    stride: int  # S

    @classmethod
    def for_run(cls, scene: Scene, count: int, frames: int, dt: float) -> Selection:
        """N particles spread evenly over the births expected in `frames` frames of `dt`."""
        if not 1 <= count <= MAX_TRAJECTORIES:
            raise ValueError(f"trajectories must be in [1, {MAX_TRAJECTORIES}], got {count!r}")
        return cls(count, max(1, int(expected_births(scene, frames, dt) // count)))

    def tracked(self, ids: np.ndarray) -> np.ndarray:
        """Mask of `ids` (birth indices) that are tracked."""
        stride = np.uint64(self.stride)
        return (ids % stride == 0) & (ids < stride * np.uint64(self.count))


def expected_births(scene: Scene, frames: int, dt: float) -> float:
    """Births the scene's emitters are expected to make in `frames` frames of `dt`, the
    capacity aside: their rates, times a helicopter's rate factors frame by frame along its
    scripted flight (as `cavesim.core.helicopter.expected_fill` plays it; no wand), the last
    scripted frame's held past the timeline's end."""
    table = EmitterTable.from_scene(scene)
    if scene.helicopter is None:
        return float(table.rate.astype(np.float64).sum()) * frames * dt
    timeline = scene.helicopter.timeline
    scripted = min(frames, max(1, round(timeline[-1].t / dt) if timeline else 1))
    driver, rotor = driver_for(scene), RotorInputs(scene)
    births = rate = 0.0
    for k in range(1, scripted + 1):
        frame = driver.decode(driver.encode(driver.advance(k * dt, dt, None).frame))
        rate = float(table.frame_rates(rotor.read(frame).rate_factors).sum())
        births += rate * dt
    return births + rate * dt * (frames - scripted)
