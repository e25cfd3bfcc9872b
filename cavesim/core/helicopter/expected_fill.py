"""How full a helicopter scene's pool gets: the particles its emitters are expected to have
alive, frame by frame over the scripted timeline, without the capacity.

Each frame's emission is the emitters' rates times the rotor's saltation factors (as the
node's emitter update gets them from the master's scene frame) times dt; each particle is
counted alive for its emitter's mean lifetime. Particles that leave the field box or settle
early are not subtracted, so this is an upper estimate: on the brownout demo it is 239,339
at the peak, where a run's report shows about 240,000 live. A scene author sizes the
capacity from it; tests/unit/test_scene_fill.py holds brownout_10m to filling its 10M.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.drivers import driver_for
from cavesim.core.emitters import EmitterTable
from cavesim.core.helicopter.inputs import RotorInputs
from cavesim.core.scene.model import Scene


def expected_live(scene: Scene, dt: float = 1 / 60) -> np.ndarray:
    """Expected live particles after each frame of the timeline (index k - 1 for frame k)."""
    if scene.helicopter is None or not scene.helicopter.timeline:
        raise ValueError(f"scene {scene.name!r} has no helicopter timeline to play")
    driver, table, rotor = driver_for(scene), EmitterTable.from_scene(scene), RotorInputs(scene)
    frames = round(scene.helicopter.timeline[-1].t / dt)
    lives = np.array([round(np.mean(e.lifetime) / dt) for e in scene.emitters])
    born = np.zeros((frames, len(lives)))
    for k in range(1, frames + 1):
        frame = driver.decode(driver.encode(driver.advance(k * dt, dt, None).frame))
        born[k - 1] = table.frame_rates(rotor.read(frame).rate_factors) * dt
    alive = np.cumsum(born, axis=0)
    for e, life in enumerate(lives):  # minus those born `life` frames or more before
        alive[life:, e] -= np.cumsum(born[:, e])[:frames - life]
    return alive.sum(axis=1)
