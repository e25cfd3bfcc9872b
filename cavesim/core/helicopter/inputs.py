"""A helicopter scene's per-frame inputs, from the frame's rotor (its scene driver's).

The same float32 values feed the GPU uniforms and the numpy twin: the rotor hub and
induced velocity of the downwash, and per emitter a rate factor and an emission origin
(saltation and the point below the hub for emitters that follow the helicopter; 1 and 0
for the others).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cavesim.core.helicopter.flight import ground_height
from cavesim.core.scene.model import Scene
from cavesim.core.scene_frame import SceneFrame


@dataclass(frozen=True)
class FrameRotor:
    hub: np.ndarray  # (3,) float32
    induced_velocity: np.float32
    rate_factors: np.ndarray  # (E,) float32
    origins: np.ndarray  # (E, 3) float32


class RotorInputs:
    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.followers = np.array([e.follow_helicopter for e in scene.emitters], dtype=bool)
        self.ground = np.float32(ground_height(scene))

    def read(self, frame: SceneFrame) -> FrameRotor:
        """The frame's rotor as float32 arrays; ValueError if the frame has none."""
        rotor = frame.rotor
        if rotor is None or len(rotor.emission_factors) != self.followers.sum():
            raise ValueError(f"a helicopter scene steps with a rotor frame of "
                             f"{int(self.followers.sum())} emission factors, got {rotor}")
        hub = np.array(rotor.hub, dtype=np.float32)
        factors = np.ones(len(self.followers), dtype=np.float32)
        factors[self.followers] = rotor.emission_factors
        origins = np.zeros((len(self.followers), 3), dtype=np.float32)
        origins[self.followers] = (hub[0], hub[1], self.ground)
        return FrameRotor(hub, np.float32(rotor.induced_velocity), factors, origins)
