"""A `ParticleSystem` as the trajectory recorder's `ParticleStream`: what it reads back after
a step. Per frame: the emitter stream's counts (16 bytes an emitter) and the newborns'
records (40 bytes each); every K frames the tracked particles' records (40 bytes each, one
read per run of consecutive ones); the survivors' records only after a runaway drop."""

from __future__ import annotations

import numpy as np

from cavesim.core.digest.shape import PARTICLES
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.trajectories.stream import survivors_of
from cavesim.gpu.engine.particle_system import ParticleSystem


class EngineStream:
    """Reads of one engine's live stream; use after `step` (the reads wait for it)."""

    def __init__(self, system: ParticleSystem) -> None:
        self.system = system

    @property
    def live_count(self) -> int:
        return self.system.live_count

    def survivors(self) -> int:
        return survivors_of(self.system.live_count, self.system.dropped(),
                            self.system.read_emitters())

    def records(self, first: int, count: int) -> np.ndarray:
        return np.frombuffer(self.system.read_particle_chunk(first, count), PARTICLE_DTYPE)

    def picked(self, indices: np.ndarray) -> np.ndarray:
        return np.frombuffer(self.system.read_records(PARTICLES, indices), PARTICLE_DTYPE)
